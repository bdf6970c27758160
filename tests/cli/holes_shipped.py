#!/usr/bin/env python3
"""ctest: no hole in a deposit in the shipped free-surface scenes (issue 11 item 3).

Each scene given runs as shipped (its own grid, end time and output interval), with only its
Output->Directory moved under WORKDIR; then scripts/find_holes.py reads every output of its
fields.h5. A hole is an Empty cell enclosed by material, the bed or a wall (find_holes.py; the
same definition as ndam::enclosed_voids, which the coupled tests apply at every step). The
test fails when a run does not complete or any output of any 2D mesh holds a hole.

  holes_shipped.py GRANFLOW FIND_HOLES WORKDIR SCENE.xml ...
"""
import os
import re
import shutil
import subprocess
import sys

exe, finder, work, scenes = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4:]
failed = []
for scene in scenes:
    name = os.path.splitext(os.path.basename(scene))[0]
    d = os.path.abspath(os.path.join(work, name))
    shutil.rmtree(d, ignore_errors=True)
    os.makedirs(d)
    text = open(scene).read()
    text, n = re.subn(r'(<Parameter name="Directory" type="string" value=")[^"]*(")',
                      r"\g<1>%s\g<2>" % os.path.join(d, "out"), text)
    if n != 1:
        sys.exit(f"{scene}: no Output->Directory to move")
    copy = os.path.join(d, "scene.xml")
    open(copy, "w").write(text)
    run = subprocess.run([exe, copy], capture_output=True, text=True)
    if run.returncode != 0:
        failed.append(f"{name}: exit {run.returncode}: {run.stderr.strip()[-300:]}")
        continue
    check = subprocess.run([sys.executable, finder, os.path.join(d, "out"), "--quiet"],
                           capture_output=True, text=True)
    print(f"{name}: {check.stdout.strip()}")
    if check.returncode != 0:
        failed.append(f"{name}: {check.stdout.strip()} {check.stderr.strip()}")
if failed:
    print("FAIL:\n  " + "\n  ".join(failed))
    sys.exit(1)
print(f"no hole in any output of {len(scenes)} scenes")
