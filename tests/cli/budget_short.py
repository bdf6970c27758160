#!/usr/bin/env python3
"""ctest: `granflow-study budget` on a channel shorter than its default stretch's start (0.3 m).
An independent tester found the default stretch [0.3, 1.2] m printing rows beyond a 1 m
channel's end and "-nan" in the % column of dry bins; cut at L, a 0.25 m channel then left
[0.3, 0.25] and was refused. Asserted: exit 0, the whole channel as the stretch ([0.000, 0.250]
m, 25 columns), no nan anywhere in the report, and a stretch beyond L refused with exit 2.
A second tester (2026-12-06) gave `--dam` a DAM run of another channel (Setup II's 1 m beside
Setup I's 1.5 m): exit 0 and a DAM budget over the stretch cut at 1 m. Asserted: a DAM run of a
0.5 m channel beside this 0.25 m run is refused with exit 2, naming Channel->Length.

  budget_short.py BUILD OUTDIR INPUTS
"""
import os
import re
import subprocess
import sys
import xml.etree.ElementTree as ET

build, out, inputs = sys.argv[1], sys.argv[2], sys.argv[3]
os.makedirs(out, exist_ok=True)


def make_run(base, name, settings):
    """Runs inputs/BASE with the (path, type, value) settings into OUT/NAME; returns its dir."""
    tree = ET.parse(os.path.join(inputs, base))
    root = tree.getroot()
    for path, typ, value in settings + [(["Output", "Directory"], "string",
                                         os.path.join(out, name))]:
        node = root
        for lst in path[:-1]:
            node = node.find(f"ParameterList[@name='{lst}']")
        e = node.find(f"Parameter[@name='{path[-1]}']")
        if e is None:
            e = ET.SubElement(node, "Parameter", name=path[-1])
        e.set("type", typ)
        e.set("value", value)
    scene = os.path.join(out, name + ".xml")
    tree.write(scene)
    run = subprocess.run([os.path.join(build, "apps", "granflow"), "--overwrite", scene],
                         capture_output=True, text=True)
    if run.returncode != 0:
        sys.exit(f"granflow ({name}) failed:\n" + run.stderr[-2000:])
    return os.path.join(out, name)


short = [(["Time", "End time"], "double", "0.2"), (["Output", "Interval"], "double", "0.05")]
make_run("setup2_ndam.xml", "run", [(["Channel", "Length"], "double", "0.25"),
                                    (["N-DAM", "Cells x"], "int", "25"),
                                    (["N-DAM", "Cells z"], "int", "15")] + short)
study = os.path.join(build, "apps", "granflow-study")
b = subprocess.run([study, "budget", os.path.join(out, "run")], capture_output=True, text=True)
print(b.stdout[-3000:], b.stderr[-1000:])
if b.returncode != 0:
    sys.exit(f"budget exit {b.returncode}")
if "nan" in b.stdout.lower():
    sys.exit("nan in the report")
if not re.search(r"stretch \[0\.000, 0\.250\] m \(25 columns\)", b.stdout):
    sys.exit("the default stretch is not the whole 0.25 m channel")
bad = subprocess.run([study, "budget", os.path.join(out, "run"), "--stretch", "0.1", "0.5"],
                     capture_output=True, text=True)
if bad.returncode == 0 or "0 <= XA < XB <= L = 0.25 m" not in bad.stderr:
    sys.exit(f"a stretch beyond L was not refused: exit {bad.returncode}, {bad.stderr}")
# a DAM run of another channel (0.5 m) given as --dam
make_run("setup2_dam.xml", "dam_other", [(["Channel", "Length"], "double", "0.5"),
                                         (["DAM", "Cells"], "int", "50")] + short)
other = subprocess.run([study, "budget", os.path.join(out, "run"), "--dam",
                        os.path.join(out, "dam_other")], capture_output=True, text=True)
if other.returncode != 2 or "run of another channel: Channel->Length = 0.5 against 0.25" \
        not in other.stderr:
    sys.exit(f"a DAM run of another channel was not refused: exit {other.returncode}, "
             f"{other.stdout[-500:]} {other.stderr[-500:]}")
print("budget on a 0.25 m channel: ok")
