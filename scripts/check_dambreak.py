#!/usr/bin/python3
"""Compare the dam-break scene (inputs/dambreak_incline.xml) with the exact solution.

In the frame accelerating at s = g cos(zeta)(tan zeta - tan delta), x' = x - s t^2/2, the
downstream edge b of the released block follows Ritter's solution
    h = (2 c0 - (x' - b)/t)^2 / (9 beta),  u = 2/3 (c0 + (x' - b)/t) + s t,
for b - c0 t < x' < b + 2 c0 t, and the plateau h = h0, u = s t lies behind it. Upstream of the
plateau the material moves upslope (u < 0) where friction changes sign, so the constant-s
solution does not hold there and that part is not compared.
usage: check_dambreak.py RUN_DIR [--cells N]
"""
import csv
import math
import sys

run = sys.argv[1] if len(sys.argv) > 1 else "output/dambreak_incline"
g, zeta, delta, phi = 9.81, math.radians(40), math.radians(25), math.radians(30)
h0, a, b, L = 0.1, 0.6, 1.2, 2.5
gc = g * math.cos(zeta)
s = gc * (math.tan(zeta) - math.tan(delta))
root = math.sqrt(1 - math.cos(phi) ** 2 / math.cos(delta) ** 2)
K = 2 / math.cos(phi) ** 2 * (1 - root) - 1
beta = gc * K
c0 = math.sqrt(beta * h0)
rows = list(csv.DictReader(open(f"{run}/profiles.csv")))
times = sorted({float(r["t"]) for r in rows if float(r["t"]) > 0})
print(f"K_act = {K:.4f}, c0 = {c0:.4f} m/s, s = {s:.4f} m/s^2")
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
