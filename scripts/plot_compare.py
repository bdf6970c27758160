#!/usr/bin/python3
"""Plot a granflow-study comparison: profiles of both runs at the compared times, the relative
errors of h and u_mean against time, and the error of the velocity averaged over [0, l].
usage: plot_compare.py OUT_DIR REF_RUN TEST_RUN   (writes OUT_DIR/compare.png)
"""
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

out, ref, test = sys.argv[1:4]


def rows(f):
    with open(f) as fh:
        return list(csv.DictReader(fh))


err = rows(os.path.join(out, "compare_errors.csv"))
avg = rows(os.path.join(out, "average_velocity.csv"))
times = sorted({float(r["t"]) for r in err})
fig, ax = plt.subplots(2, 2, figsize=(11, 7))
for k, (run, style) in enumerate(((ref, "-"), (test, "--"))):
    prof = rows(os.path.join(run, "profiles.csv"))
    for j, t in enumerate(times[-3:]):
        p = [r for r in prof if abs(float(r["t"]) - t) < 1e-9]
        x = [float(r["x"]) for r in p]
        ax[0, 0].plot(x, [float(r["h"]) for r in p], style, color=f"C{j}",
                      label=f"{os.path.basename(run.rstrip('/'))} t={t:g}")
        ax[0, 1].plot(x, [float(r["u_mean"]) for r in p], style, color=f"C{j}")
ax[0, 0].set(xlabel="x [m]", ylabel="h [m]")
ax[0, 1].set(xlabel="x [m]", ylabel="u_mean [m/s]")
ax[0, 0].legend(fontsize=7)
zeros = {}
for q, c in (("h", "C0"), ("u_mean", "C1")):
    # (times where the reference has no flowing point have no relative error: empty fields)
    # Exact agreement (0, e.g. before the layouts differ) has no place on a log axis: those
    # times are left out (they were drawn at 1e-12, an axis of eleven decades whose errors
    # seemed to jump from 1e-12; an independent run) and the title says how many.
    e = [r for r in err if r["quantity"] == q and r["l2_rel"] != ""]
    for key, style, lab in (("max_rel", "o-", "max"), ("l2_rel", "s--", "L2")):
        pts = [(float(r["t"]), float(r[key])) for r in e if float(r[key]) > 0.0]
        zeros[q] = max(zeros.get(q, 0), sum(1 for r in e if float(r[key]) == 0.0))
        if pts:
            ax[1, 0].semilogy([p[0] for p in pts], [p[1] for p in pts], style, color=c,
                              label=f"{q} {lab}")
ax[1, 0].set(xlabel="t [s]", ylabel="relative error",
             title=", ".join(f"{q}: {n} times exact (not drawn)" for q, n in zeros.items() if n)
             or None)
if ax[1, 0].get_legend_handles_labels()[0]:  # (identical runs: no error to draw, no legend)
    ax[1, 0].legend(fontsize=7)
avg = [r for r in avg if r["rel_error"] != ""]
ax[1, 1].plot([float(r["t"]) for r in avg], [100 * float(r["rel_error"]) for r in avg], "o-")
ax[1, 1].set(xlabel="t [s]", ylabel="rel. error of averaged velocity [%]")
for a in ax.flat:
    a.grid(alpha=0.3)
fig.tight_layout()
fig.savefig(os.path.join(out, "compare.png"), dpi=110)
print(os.path.join(out, "compare.png"))
