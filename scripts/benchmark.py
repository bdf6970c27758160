#!/usr/bin/python3
"""Speed benchmark of the full 2D model (issue 14 item 6; not a test: timings depend on the machine).

Runs Setup II in full 2D (inputs/setup2_ndam.xml, the shipped defaults) to t = 0.75 s at 5, 2.6
and 1.3 mm, one run at a time, and prints per resolution: wall time, per-phase seconds, steps,
Krylov iterations per solve, peak resident memory (and per material cell), and the run's time as
a multiple of the floor; then the momentum and pressure phases split into preconditioner setups,
Krylov iterations and the rest (assembly, copies). A header line describes the machine (CPU
model, cores, threads per core, memory, the load average at the start and the end; also
machine.json beside benchmark.json). With GRANFLOW=/path/to/other/granflow the same scenes also run through
that build, back to back with this one (ours, then the other, per resolution and repeat), and a
ratio column says how much faster this build is (median over the repeats).

The floor (what the issue measures against): one AMG-preconditioned pressure solve and one
momentum solve per step on the material cells only, timed with granflow-bench-ndam of the same
build on a cavity of n x n cells with n^2 = the run's mean number of material cells (Fluid and
Surface cells, from fields.h5 at every output) and the scene's momentum preconditioner; floor =
steps x (momentum + pressure seconds per step of the bench). The cavity's matrices are not the
deposit's (a Newtonian nu, a constant pressure matrix: no preconditioner setup per step), so the
floor is a lower bound of the kind the issue names, not an exact model of the run.

Usage:
  scripts/benchmark.py [--build build] [--out /tmp/granflow_benchmark] [--repeat 1]
                       [--resolutions 5,2.6,1.3] [--np 1] [--end-time 0.75] [--quick]
  GRANFLOW=/other/build/apps/granflow scripts/benchmark.py ...
--quick: 10 mm and 5 mm to t = 0.1 s (for the suite's check of the report, cli.benchmark_quick).
Runs already made are reused when their summary.json is complete and from the same binary
(--fresh to rerun).
"""
import argparse
import json
import math
import os
import re
import statistics
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
# Setup II's box: L = 1 m, Height 0.15 m (inputs/setup2_ndam.xml). Cells for dx = dz = 5, 2.6,
# 1.3 mm as in docs/validation.md (200 x 30, 384 x 58, 768 x 116) and 10 mm for --quick.
GRIDS = {"10": (100, 15), "5": (200, 30), "2.6": (384, 58), "1.3": (768, 116)}


def scene(out, name, nx, nz, end):
    text = open(os.path.join(ROOT, "inputs", "setup2_ndam.xml")).read()
    subs = [(r'(name="Cells x" type="int" value=")\d+', r"\g<1>%d" % nx),
            (r'(name="Cells z" type="int" value=")\d+', r"\g<1>%d" % nz),
            (r'(name="End time" type="double" value=")[^"]*', r"\g<1>%r" % end),
            (r'(name="Directory" type="string" value=")[^"]*', r"\g<1>" + os.path.join(out, name))]
    for pat, rep in subs:
        text, n = re.subn(pat, rep, text, count=1)
        if n != 1:
            sys.exit("benchmark: inputs/setup2_ndam.xml has no '%s'" % pat)
    path = os.path.join(out, name + ".xml")
    open(path, "w").write(text)
    return path


def run(exe, xml, rundir, np_, fresh):
    summ = os.path.join(rundir, "summary.json")
    stamp = "%s %d" % (exe, os.stat(exe).st_mtime_ns)  # which binary made the run
    if not fresh and os.path.exists(summ) and os.path.exists(rundir + ".exe"):
        s = json.load(open(summ))
        if s.get("status") == "completed" and open(rundir + ".exe").read() == stamp:
            return s
    cmd = [exe, xml, "--overwrite"]
    if np_ > 1:
        cmd = ["mpiexec", "--allow-run-as-root", "--oversubscribe", "-n", str(np_)] + cmd
    log = open(rundir + ".log", "w")
    rc = subprocess.call(cmd, stdout=log, stderr=subprocess.STDOUT)
    if not os.path.exists(summ):
        sys.exit("benchmark: %s wrote no summary.json (exit %d, log %s.log)" % (exe, rc, rundir))
    s = json.load(open(summ))
    open(rundir + ".exe", "w").write(stamp)
    return s


def material_cells(rundir):
    import h5py
    with h5py.File(os.path.join(rundir, "fields.h5"), "r") as f:
        counts = []
        for g in f:
            if "ndam" in f[g]:
                fl = f[g]["ndam"]["flag"][()]
                counts.append(int(((fl == 1) | (fl == 2)).sum()))  # Fluid, Surface (grid.hpp)
    return statistics.mean(counts)


def floor_per_step(bench, cells, prec, np_):
    n = max(8, int(round(math.sqrt(cells))))
    cmd = [bench, "--steps", "10", "--momentum-preconditioner", prec, str(n)]
    if np_ > 1:
        cmd = ["mpiexec", "--allow-run-as-root", "--oversubscribe", "-n", str(np_)] + cmd
    out = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
    row = [l for l in out.splitlines() if l.strip() and not l.startswith("#")][-1].split()
    # columns: cells unknowns | mom s/step us/unk its | p s/step us/unk its | step s
    return float(row[3]) + float(row[7])


def machine():
    """What the timings were taken on (the brief: report the machine with the figures): the CPU
    model, cores and threads per core from lscpu, the memory, the load average now, the host."""
    info = {"host": os.uname().nodename, "cpu": "?", "cores": os.cpu_count(), "threads_per_core": "?"}
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, check=True).stdout
        for line in out.splitlines():
            k, _, v = line.partition(":")
            if k.strip() == "Model name":
                info["cpu"] = v.strip()
            elif k.strip() == "Thread(s) per core":
                info["threads_per_core"] = v.strip()
    except (OSError, subprocess.CalledProcessError):
        pass
    try:
        kb = [l for l in open("/proc/meminfo") if l.startswith("MemTotal:")][0].split()[1]
        info["memory_GB"] = round(int(kb) / 1024 ** 2, 1)
    except (OSError, IndexError, ValueError):
        info["memory_GB"] = "?"
    info["load_average"] = os.getloadavg()[0]
    return info


def split(n):
    """The momentum and pressure phases split into preconditioner setups, Krylov iterations and
    the rest (assembly of matrix and right-hand side, copies), in seconds; None for a build whose
    summary has no Krylov seconds (before 2026-12-05)."""
    out = {}
    for ph in ("momentum", "pressure"):
        if ph + "_krylov_seconds" not in n:
            return None
        setup, krylov = n[ph + "_preconditioner_setup_seconds"], n[ph + "_krylov_seconds"]
        out[ph] = {"setup": setup, "krylov": krylov,
                   "rest": n["seconds"].get(ph, 0) - setup - krylov}
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--out", default="/tmp/granflow_benchmark")
    ap.add_argument("--resolutions", default="5,2.6,1.3")
    ap.add_argument("--np", type=int, default=1)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--end-time", type=float, default=0.75)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--fresh", action="store_true")
    ap.add_argument("--oversubscribe", action="store_true",
                    help="allow --np above the machine's cores (the timings then measure the "
                         "ranks' time sharing, not the code's parallel speed)")
    a = ap.parse_args()
    # a count below 1 has nothing to time (and a median of no runs is undefined)
    for name, value in (("--np", a.np), ("--repeat", a.repeat)):
        if value < 1:
            ap.error("%s = %d; allowed: an integer of at least 1" % (name, value))
    # more ranks than cores time the scheduler's sharing of a core between ranks: a speed-up
    # read from such a table would be the machine's, not the code's
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    if cores and a.np > cores and not a.oversubscribe:
        ap.error("--np = %d; allowed: at most the %d cores this process may use (or add "
                 "--oversubscribe to time shared cores anyway)" % (a.np, cores))
    if not (a.end_time > 0.0 and math.isfinite(a.end_time)):
        ap.error("--end-time = %g; allowed: a finite time above 0 s" % a.end_time)
    if a.quick:
        a.resolutions, a.end_time = "10,5", 0.1
    exe = os.path.abspath(os.path.join(a.build, "apps", "granflow"))
    bench = os.path.abspath(os.path.join(a.build, "apps", "granflow-bench-ndam"))
    other = os.environ.get("GRANFLOW")
    for e in [exe, bench] + ([other] if other else []):
        if not os.access(e, os.X_OK):
            sys.exit("benchmark: no executable %s" % e)
    os.makedirs(a.out, exist_ok=True)
    res = a.resolutions.split(",")
    for r in res:
        if r not in GRIDS:
            ap.error("--resolutions: '%s' is not one of %s" % (r, ", ".join(GRIDS)))
    before = machine()
    rows = []
    for r in res:
        nx, nz = GRIDS[r]
        walls, walls_other, s = [], [], None
        for q in range(a.repeat):
            name = "setup2_%smm_np%d_r%d" % (r, a.np, q)
            xml = scene(a.out, name, nx, nz, a.end_time)
            s = run(exe, xml, os.path.join(a.out, name), a.np, a.fresh)
            walls.append(s["wall_time"]["total"])
            if other:
                oname = name + "_other"
                oxml = scene(a.out, oname, nx, nz, a.end_time)
                so = run(other, oxml, os.path.join(a.out, oname), a.np, a.fresh)
                walls_other.append(so["wall_time"]["total"])
        rundir = os.path.join(a.out, "setup2_%smm_np%d_r0" % (r, a.np))
        n = s["solver_statistics"]["ndam"]
        cells = material_cells(rundir)
        # the scene's momentum preconditioner (the default when the scene does not set it)
        prec = s.get("parameters", {}).get("N-DAM", {}).get("Momentum solver", {}).get(
            "Preconditioner", "Ifpack2 RELAXATION")
        floor = n["steps"] * floor_per_step(bench, cells, prec, a.np) if cells > 0 else None
        peak = s["memory"]["peak_resident_bytes_rank0"]
        wall = statistics.median(walls)
        row = {"resolution_mm": float(r), "cells": "%d x %d" % (nx, nz), "np": a.np,
               "status": s["status"], "wall_s": wall, "steps": n["steps"],
               "seconds": n["seconds"], "krylov_p": n["pressure_krylov_iterations_per_solve"],
               "krylov_m": n["momentum_krylov_iterations_per_solve"],
               "split": split(n),
               "material_cells": cells, "peak_MB": peak / 1e6,
               # no material cell at any output (an end time before the gate's first marker
               # row, an independent run: a ZeroDivisionError): no figure per cell, no floor
               "bytes_per_material_cell": peak / cells if cells > 0 else None,
               "floor_s": floor if cells > 0 else None,
               "multiple_of_floor": wall / floor if cells > 0 else None}
        if other:
            row["other_wall_s"] = statistics.median(walls_other)
            row["speedup_vs_other"] = row["other_wall_s"] / wall
        rows.append(row)
    json.dump(rows, open(os.path.join(a.out, "benchmark.json"), "w"), indent=1)
    after = machine()
    before["load_average_end"] = after["load_average"]
    json.dump(before, open(os.path.join(a.out, "machine.json"), "w"), indent=1)
    hdr = ("| dx [mm] | cells | np | wall [s] | steps | momentum | pressure | markers | other | "
           "Krylov/solve p / m | material cells | peak [MB] | kB/material cell | floor [s] | "
           "x floor |" + (" other build [s] | speed-up |" if other else ""))
    print("# granflow benchmark: Setup II full 2D to t = %g s, %s, median of %d run(s)"
          % (a.end_time, exe, a.repeat))
    print("# machine: %s (%s), %s cores, %s thread(s) per core, %s GB; load average %.2f at the "
          "start, %.2f at the end (a busy machine slows every run: compare ratios of runs made "
          "back to back)" % (before["host"], before["cpu"], before["cores"],
                             before["threads_per_core"], before["memory_GB"],
                             before["load_average"], before["load_average_end"]))
    print(hdr)
    print("|" + "---|" * (hdr.count("|") - 1))
    for w in rows:
        sec = w["seconds"]
        opt = lambda v, fmt, scale=1.0: "-" if v is None else fmt % (v / scale)
        line = ("| %g | %s | %d | %.3g | %d | %.3g | %.3g | %.3g | %.3g | %.1f / %.1f | %.0f | "
                "%.0f | %s | %s | %s |" % (
                    w["resolution_mm"], w["cells"], w["np"], w["wall_s"], w["steps"],
                    sec.get("momentum", 0), sec.get("pressure", 0), sec.get("markers", 0),
                    sec.get("other", 0), w["krylov_p"], w["krylov_m"], w["material_cells"],
                    w["peak_MB"], opt(w["bytes_per_material_cell"], "%.1f", 1e3),
                    opt(w["floor_s"], "%.3g"), opt(w["multiple_of_floor"], "%.1f")))
        if other:
            line += " %.1f | %.2fx |" % (w["other_wall_s"], w["speedup_vs_other"])
        if w["status"] != "completed":
            line += " (%s)" % w["status"]
        print(line)
    if any(w["split"] for w in rows):
        print()
        print("Where the momentum and pressure phases go [s] (setup: preconditioner setups; "
              "Krylov: the iterations; rest: assembly and copies):")
        print("| dx [mm] | momentum setup | momentum Krylov | momentum rest | pressure setup | "
              "pressure Krylov | pressure rest |")
        print("|---|---|---|---|---|---|---|")
        for w in rows:
            if w["split"]:
                m, p = w["split"]["momentum"], w["split"]["pressure"]
                print("| %g | %.3g | %.3g | %.3g | %.3g | %.3g | %.3g |" % (
                    w["resolution_mm"], m["setup"], m["krylov"], m["rest"], p["setup"],
                    p["krylov"], p["rest"]))


if __name__ == "__main__":
    main()
