#!/usr/bin/env python3
"""Wall numbers of a 2D (N-DAM) run at its last snapshot: the depth of the last columns (from
profiles.csv) and their bottom pressure against the hydrostatic rho g cos(zeta) h, with rho, g
and zeta read from the run's own run.json (the scene's parameters as the run used them).
Uses h5dump (hdf5-tools), no Python HDF5 module.

Usage: scripts/ndam_wall_report.py OUTPUT_DIR [--columns N]
Exit 0 with the table, 2 for a directory that is not a finished 2D run (with the reason)."""
import argparse
import csv
import json
import math
import os
import re
import subprocess
import sys


def fail(msg):
    print(f"ndam_wall_report.py: {msg}", file=sys.stderr)
    sys.exit(2)


def run_parameter(run, name):
    """The value of `name` (e.g. 'Channel->Slope angle') in run.json's parameter lines."""
    for line in run.get("parameters", []):
        m = re.match(r"(.+?) \((\w+)\) = (.*)$", line)
        if m and m.group(1) == name:
            return float(m.group(3))
    fail(f"run.json has no parameter '{name}'")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out", metavar="OUTPUT_DIR", help="the run's output directory")
    ap.add_argument("--columns", type=int, default=6, help="columns next to the wall (6)")
    a = ap.parse_args()
    for f in ("run.json", "profiles.csv", "fields.h5"):
        if not os.path.isfile(os.path.join(a.out, f)):
            fail(f"{a.out}: no {f} (give the output directory of a finished N-DAM run)")
    run = json.load(open(os.path.join(a.out, "run.json")))
    rho = run_parameter(run, "Material->Density")
    g = run_parameter(run, "Material->Gravity")
    zeta = math.radians(run_parameter(run, "Channel->Slope angle"))
    fields = os.path.join(a.out, "fields.h5")
    ls = subprocess.run(["h5ls", fields], capture_output=True, text=True)
    groups = re.findall(r"^(step_\d+)", ls.stdout, re.M)
    if not groups:
        fail(f"{fields}: no snapshot (h5ls: {ls.stderr.strip() or 'no step_ groups'})")
    last = groups[-1]

    def dataset(name):
        txt = subprocess.run(["h5dump", "-w", "0", "-y", "-d", f"/{last}/ndam/{name}", fields],
                             capture_output=True, text=True).stdout
        m = re.search(r"SIMPLE \{ \( ([\d, ]+) \)", txt)
        if not m:
            fail(f"{fields}: no /{last}/ndam/{name} (not a 2D run?)")
        dims = [int(v) for v in m.group(1).split(",")]
        body = txt[txt.index("DATA {") + 6:txt.rindex("}")]
        return dims, [float(v) for v in re.findall(r"[-+]?\d*\.?\d+(?:[eE][-+]?\d+)?", body)]

    (nz, nx), p = dataset("p_Pa")
    rows = [r for r in csv.DictReader(open(os.path.join(a.out, "profiles.csv")))
            if r.get("model", "2D") == "2D"]
    if not rows:
        fail(f"{a.out}/profiles.csv: no 2D rows")
    tmax = max(float(r["t"]) for r in rows)
    last_rows = [r for r in rows if float(r["t"]) == tmax]
    dx = float(last_rows[1]["x"]) - float(last_rows[0]["x"])
    x0 = float(last_rows[0]["x"]) - 0.5 * dx  # the 2D grid's first face
    print(f"t = {tmax:g} s ({last}); rho = {rho:g} kg/m^3, g = {g:g} m/s^2, "
          f"zeta = {math.degrees(zeta):g} deg")
    for r in last_rows[-a.columns:]:
        x, h = float(r["x"]), float(r["h"])
        i = min(nx - 1, int((x - x0) / dx))
        print(f"x = {x:.4f} m  h = {h:.4f} m  u_mean = {float(r['u_mean']):.3f} m/s  "
              f"p_bottom = {p[i] / 1000:.2f} kPa  "
              f"hydrostatic = {rho * g * math.cos(zeta) * h / 1000:.2f} kPa")


if __name__ == "__main__":
    main()
