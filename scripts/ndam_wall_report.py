#!/usr/bin/env python3
"""Setup II numbers of a 2D (N-DAM) run at its last snapshot: deposit depth at the wall (from
profiles.csv, model 2D) and the bottom pressure of the last columns against the hydrostatic
rho g cos(zeta) h. Uses h5dump (hdf5-tools), no Python HDF5 module.
Usage: scripts/ndam_wall_report.py OUTPUT_DIR [rho=1440] [zeta_deg=50]"""
import csv, math, re, subprocess, sys

out = sys.argv[1]
rho = float(sys.argv[2]) if len(sys.argv) > 2 else 1440.0
zeta = math.radians(float(sys.argv[3]) if len(sys.argv) > 3 else 50.0)
g = 9.81
groups = re.findall(r"^(step_\d+)", subprocess.run(["h5ls", f"{out}/fields.h5"], capture_output=True,
                                                  text=True).stdout, re.M)
last = groups[-1]

def ds(name):
    txt = subprocess.run(["h5dump", "-w", "0", "-y", "-d", f"/{last}/ndam/{name}", f"{out}/fields.h5"],
                         capture_output=True, text=True).stdout
    dims = [int(v) for v in re.search(r"SIMPLE \{ \( ([\d, ]+) \)", txt).group(1).split(",")]
    body = txt[txt.index("DATA {") + 6:txt.rindex("}")]
    return dims, [float(v) for v in re.findall(r"[-+]?\d*\.?\d+(?:[eE][-+]?\d+)?", body)]

(nz, nx), p = ds("p_Pa")
rows = [r for r in csv.DictReader(open(f"{out}/profiles.csv"))]
tmax = max(float(r["t"]) for r in rows)
last_rows = [r for r in rows if float(r["t"]) == tmax]
print(f"t = {tmax:g} s ({last})")
for r in last_rows[-6:]:
    x, h = float(r["x"]), float(r["h"])
    i = min(nx - 1, int(x / (float(last_rows[1]["x"]) - float(last_rows[0]["x"]))))
    print(f"x = {x:.4f} m  h = {h:.4f} m  u_mean = {float(r['u_mean']):.3f} m/s  "
          f"p_bottom = {p[i] / 1000:.2f} kPa  hydrostatic = {rho * g * math.cos(zeta) * h / 1000:.2f} kPa")
