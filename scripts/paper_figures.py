#!/usr/bin/python3
"""Figures comparable to Domnik et al. (2013), section 5, from granflow output directories.

usage: paper_figures.py --setup2 DIR [--bingham DIR] [--setup1 DIR] [--out docs/figures]

  --setup2   full 2D Setup II run (inputs/setup2_ndam.xml; for the deposit growth use a copy
             with a short Output->Interval, e.g. 0.05 s)
  --bingham  the same scene with the Bingham material (inputs/setup2_ndam_bingham.xml)
  --setup1   full 2D Setup I run (inputs/setup1_ndam.xml)

Writes PNG files into --out:
  setup2_depth.png          h(x) near the wall at every output time from 0.5 s on (the shock
                            and the deposit growing upstream from the wall), and the deposit
                            depth at the wall and the position of the shock against time
  setup2_wall_fields.png    |u| and p near the wall at four output times (cf. the paper's Fig. 9)
  setup2_wall_pressure.png  bottom pressure along x near the wall against the hydrostatic
                            rho g cos(zeta) h, Drucker-Prager and Bingham (cf. Figs. 9b, 10b)
  setup1_profiles.png       Setup I h and u_mean along the channel (cf. Fig. 6)
The paper's reference values are drawn as markers. Needs Debian's python3-matplotlib and
python3-h5py (scripts/install-deps.sh).
"""
import argparse
import csv
import json
import math
import os
from collections import defaultdict

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

G = 9.81
# Paper values (section 5.1.2): Setup II at t = 0.75 s
PAPER_DEPOSIT = 0.11       # m, deposit depth at the wall
PAPER_P_BOTTOM = 2.3       # kPa, bottom pressure at the wall
PAPER_P_HYDRO = 1.0        # kPa, rho g cos(zeta) h for h = 0.11 m
PAPER_P_BINGHAM = 6.0      # kPa, pressure near the wall, Bingham tau_y = 100 Pa (Fig. 10b)
PAPER_P_DP = 4.0           # kPa, same place, pressure-dependent yield stress (Fig. 9b)


def read_profiles(run):
    data = defaultdict(lambda: {"x": [], "h": [], "u": []})
    with open(os.path.join(run, "profiles.csv")) as f:
        for r in csv.DictReader(f):
            d = data[float(r["t"])]
            d["x"].append(float(r["x"]))
            d["h"].append(float(r["h"]))
            d["u"].append(float(r["u_mean"]))
    return {t: {k: np.array(v) for k, v in d.items()} for t, d in sorted(data.items())}


def scene(run):
    """rho and the slope angle from summary.json (parameters as validated)."""
    with open(os.path.join(run, "summary.json")) as f:
        s = json.load(f)
    p = s["parameters"]
    rho = p["Material"]["Density"]
    zeta = math.radians(p["Channel"]["Slope angle"])
    return rho, zeta, s


def snapshots(run):
    """[(t, group)] of fields.h5, in time order."""
    f = h5py.File(os.path.join(run, "fields.h5"), "r")
    snaps = sorted(((float(f[k].attrs["time"]), f[k]["ndam"]) for k in f if k.startswith("step_")),
                   key=lambda s: s[0])
    return f, snaps


def nearest(snaps, t):
    return min(snaps, key=lambda s: abs(s[0] - t))


def shock_position(x, h, u, wall_x):
    """Upstream end of the slow region at the wall: the first column, walking upstream from the
    wall, where u_mean exceeds half of the mean speed of the incoming layer (taken 0.2-0.3 m
    upstream of the wall). None before the material reaches the wall."""
    up = (x > wall_x - 0.3) & (x < wall_x - 0.2) & (h > 1e-3)
    if not up.any() or h[-1] < 1e-3:
        return None
    u_in = float(np.mean(u[up]))
    for i in range(len(x) - 1, -1, -1):
        if h[i] > 1e-3 and u[i] > 0.5 * u_in:
            return float(x[i])
    return None


def fig_setup2_depth(run, out):
    prof = read_profiles(run)
    times = [t for t in prof if t >= 0.5 - 1e-9]
    x_last = prof[max(prof)]["x"]
    wall = float(x_last[-1] + 0.5 * (x_last[1] - x_last[0]))
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2), gridspec_kw={"width_ratios": [1.6, 1]})
    cmap = plt.get_cmap("viridis")
    for n, t in enumerate(times):
        d = prof[t]
        a.plot(d["x"], d["h"], color=cmap(n / max(1, len(times) - 1)), label=f"t = {t:.2f} s")
    a.plot([wall - 0.0025], [PAPER_DEPOSIT], "r*", ms=12, label="paper, 0.75 s: 0.11 m")
    a.set_xlim(wall - 0.45, wall + 0.005)
    a.set_xlabel("x [m] (wall at x = %.2f m)" % wall)
    a.set_ylabel("depth h [m]")
    a.set_title("Setup II, full 2D: depth near the wall")
    a.legend(fontsize=7, ncol=2)
    a.grid(alpha=0.3)
    ts, hw, xs = [], [], []
    for t, d in prof.items():
        ts.append(t)
        hw.append(d["h"][-1])
        xs.append(shock_position(d["x"], d["h"], d["u"], wall))
    b.plot(ts, hw, "o-", label="deposit depth at the wall [m]")
    b.plot([0.75], [PAPER_DEPOSIT], "r*", ms=12, label="paper: 0.11 m at 0.75 s")
    b.set_xlabel("t [s]")
    b.set_ylabel("h at the wall [m]")
    b2 = b.twinx()
    tx = [(t, wall - x) for t, x in zip(ts, xs) if x is not None]
    if tx:
        b2.plot([p[0] for p in tx], [p[1] for p in tx], "s--", color="C1",
                label="shock: distance from the wall [m]")
    b2.set_ylabel("distance of the shock from the wall [m]", color="C1")
    lines = b.get_legend_handles_labels()
    lines2 = b2.get_legend_handles_labels()
    b.legend(lines[0] + lines2[0], lines[1] + lines2[1], fontsize=7, loc="upper left")
    b.set_title("deposit and shock against time")
    b.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "setup2_depth.png"), dpi=90)
    plt.close(fig)


def fig_setup2_fields(run, out):
    rho, zeta, _ = scene(run)
    f, snaps = snapshots(run)
    # the snapshots after the material has reached the wall (a non-empty cell in the last column)
    late = [s for s in snaps if (~flag_empty(s[1]["flag"][:][:, -1:])).any()] or snaps[-1:]
    pick = [late[int(round(i * (len(late) - 1) / 3))] for i in range(4)] if len(late) >= 4 else late
    fig, axes = plt.subplots(2, len(pick), figsize=(3.2 * len(pick), 5.2), squeeze=False)
    for j, (t, g) in enumerate(pick):
        xn, zn = g["x_nodes"][:], g["z_nodes"][:]
        flag = g["flag"][:]
        u, w, p = g["u"][:], g["w"][:], g["p_Pa"][:] / 1000.0
        empty = flag_empty(flag)
        speed = np.ma.masked_where(empty, np.hypot(u, w))
        pm = np.ma.masked_where(empty, p)
        sel = xn[:-1] >= xn[-1] - 0.2
        i0 = int(np.argmax(sel))
        zmax = 0.16
        for r, (fld, lab, cm) in enumerate(((speed, "|u| [m/s]", "viridis"),
                                            (pm, "p [kPa]", "magma"))):
            ax = axes[r][j]
            im = ax.pcolormesh(xn[i0:], zn, fld[:, i0:], cmap=cm, shading="flat",
                               vmin=0, vmax=(3.0 if r == 0 else 4.5))
            ax.set_xlim(xn[i0], xn[-1])
            ax.set_ylim(0, min(zmax, zn[-1]))
            ax.set_aspect("equal")
            ax.set_title(f"t = {t:.2f} s", fontsize=9)
            if j == 0:
                ax.set_ylabel("z [m]")
            if r == 1:
                ax.set_xlabel("x [m]")
            fig.colorbar(im, ax=ax, shrink=0.8, label=lab)
    fig.suptitle("Setup II, full 2D, Drucker-Prager: speed and pressure near the wall "
                 "(material cells only)", fontsize=10)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "setup2_wall_fields.png"), dpi=80)
    plt.close(fig)
    f.close()


def flag_empty(flag):
    """Cells without material: Empty (3) and Obstacle (0) in the flag field
    (include/granflow/ndam/grid.hpp: Obstacle 0, Fluid 1, Surface 2, Empty 3)."""
    f = np.rint(flag).astype(int)
    return (f == 3) | (f == 0)


def fig_wall_pressure(runs, out):
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    for name, run, col in runs:
        rho, zeta, _ = scene(run)
        f, snaps = snapshots(run)
        t, g = nearest(snaps, 0.75)
        xn = g["x_nodes"][:]
        xc = 0.5 * (xn[1:] + xn[:-1])
        p = g["p_Pa"][:] / 1000.0
        empty = flag_empty(g["flag"][:])
        prof = read_profiles(run)
        tp = min(prof, key=lambda s: abs(s - t))
        h = prof[tp]["h"]
        pmax = np.where(empty, -np.inf, p).max(axis=0)
        sel = xc >= xn[-1] - 0.15
        a.plot(xc[sel], p[0, sel], "-", color=col, label=f"{name}: bottom p")
        a.plot(xc[sel], rho * G * math.cos(zeta) * h[sel] / 1000.0, "--", color=col,
               label=f"{name}: rho g cos(zeta) h")
        b.plot(xc[sel], pmax[sel], "-", color=col, label=f"{name}: max p in the column")
        f.close()
    xw = 1.0
    a.plot([xw - 0.003], [PAPER_P_BOTTOM], "k*", ms=12, label="paper DP: 2.3 kPa bottom")
    a.plot([xw - 0.003], [PAPER_P_HYDRO], "kx", ms=10, mew=2, label="paper DP: 1.0 kPa hydrostatic")
    a.set_xlabel("x [m]")
    a.set_ylabel("pressure [kPa]")
    a.set_title("Setup II, t = 0.75 s: bottom pressure near the wall")
    a.legend(fontsize=7)
    a.grid(alpha=0.3)
    b.plot([xw - 0.005], [PAPER_P_BINGHAM], "*", color="C3", ms=12, label="paper Bingham: about 6 kPa")
    b.plot([xw - 0.005], [PAPER_P_DP], "*", color="C0", ms=12, label="paper DP: about 4 kPa")
    b.set_xlabel("x [m]")
    b.set_ylabel("pressure [kPa]")
    b.set_title("largest pressure in each column (cf. Figs. 9b, 10b)")
    b.legend(fontsize=7)
    b.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "setup2_wall_pressure.png"), dpi=90)
    plt.close(fig)


def fig_setup1(run, out):
    prof = read_profiles(run)
    times = [t for t in prof if t > 0]
    fig, (a, b) = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True)
    cmap = plt.get_cmap("viridis")
    for n, t in enumerate(times):
        d = prof[t]
        wet = d["h"] > 1e-3
        c = cmap(n / max(1, len(times) - 1))
        a.plot(d["x"], d["h"], color=c, label=f"t = {t:.2f} s")
        b.plot(d["x"][wet], d["u"][wet], color=c, label=f"t = {t:.2f} s")
    a.set_ylabel("depth h [m]")
    a.set_title("Setup I (open end), full 2D: depth and mean velocity (cf. Fig. 6, t = 0.75 s)")
    a.legend(fontsize=7)
    a.grid(alpha=0.3)
    b.set_ylabel("u_mean [m/s]")
    b.set_xlabel("x [m]")
    b.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "setup1_profiles.png"), dpi=90)
    plt.close(fig)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--setup2", required=True)
    ap.add_argument("--bingham")
    ap.add_argument("--setup1")
    ap.add_argument("--out", default="docs/figures")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    fig_setup2_depth(a.setup2, a.out)
    fig_setup2_fields(a.setup2, a.out)
    runs = [("Drucker-Prager", a.setup2, "C0")]
    if a.bingham:
        runs.append(("Bingham", a.bingham, "C3"))
    fig_wall_pressure(runs, a.out)
    if a.setup1:
        fig_setup1(a.setup1, a.out)
    print("paper_figures: wrote", ", ".join(sorted(f for f in os.listdir(a.out) if f.endswith(".png"))))


if __name__ == "__main__":
    main()
