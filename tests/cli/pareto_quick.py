#!/usr/bin/env python3
"""ctest: the error-against-run-time report (scripts/pareto.py --quick) is produced and its
numbers are the runs' own: every row's wall time and steps equal its summary.json, the
reference row has zero error, every other error is finite, and the order of the methods is
the physical one at 0.4 s (before the impact): the DAM alone is further from full 2D than the
coupled runs and the coarse full 2D run (measured: u_mean L2 0.16 against 0.02-0.03).

  pareto_quick.py BUILD OUTDIR
"""
import csv
import json
import math
import os
import subprocess
import sys

build, out = sys.argv[1], sys.argv[2]
root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
p = subprocess.run([sys.executable, os.path.join(root, "scripts", "pareto.py"), build, out,
                    "--quick", "--times", "0.4", "0.5"], stdout=subprocess.PIPE,
                   stderr=subprocess.STDOUT, text=True)
print(p.stdout[-3000:])
if p.returncode != 0:
    sys.exit("pareto.py failed")
for f in ("pareto.csv", "pareto.md", "pareto.png"):
    if not os.path.exists(os.path.join(out, f)) or os.path.getsize(os.path.join(out, f)) == 0:
        sys.exit(f"no {f}")
rows = list(csv.DictReader(open(os.path.join(out, "pareto.csv"))))
methods = {(r["method"], float(r["cell_mm"])) for r in rows}
for m in ("full", "static", "dynamic", "dam"):
    for c in (10.0, 5.0):
        if (m, c) not in methods:
            sys.exit(f"no row for {m} at {c} mm")
bad = []
for r in rows:
    s = json.load(open(r["summary"]))
    if abs(float(r["wall_seconds"]) - s["wall_time"]["total"]) > 1e-9 or int(r["steps"]) != s["steps"]:
        bad.append(f"{r['method']} {r['cell_mm']}: wall time / steps differ from its summary.json")
    # the cost is the run's own CPU time, without the process's start-up (cpu_time.run_seconds)
    cpu = s.get("cpu_time", {}).get("run_seconds")
    if cpu is None or abs(float(r["cpu_seconds"]) - cpu) > 1e-9 or not cpu > 0.0:
        bad.append(f"{r['method']} {r['cell_mm']}: CPU time missing or differs from its summary.json")
    if not cpu < s["cpu_time"]["process_seconds"]:
        bad.append(f"{r['method']} {r['cell_mm']}: the run's CPU time is not below the process's")
    for k in ("h_L2", "u_L2", "h_max", "u_max"):
        if not math.isfinite(float(r[k])):
            bad.append(f"{r['method']} {r['cell_mm']}: {k} not finite")
    if r["method"] == "full" and float(r["cell_mm"]) == 5.0 and float(r["u_L2"]) != 0.0:
        bad.append("the reference row has a non-zero error")
at = {(r["method"], float(r["cell_mm"])): float(r["u_L2"]) for r in rows if abs(float(r["t"]) - 0.4) < 1e-9}
for m in ("static", "dynamic"):
    if not at[("dam", 10.0)] > at[(m, 10.0)]:
        bad.append(f"u_mean L2 at 0.4 s: the DAM alone ({at[('dam', 10.0)]:.3f}) is not further from full 2D than {m} ({at[(m, 10.0)]:.3f})")
if not at[("dam", 10.0)] > at[("full", 10.0)]:
    bad.append("the DAM alone is not further from full 2D than the coarse full 2D run")
# every method runs to the same end time (the DAM's scene runs to 1.5 s on its own, and its rows'
# steps and times were those of a 1.5 s run in a table at 0.75 s; an independent run)
for r in rows:
    if abs(json.load(open(r["summary"]))["final_time"] - 0.5) > 1e-9:
        bad.append(f"{r['method']} {r['cell_mm']}: not run to the quick matrix's 0.5 s")
if bad:
    sys.exit("\n".join(bad))
print("pareto report consistent:", len(rows), "rows")

# A run directory that is not what the report would make is run again, not taken (an
# independent run: a profiles.csv cut inside its last output gave u_mean L2 0.008 against 0.067,
# and another method's directory copied into a slot its figures, both with exit 0): cut the
# static 5 mm run's profiles.csv, put the DAM's 10 mm run in the dynamic 10 mm slot, break the
# full 10 mm run's summary.json; the report must name each, run them again and give the same
# table.
import shutil
first = open(os.path.join(out, "pareto.csv")).read()
prof = os.path.join(out, "static_5mm", "profiles.csv")
lines = open(prof).read().splitlines(True)
open(prof, "w").writelines(lines[:-100])
shutil.rmtree(os.path.join(out, "dynamic_10mm"))
shutil.copytree(os.path.join(out, "dam_10mm"), os.path.join(out, "dynamic_10mm"))
open(os.path.join(out, "full_10mm", "summary.json"), "w").write('{"status": "compl')
p = subprocess.run([sys.executable, os.path.join(root, "scripts", "pareto.py"), build, out,
                    "--quick", "--times", "0.4", "0.5"], stdout=subprocess.PIPE,
                   stderr=subprocess.STDOUT, text=True)
print(p.stdout[:1500])
if p.returncode != 0:
    sys.exit("pareto.py failed on the damaged directory")
for name, why in (("static_5mm", "ends before the channel's end at t = 0.5 s"), ("dynamic_10mm", "records Name = setup2_dam"),
                  ("full_10mm", "summary.json unreadable")):
    if not any(f"{name}: not reused (" in l and why in l for l in p.stdout.splitlines()):
        sys.exit(f"{name}: not named as run again ({why})")
keys = ("method", "cell_mm", "t", "h_L2", "h_max", "u_L2", "u_max", "wall_depth", "steps")
strip = lambda text: [tuple(r[k] for k in keys) for r in csv.DictReader(text.splitlines())]
if strip(open(os.path.join(out, "pareto.csv")).read()) != strip(first):  # (not the timings)
    sys.exit("the table after the re-runs differs from the first one")
print("damaged runs named, run again, the same table")
