#!/usr/bin/env python3
"""ctest: no hole in a deposit in the shipped free-surface scenes (issue 11 item 3).

Each scene given runs as shipped (its own grid, end time and output interval), with only its
Output->Directory moved under WORKDIR; then scripts/find_holes.py reads every output of its
fields.h5. A hole is an Empty cell enclosed by material, the bed or a wall (find_holes.py; the
same definition as ndam::enclosed_voids, which the coupled tests apply at every step). The
test fails when a run does not complete or any output of any 2D mesh holds a hole.

Before that verdict counts, the finder must find a hole where there is one: in a copy of the
first scene's output (positive_control), one cell of the last snapshot's deposit, with material
on its four sides, is made Empty (h5py), and find_holes.py must report exactly that cell at its
coordinates; then the column above it is emptied to the box's top, which opens the void to the
atmosphere, and it must report none. Without this a reader that lost the cells (a changed flag
encoding, rows and columns swapped, a parse that drops values) would report "0 hole cells" for
every scene and the test would pass (an audit of the suite, session 44).

  holes_shipped.py GRANFLOW FIND_HOLES WORKDIR SCENE.xml ...
"""
import glob
import os
import re
import shutil
import subprocess
import sys

EMPTY, FLUID = 3, 1


def positive_control(finder, out, work):
    """The finder on a copy of `out` with a hole cut into the last snapshot: a list of failures."""
    import h5py  # python3-h5py, installed by scripts/install-deps.sh
    d = os.path.join(work, "positive_control")
    shutil.rmtree(d, ignore_errors=True)
    shutil.copytree(out, d)
    last = sorted(glob.glob(os.path.join(d, "fields.h5.d", "step_*.h5")))[-1]
    with h5py.File(last, "r+") as f:
        mesh = f["ndam"]
        flag = mesh["flag"][:]  # z-major: flag[k, i]
        nz, nx = flag.shape
        cell = next(((k, i) for i in range(nx - 2, 0, -1) for k in range(1, nz - 1)
                     if flag[k, i] == FLUID and flag[k - 1, i] == FLUID and flag[k + 1, i] == FLUID
                     and flag[k, i - 1] == FLUID and flag[k, i + 1] == FLUID), None)
        if cell is None:
            return [f"positive control: no cell with material on four sides in {last}"]
        k, i = cell
        flag[k, i] = EMPTY
        mesh["flag"][...] = flag
        x, z = mesh["x_nodes"][:], mesh["z_nodes"][:]
    where = f"x = {0.5 * (x[i] + x[i + 1]):.4f} m, z = {0.5 * (z[k] + z[k + 1]):.4f} m"
    failures = []
    cut = subprocess.run([sys.executable, finder, d, "--quiet"], capture_output=True, text=True)
    print(f"positive control, one cell emptied at {where}: exit {cut.returncode}; "
          f"{cut.stdout.strip()}")
    if cut.returncode != 1 or where not in cut.stdout or " 1 hole cells in 1 of " not in cut.stdout:
        failures.append(f"positive control: the emptied cell at {where} was not reported as the "
                        f"one hole (exit {cut.returncode}): {cut.stdout.strip()} {cut.stderr.strip()}")
    with h5py.File(last, "r+") as f:
        flag = f["ndam/flag"][:]
        flag[k:, i] = EMPTY  # a shaft from the emptied cell to the top row: open to the air
        f["ndam/flag"][...] = flag
    shaft = subprocess.run([sys.executable, finder, d, "--quiet"], capture_output=True, text=True)
    print(f"negative control, that column emptied to the top: exit {shaft.returncode}; "
          f"{shaft.stdout.strip()}")
    if shaft.returncode != 0:
        failures.append(f"negative control: an Empty shaft open to the top reported as a hole "
                        f"(exit {shaft.returncode}): {shaft.stdout.strip()} {shaft.stderr.strip()}")
    return failures



exe, finder, work, scenes = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4:]
failed = []
controlled = False
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
    if not controlled and check.returncode == 0:
        failed += positive_control(finder, os.path.join(d, "out"), work)
        controlled = True
if not controlled:
    failed.append("no scene's output could carry the finder's positive control")
if failed:
    print("FAIL:\n  " + "\n  ".join(failed))
    sys.exit(1)
print(f"no hole in any output of {len(scenes)} scenes")
