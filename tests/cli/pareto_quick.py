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
                    "--quick", "--times", "0.4", "0.6"], stdout=subprocess.PIPE,
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
    cpu = s.get("cpu_time", {}).get("process_seconds")
    if cpu is None or abs(float(r["cpu_seconds"]) - cpu) > 1e-9 or not cpu > 0.0:
        bad.append(f"{r['method']} {r['cell_mm']}: CPU time missing or differs from its summary.json")
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
if bad:
    sys.exit("\n".join(bad))
print("pareto report consistent:", len(rows), "rows")
