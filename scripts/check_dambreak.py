#!/usr/bin/python3
"""Compare a DAM dam-break run (inputs/dambreak_incline.xml or a variant of it) with the exact
solution.

In the frame accelerating at s = g cos(zeta)(tan zeta - tan delta), x' = x - s t^2/2, the
downstream edge b of the released block follows Ritter's solution
    h = (2 c0 - (x' - b)/t)^2 / (9 beta),  u = 2/3 (c0 + (x' - b)/t) + s t,
for b - c0 t < x' < b + 2 c0 t, and the plateau h = h0, u = s t lies behind it. Upstream of the
plateau the material moves upslope (u < 0) where friction changes sign, so the constant-s
solution does not hold there and that part is not compared.

The slope, the friction angles, gravity, the block (depth, start, end) and the earth pressure
come from the run's run.json (the scene as the run validated it). The solution holds for a DAM
run of a Block initial condition with a constant earth pressure coefficient (Active, Passive or
Isotropic) and slope above the bed friction angle; any other run is refused (exit 2).
usage: check_dambreak.py RUN_DIR
"""
import csv
import json
import math
import os
import re
import sys

if len(sys.argv) != 2 or sys.argv[1].startswith("-"):
    print(__doc__)
    sys.exit(0 if len(sys.argv) == 2 and sys.argv[1] in ("-h", "--help") else 2)
run = sys.argv[1]


def refuse(msg):
    print(f"check_dambreak: {run}: {msg}", file=sys.stderr)
    sys.exit(2)


try:
    lines = json.load(open(os.path.join(run, "run.json")))["parameters"]
except (OSError, ValueError, KeyError) as e:
    refuse(f"no readable run.json with the run's parameters ({e}); run granflow on the scene first")
par = {}
for line in lines:
    m = re.match(r"(.*?) \((\w+)\) = (.*)$", line)
    if m:
        v = m.group(3)
        par[m.group(1)] = v.strip('"') if m.group(2) == "string" else v


def num(name, default=None):
    if name not in par:
        if default is None:
            refuse(f"the run has no parameter {name}")
        return default
    return float(par[name])


if par.get("Model") != "DAM":
    refuse(f"Model = {par.get('Model')}: the solution is of the DAM (Model = DAM)")
if par.get("Initial condition->Type") != "Block":
    refuse(f"Initial condition->Type = {par.get('Initial condition->Type')}: the solution "
           "needs a released Block")
ep = par.get("DAM->Earth pressure", "Savage-Hutter")
g = num("Material->Gravity", 9.81)
zeta = math.radians(num("Channel->Slope angle"))
delta = math.radians(num("Material->Bed friction angle"))
phi = math.radians(num("Material->Internal friction angle"))
h0, a, b = num("Initial condition->Depth"), num("Initial condition->Start"), num("Initial condition->End")
if zeta <= delta:
    refuse("the slope is not steeper than the bed friction angle: the block does not slide as "
           "the accelerating-frame solution assumes")
gc = g * math.cos(zeta)
s = gc * (math.tan(zeta) - math.tan(delta))
root = math.sqrt(max(0.0, 1 - math.cos(phi) ** 2 / math.cos(delta) ** 2))
K = {"Active": 2 / math.cos(phi) ** 2 * (1 - root) - 1,
     "Passive": 2 / math.cos(phi) ** 2 * (1 + root) - 1,
     "Isotropic": 1.0}.get(ep)
if K is None:
    refuse(f"DAM->Earth pressure = {ep}: Ritter's solution needs a constant K (Active, Passive "
           "or Isotropic)")
beta = gc * K
c0 = math.sqrt(beta * h0)
print(f"slope {math.degrees(zeta):g} deg, delta {math.degrees(delta):g} deg, phi "
      f"{math.degrees(phi):g} deg, block {h0:g} m on [{a:g}, {b:g}] m, Earth pressure {ep}")
rows = list(csv.DictReader(open(f"{run}/profiles.csv")))
times = sorted({float(r["t"]) for r in rows if float(r["t"]) > 0})
print(f"K = {K:.4f}, c0 = {c0:.4f} m/s, s = {s:.4f} m/s^2")
print("t [s] | L1(h) rel. | max|h err| [m] | max|u err| where h > 5 mm [m/s] | front exact/num [m]")
for t in times:
    r = [x for x in rows if float(x["t"]) == t]
    xs = [float(x["x"]) for x in r]
    dx = xs[1] - xs[0]
    e1 = m = emax = eu = 0.0
    front_num = max((float(x["x"]) for x in r if float(x["h"]) > 1e-4), default=0.0)
    for x in r:
        X = float(x["x"])
        xp = X - s * t * t / 2
        if xp < a + c0 * t:
            continue  # upstream part: friction changes sign, not covered by the solution
        if xp < b - c0 * t:
            he, ue = h0, s * t
        elif xp < b + 2 * c0 * t:
            he = (2 * c0 - (xp - b) / t) ** 2 / (9 * beta)
            ue = 2 / 3 * (c0 + (xp - b) / t) + s * t
        else:
            he, ue = 0.0, 0.0
        hn, un = float(x["h"]), float(x["u_mean"])
        e1 += abs(hn - he) * dx
        m += he * dx
        emax = max(emax, abs(hn - he))
        if he > 0.005:
            eu = max(eu, abs(un - ue))
    front_exact = b + 2 * c0 * t + s * t * t / 2
    print(f"{t:.3f} | {e1 / m:.2e} | {emax:.2e} | {eu:.2e} | {front_exact:.4f} / {front_num:.4f}")
