#!/usr/bin/env python3
"""ctest: a run stopped by 'Max steps' keeps the stopped state in checkpoint.h5, and a restart
from it with a larger 'Max steps' continues bit for bit (an independent run: the checkpoint held
the last output's state, step 86 at 0.35 s, while the run stopped at step 100, 0.385 s, so a
restart repeated 14 steps and, with the same 'Max steps', stopped again).

  step_limit_restart.py GRANFLOW WORKDIR setup2_dynamic.xml

Setup II with the dynamic layout at 10 mm (a 2D box, the DAM and the domain manager's state in
the checkpoint) to 0.5 s, outputs every 0.1 s: a straight run; a run with 'Max steps' = half
the straight run's steps, chosen off the output times (exit 5, status step_limit, the
checkpoint's time the summary's final_time and the step count the limit); a restart from its
checkpoint with 'Max steps' above the straight run's. The restarted run's profiles.csv rows at
the output times after the stop (0.4 and 0.5 s) must equal the straight run's byte for byte
(round-trip precision: the last bit of any h or u_mean shows), and its step count the straight
run's.
"""
import csv
import json
import os
import shutil
import subprocess
import sys

import h5py

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from scene_edit import edit  # noqa: E402

exe, work, scene = sys.argv[1], sys.argv[2], sys.argv[3]
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
text = open(scene).read()
for name, typ, value in (("Cells x", "int", 100), ("Cells z", "int", 30), ("Height", "double", 0.3),
                         ("Cells", "int", 100), ("Interval", "double", 0.1),
                         ("End time", "double", 0.5)):
    text = edit(text, name, typ, value)


def run(name, max_steps=None, restart=None):
    t = edit(text, "Directory", "string", name)
    extra = ""
    if max_steps is not None:
        t = t.replace('<Parameter name="End time" type="double" value="0.5"/>',
                      '<Parameter name="End time" type="double" value="0.5"/>\n    '
                      '<Parameter name="Max steps" type="int" value="%d"/>' % max_steps)
    if restart:
        t = t.replace('<Parameter name="Interval" type="double" value="0.1"/>',
                      '<Parameter name="Interval" type="double" value="0.1"/>\n    '
                      '<Parameter name="Restart from" type="string" value="%s"/>' % restart)
    open(os.path.join(work, name + ".xml"), "w").write(t)
    p = subprocess.run([exe, name + ".xml"], cwd=work, stdout=subprocess.PIPE,
                       stderr=subprocess.STDOUT, text=True)
    return p.returncode, p.stdout, json.load(open(os.path.join(work, name, "summary.json")))


failed = []
code, out, straight = run("straight")
if code != 0:
    sys.exit(f"the straight run exited with {code}: {out[-500:]}")
steps = straight["steps"]
limit = steps // 2
code, out, stopped = run("stopped", max_steps=limit)
print(f"straight: {steps} steps; stopped at 'Max steps' = {limit}: exit {code}, "
      f"status {stopped.get('status')}, t = {stopped.get('final_time')}")
if code != 5 or stopped.get("status") != "step_limit":
    failed.append(f"the step-limited run: exit {code}, status {stopped.get('status')} "
                  f"(expected 5, step_limit): {out[-300:]}")
with h5py.File(os.path.join(work, "stopped", "checkpoint.h5"), "r") as f:
    ck_time = float(f["scalars"]["run:time"][()].ravel()[0])
print(f"checkpoint time {ck_time}, summary final_time {stopped.get('final_time')}")
if ck_time is None or abs(ck_time - stopped["final_time"]) > 1e-12:
    failed.append(f"checkpoint.h5 holds t = {ck_time}, the run stopped at {stopped.get('final_time')}")
if "checkpoint.h5 holds this state" not in stopped.get("reason", ""):
    failed.append(f"the summary's reason does not say where the state is: {stopped.get('reason')}")
code, out, second = run("second", max_steps=10 * steps, restart="stopped/checkpoint.h5")
if code != 0:
    failed.append(f"the restart exited with {code}: {out[-500:]}")
else:
    rows = lambda f, t: [r for r in csv.reader(open(os.path.join(work, f))) if r[0] == t]
    after = [t for t in ("0.3", "0.4", "0.5") if float(t) > stopped["final_time"]]
    if len(after) < 2:
        failed.append(f"the step limit stopped the run at {stopped['final_time']} s, after the "
                      "outputs the test compares")
    for t in after:
        a, b = rows("straight/profiles.csv", t), rows("second/profiles.csv", t)
        diff = sum(1 for x, y in zip(a, b) if x != y)
        print(f"t = {t} s: {len(a)} rows, {diff} differ")
        if not a or len(a) != len(b) or diff:
            failed.append(f"the restart differs from the straight run at t = {t} s ({diff} of {len(a)} rows)")
    s2 = second["steps"]
    print(f"restart: {s2} steps (straight {steps})")
    if s2 != steps:
        failed.append(f"the restart took {s2} steps in all, the straight run {steps}")
if failed:
    sys.exit("\n".join(failed))
print("ok")
