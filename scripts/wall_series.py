#!/usr/bin/env python3
"""The wall load of granflow runs (wall.csv, summary.json 'wall_load'): first contact, the
impact peaks of the single-step series, the time means of the load over windows after the
contact (which do not depend on which step a peak falls on), the impulse over the impact, the
final load, and the load against the hydrostatic one of the wall column, rho g cos(zeta) h^2/2.
Standard library only.

Usage: scripts/wall_series.py RUN_DIR [RUN_DIR ...] [--windows A:B,...] [--at A:B,...]
  --windows: milliseconds after the first contact, 0 <= A < B (default
             0:5,0:10,0:20,20:50,100:150,300:400; also --windows=...);
  --at:      fixed windows in seconds of the run's time, 0 <= A < B. The first contact moves
             with dt and with the layout (a coupled run's 1D front tongue can touch the wall
             first), and every window that starts there moves with it; runs are compared over
             fixed windows (docs/validation.md, "Wall load and impact")."""
import argparse
import csv
import json
import math
import os
import sys


def window_list(text, unit="ms"):
    """A:B,... in `unit`, 0 <= A < B (an independent run: --windows 0:5 was taken as a run
    directory, and 5:0 or 0:0 printed nan means)."""
    out = []
    for w in text.split(","):
        try:
            a, b = (float(v) for v in w.split(":"))
        except ValueError:
            raise argparse.ArgumentTypeError(f"'{w}' is not A:B (two numbers of {unit})")
        if not (0 <= a < b and math.isfinite(b)):
            raise argparse.ArgumentTypeError(f"'{w}': allowed: 0 <= A < B {unit}")
        out.append((a, b))
    return out


ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
ap.add_argument("dirs", nargs="+", metavar="RUN_DIR")
ap.add_argument("--windows", type=window_list,
                default=[(0, 5), (0, 10), (0, 20), (20, 50), (100, 150), (300, 400)],
                help="A:B,... [ms] after the first contact")
ap.add_argument("--at", type=lambda t: window_list(t, "s"), default=[],
                help="A:B,... [s] fixed windows of the run's time")
# a window that starts below 0 ('--at -1:0.6') was read by argparse as an option and refused
# with "expected one argument"; join such values to their option so the range check names them
argv = sys.argv[1:]
for i in range(len(argv) - 1):
    if argv[i] in ("--at", "--windows") and argv[i + 1].startswith("-") and ":" in argv[i + 1]:
        argv[i:i + 2] = [argv[i] + "=" + argv[i + 1], ""]
args = ap.parse_args([a for a in argv if a != ""])
dirs, windows = args.dirs, args.windows
for d in dirs:
    for f in ("summary.json", "wall.csv"):
        if not os.path.isfile(os.path.join(d, f)):
            sys.exit(f"wall_series: {d} has no {f} (a granflow run of a channel that ends at a "
                     "wall?)")

for d in dirs:
    s = json.load(open(d + "/summary.json"))
    w = s["wall_load"]
    par = s["parameters"]
    rho, g = par["Material"]["Density"], par["Material"]["Gravity"]
    zeta = math.radians(par["Channel"]["Slope angle"])
    rows = [{k: float(v) for k, v in r.items()} for r in csv.DictReader(open(d + "/wall.csv"))]
    tc = w["first_contact_time"]
    # a run that stopped early: its series ends at the stop, and "final" is the stop's (an
    # independent run read a stopped run's last row as the final load)
    ended = ("" if s.get("status", "completed") == "completed" else
             f"; {s['status']} at t = {s['final_time']:.4g} s ({s.get('reason', '')}): the series ends there")
    if tc is None:  # no sample in contact: no peaks (summary.json gives null)
        print(f"{d}: {w['samples']} samples, the material never reached the wall{ended}")
        continue
    print(f"{d}: {w['samples']} samples, first contact at {tc:.4f} s "
          f"(impact window {w['impact_window']} s){ended}")
    for k in ("force", "normal_force", "p_foot"):
        q = w[k]
        print(f"  {k:12s} impact peak {q['impact_peak']:9.1f} at +{1e3 * (q['impact_peak_time'] - tc):5.1f} ms,"
              f" peak {q['peak']:9.1f} at {q['peak_time']:.3f} s, final {q['final']:9.1f}")

    def mean(col, a, b):  # time mean over [tc + a, tc + b] (each row holds over its step)
        num = den = 0.0
        for r0, r1 in zip(rows, rows[1:]):
            lo, hi = max(r0["t"], tc + a), min(r1["t"], tc + b)
            if hi > lo:
                num += r1[col] * (hi - lo)
                den += hi - lo
        return num / den if den else float("nan")

    def covered(a, b):  # [ms] of the window [a, b] the run reaches (it may end inside it)
        return max(0.0, min(b, 1e3 * (rows[-1]["t"] - tc)) - a)

    for a, b in windows:
        if tc + a / 1e3 >= rows[-1]["t"]:  # the run ended before the window
            print(f"  mean over +[{a:g}, {b:g}] ms: no rows (the run ends at +"
                  f"{1e3 * (rows[-1]['t'] - tc):.0f} ms)")
            continue
        # (an independent run: a window the run ends inside was printed as if whole)
        part = covered(a, b)
        note = "" if part >= b - a - 1e-9 else f" (the run ends at +{a + part:.1f} ms: mean of that part)"
        print(f"  mean over +[{a:g}, {b:g}] ms: force {mean('force', a / 1e3, b / 1e3):7.1f}  "
              f"normal {mean('normal_force', a / 1e3, b / 1e3):7.1f}  shear "
              f"{mean('shear', a / 1e3, b / 1e3):6.1f} N/m  p_foot {mean('p_foot', a / 1e3, b / 1e3):7.0f} Pa"
              + note)
    for a, b in args.at:
        if a >= rows[-1]["t"] or b <= rows[0]["t"]:
            print(f"  mean over [{a:g}, {b:g}] s: no rows (the run covers [{rows[0]['t']:g}, "
                  f"{rows[-1]['t']:g}] s)")
            continue
        lo, hi = max(a, rows[0]["t"]), min(b, rows[-1]["t"])
        note = "" if (lo, hi) == (a, b) else f" (rows only on [{lo:g}, {hi:g}] s: mean of that part)"
        print(f"  mean over [{a:g}, {b:g}] s: force {mean('force', a - tc, b - tc):7.1f}  "
              f"normal {mean('normal_force', a - tc, b - tc):7.1f}  shear "
              f"{mean('shear', a - tc, b - tc):6.1f} N/m  p_foot {mean('p_foot', a - tc, b - tc):7.0f} Pa"
              + note)
    part = covered(0.0, 50.0)
    imp = mean("normal_force", 0, part / 1e3) * part / 1e3 if part > 0 else 0.0
    print(f"  impulse of the normal force over +[0, {part:.1f}] ms: {imp:.3f} N s/m"
          + ("" if part >= 50.0 - 1e-9 else " (the run ends before +50 ms)"))
    last = rows[-1]
    hyd = 0.5 * rho * g * math.cos(zeta) * last["depth"] ** 2
    # the load is the normal force, the full normal stress (docs/numerics.md "Wall load": a pile
    # at rest carries deviatoric normal stress too), not the pressure integral
    ratio = f"{last['normal_force'] / hyd:.3f} x" if hyd > 0 else "(no depth at the wall:) no ratio to the"
    print(f"  {'final' if not ended else 'at the stop'}: depth {last['depth']:.4f} m, normal "
          f"force {last['normal_force']:.1f} N/m = {ratio} hydrostatic "
          f"{hyd:.1f} N/m, pressure integral {last['force']:.1f}"
          + ("" if last["contact"] else " (not in contact: a film thinner than a cell, whose "
             "row carries the viscous normal stress of a cell it barely fills)"))
