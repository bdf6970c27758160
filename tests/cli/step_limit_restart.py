#!/usr/bin/env python3
"""ctest: a run stopped by 'Max steps' keeps the stopped state in checkpoint.h5, and a restart
from it with a larger 'Max steps' continues it (an independent run: the checkpoint held the last
output's state, step 86 at 0.35 s, while the run stopped at step 100, 0.385 s, so a restart
repeated 14 steps and, with the same 'Max steps', stopped again).

  step_limit_restart.py GRANFLOW WORKDIR setup2_dynamic.xml

Setup II with the dynamic layout at 10 mm (a 2D box, the DAM and the domain manager's state in
the checkpoint) to 0.5 s, outputs every 0.1 s: a straight run; a run with 'Max steps' = half
the straight run's steps, which stops between two outputs (exit 5, status step_limit, the
checkpoint's time the summary's final_time); a restart from its checkpoint with 'Max steps'
above the straight run's. The restart continues the stopped state: it takes the straight run's
steps, and its fields.h5 snapshots at the outputs after the stop (0.4 and 0.5 s, every field at
full double precision) equal the straight run's to 1e-9 (their scale is 1: m/s, m, m^2/s^2).
Not exactly: the straight run went through the stop with the lagged pressure preconditioner of
up to 10 steps before it, the restart builds a fresh one (a stop between outputs is no restart
point of the straight run; an output is, Stepper::restart_point, and there restarts are exact:
cli.restart_exact_*), so the two solve the same systems to the Krylov tolerance (relative 1e-10)
with different iterates; measured by an independent run: 9e-16 in u, 1.3e-15 in p.
"""
import json
import os
import shutil
import subprocess
import sys

import h5py

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from scene_edit import edit  # noqa: E402
from fields_compare import max_difference  # noqa: E402

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
    after = [t for t in (0.3, 0.4, 0.5) if t > stopped["final_time"]]
    if len(after) < 2:
        failed.append(f"the step limit stopped the run at {stopped['final_time']} s, after the "
                      "outputs the test compares")
    worst, where = max_difference(os.path.join(work, "straight", "fields.h5"),
                                  os.path.join(work, "second", "fields.h5"), after)
    print(f"fields.h5 at {after} s: largest difference from the straight run {worst} ({where})")
    if worst is None or worst > 1e-9:
        failed.append(f"the restart differs from the straight run by {worst} ({where})")
    s2 = second["steps"]
    print(f"restart: {s2} steps (straight {steps})")
    if s2 != steps:
        failed.append(f"the restart took {s2} steps in all, the straight run {steps}")
if failed:
    sys.exit("\n".join(failed))
print("ok")
