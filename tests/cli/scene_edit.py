"""Shared by the ctest scripts here: set one parameter of a scene's XML text."""
import re
import sys


def edit(text, name, typ, value):
    """The text with the value of every <Parameter name=NAME type=TYP> set to VALUE; exits when
    the scene has no such parameter (a test that edits nothing would test the shipped scene)."""
    new, n = re.subn(r'(<Parameter name="%s" type="%s" value=")[^"]*(")' % (re.escape(name), typ),
                     r"\g<1>%s\g<2>" % value, text)
    if n == 0:
        sys.exit(f"{name} not in the scene")
    return new
