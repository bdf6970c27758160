#!/usr/bin/python3
"""Plot depth h and mean velocity u_mean along the channel from one or more run directories.

usage: plot_profiles.py RUN_DIR [RUN_DIR ...] [--times T ...] [--out FILE.png]
Each RUN_DIR holds the profiles.csv of a granflow run; several runs are overlaid (e.g. DAM
against full 2D). Without --times, five output times spread over the run are drawn.
"""
import argparse
import csv
import os
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt


def read_profiles(run_dir):
    data = defaultdict(lambda: {"x": [], "h": [], "u": []})
    with open(os.path.join(run_dir, "profiles.csv")) as f:
        for r in csv.DictReader(f):
            d = data[float(r["t"])]
            d["x"].append(float(r["x"]))
            d["h"].append(float(r["h"]))
            d["u"].append(float(r["u_mean"]))
    return data


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("runs", nargs="+")
    ap.add_argument("--times", nargs="*", type=float)
    ap.add_argument("--out", default=None)
    a = ap.parse_args()
    fig, (ax_h, ax_u) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    styles = ["-", "--", ":", "-."]
    for k, run in enumerate(a.runs):
        data = read_profiles(run)
        times = sorted(data)
        wanted = a.times or [times[int(i * (len(times) - 1) / 4)] for i in range(5)]
        for j, t in enumerate(wanted):
            tt = min(times, key=lambda s: abs(s - t))
            d = data[tt]
            c = f"C{j}"
            lab = f"{os.path.basename(run.rstrip('/'))} t={tt:.3g} s"
            ax_h.plot(d["x"], d["h"], styles[k % 4], color=c, label=lab)
            ax_u.plot(d["x"], d["u"], styles[k % 4], color=c)
    ax_h.set_ylabel("h [m]")
    ax_u.set_ylabel("u_mean [m/s]")
    ax_u.set_xlabel("x [m]")
    ax_h.legend(fontsize=7)
    for ax in (ax_h, ax_u):
        ax.grid(alpha=0.3)
    out = a.out or os.path.join(a.runs[0], "profiles.png")
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    print(out)


if __name__ == "__main__":
    main()
