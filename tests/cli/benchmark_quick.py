#!/usr/bin/python3
"""cli.benchmark_quick: scripts/benchmark.py --quick (Setup II full 2D at 10 and 5 mm to 0.1 s)
makes its table, and the table says what the runs' summary.json say: steps, status and the
Krylov counts are copied, the floor is positive and below the run's own time spent in the
momentum and pressure phases plus everything else (a run does at least one pressure and one
momentum solve per step on at least its material cells, so wall / floor must exceed 1 unless
the floor is mis-timed or mis-scaled; measured 3.8x and 10.5x on this machine), and the peak
memory is the summary's; machine.json names the machine. Usage: benchmark_quick.py BUILD_DIR OUT_DIR"""
import json
import os
import subprocess
import sys

build, out = sys.argv[1], sys.argv[2]
root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
subprocess.run(["/usr/bin/python3", os.path.join(root, "scripts", "benchmark.py"), "--quick",
                "--fresh", "--build", build, "--out", out], check=True)
rows = json.load(open(os.path.join(out, "benchmark.json")))
assert [r["resolution_mm"] for r in rows] == [10.0, 5.0], rows
for r in rows:
    name = "setup2_%gmm_np1_r0" % r["resolution_mm"]
    s = json.load(open(os.path.join(out, name, "summary.json")))
    n = s["solver_statistics"]["ndam"]
    assert r["status"] == s["status"] == "completed", (r["status"], s["status"])
    assert r["steps"] == n["steps"] > 0
    assert r["krylov_p"] == n["pressure_krylov_iterations_per_solve"]
    assert r["krylov_m"] == n["momentum_krylov_iterations_per_solve"]
    assert r["wall_s"] == s["wall_time"]["total"]
    assert r["peak_MB"] * 1e6 == s["memory"]["peak_resident_bytes_rank0"] > 0
    assert r["material_cells"] > 0
    assert 0 < r["floor_s"] and r["multiple_of_floor"] > 1.0, r
    print("%g mm: %d steps, %.2f s, floor %.3f s (x %.1f)" % (
        r["resolution_mm"], r["steps"], r["wall_s"], r["floor_s"], r["multiple_of_floor"]))
# the machine the figures were taken on is reported with them (machine.json and the header)
m = json.load(open(os.path.join(out, "machine.json")))
assert m["cores"] == os.cpu_count() and m["cpu"] and m["load_average"] >= 0.0, m
assert m["load_average_end"] >= 0.0, m
print("benchmark report checks passed")
