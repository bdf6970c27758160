#!/usr/bin/python3
"""The paper's two coupling studies on Setup I (Domnik et al. 2013, section 5.2), each coupled
run compared with the full 2D run of the same scene through granflow-study:

  delta_1D (Fig. 12): 2D on [0, 0.2] m with delta_2D = 22 deg, 1D beyond with
      delta_1D in {14, 18, 22, 26, 30} deg (DAM->Bed friction angle);
  x_IF (Fig. 14): 2D on [0, x_IF], 1D beyond, x_IF in {0.02, 0.04, 0.06, 0.10} m (and 0.2 m,
      the layout of Setup I/II, for reference); the error of the velocity averaged over
      [0, l = 0.2 m] against time.

The variants are generated from inputs/setup1_ndam.xml and inputs/setup1_coupled.xml (only the
decomposition, the DAM's bed friction angle and the output schedule change), run one after the
other with `nice`, compared with `granflow-study compare`, and summarised in OUT/studies.md
(tables), OUT/fig12_delta1d.png and OUT/fig14_xif.png.

usage: scripts/coupling_studies.py [--build build] [--out output/studies] [--interval 0.025]
                                   [--study delta|xif|both] [--reuse]
  --reuse  keep runs that have a summary.json (re-plot without re-running)
A run that stops early (e.g. diverged) is reported in the tables with its reason.
"""
import argparse
import csv
import json
import os
import subprocess
import sys
import xml.etree.ElementTree as ET

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DELTAS = [14, 18, 22, 26, 30]
XIFS = [0.02, 0.04, 0.06, 0.10, 0.20]  # the paper's four and the Setup I/II layout's 0.2


def set_param(root, path, name, ptype, value):
    """Set (or add) parameter `name` in the sublist path (list of names) of an XML tree."""
    node = root
    for sub in path:
        nxt = next((c for c in node.findall("ParameterList") if c.get("name") == sub), None)
        if nxt is None:
            nxt = ET.SubElement(node, "ParameterList", name=sub)
        node = nxt
    p = next((c for c in node.findall("Parameter") if c.get("name") == name), None)
    if p is None:
        p = ET.SubElement(node, "Parameter", name=name)
    p.set("type", ptype)
    p.set("value", value)


def variant(base, out_xml, run_dir, interval, name, models=None, interfaces=None, delta1d=None):
    tree = ET.parse(os.path.join(ROOT, "inputs", base))
    root = tree.getroot()
    set_param(root, [], "Name", "string", name)
    set_param(root, ["Output"], "Directory", "string", run_dir)
    set_param(root, ["Output"], "Interval", "double", repr(interval))
    if models is not None:
        set_param(root, ["Decomposition"], "Models", "Array(string)", "{" + ", ".join(models) + "}")
        set_param(root, ["Decomposition"], "Interfaces", "Array(double)",
                  "{" + ", ".join(repr(x) for x in interfaces) + "}")
    if delta1d is not None:
        set_param(root, ["DAM"], "Bed friction angle", "double", repr(float(delta1d)))
    tree.write(out_xml)


def completed(run_dir):
    try:
        with open(os.path.join(run_dir, "summary.json")) as fh:
            return json.load(fh).get("status") == "completed"
    except (OSError, ValueError):
        return False


def status(run_dir):
    """'completed', or how the run ended (its summary.json reason and time)."""
    with open(os.path.join(run_dir, "summary.json")) as fh:
        s = json.load(fh)
    if s.get("status") == "completed":
        return "completed"
    return "%s at t = %.3f s: %s" % (s.get("status"), s.get("final_time", 0.0), s.get("reason"))


def run(build, xml, run_dir, reuse):
    """Runs a scene; a run that stops early (diverged) is kept and reported, not fatal."""
    if reuse and os.path.exists(os.path.join(run_dir, "summary.json")):
        return status(run_dir)
    print("running", os.path.basename(xml), flush=True)
    subprocess.run(["nice", os.path.join(build, "apps", "granflow"), xml],
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    st = status(run_dir)
    if st != "completed":
        print("  ", os.path.basename(xml), st, flush=True)
    return st


def output_times(run_dir, times):
    have = {round(float(r["t"]), 9) for r in rows(os.path.join(run_dir, "profiles.csv"))}
    return [t for t in times if round(t, 9) in have]


def compare(build, ref, test, out, times):
    subprocess.run([os.path.join(build, "apps", "granflow-study"), "compare", ref, test,
                    "--times", *[repr(t) for t in times], "--average-length", "0.2", "--out", out],
                   check=True, stdout=subprocess.DEVNULL)


def rows(f):
    with open(f) as fh:
        return list(csv.DictReader(fh))


def profile(run_dir, t):
    p = [r for r in rows(os.path.join(run_dir, "profiles.csv")) if abs(float(r["t"]) - t) < 1e-9]
    return {round(float(r["x"]), 6): (float(r["h"]), float(r["u_mean"])) for r in p}


def wall(run_dir):
    with open(os.path.join(run_dir, "summary.json")) as fh:
        return json.load(fh)["wall_time"]["total"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--out", default=os.path.join(os.getcwd(), "output", "studies"))
    ap.add_argument("--interval", type=float, default=0.025)
    ap.add_argument("--study", choices=["delta", "xif", "both"], default="both")
    ap.add_argument("--reuse", action="store_true")
    a = ap.parse_args()
    out = os.path.abspath(a.out)
    os.makedirs(out, exist_ok=True)
    end = 0.75
    n = int(round(end / a.interval))
    times = [round(a.interval * k, 10) for k in range(1, n + 1)]
    md = ["# Coupling studies on Setup I (generated by scripts/coupling_studies.py)", ""]

    ref = os.path.join(out, "full2d")
    variant("setup1_ndam.xml", os.path.join(out, "full2d.xml"), ref, a.interval, "study_full2d")
    if run(a.build, os.path.join(out, "full2d.xml"), ref, a.reuse) != "completed":
        sys.exit("the full 2D reference run did not complete: " + status(ref))
    md += ["Reference: full 2D (setup1_ndam.xml), wall time %.1f s." % wall(ref), ""]

    if a.study in ("delta", "both"):
        fig, ax = plt.subplots(1, 2, figsize=(12, 4.5))
        md += ["## delta_1D (paper Fig. 12): 2D [0, 0.2] m with delta_2D = 22 deg, 1D beyond", "",
               "Relative error of u_mean against the full 2D run over the flowing channel "
               "(h > 1 mm), L2 and max, and at x = 0.5 / 1.0 m; t in s.", "",
               "| delta_1D [deg] | t | u_mean L2 | u_mean max | rel. error at 0.5 m | at 1.0 m "
               "| wall [s] |", "|---|---|---|---|---|---|---|"]
        for d in DELTAS:
            name = "delta1d_%02d" % d
            rd = os.path.join(out, name)
            variant("setup1_coupled.xml", os.path.join(out, name + ".xml"), rd, a.interval, name,
                    ["2D", "1D"], [0.2], d)
            st = run(a.build, os.path.join(out, name + ".xml"), rd, a.reuse)
            if st != "completed":
                md.append("| %d | - | %s | | | | |" % (d, st))
                continue
            cmp = os.path.join(out, "cmp_" + name)
            compare(a.build, ref, rd, cmp, [0.25, 0.5, 0.75])
            err = {(float(r["t"]), r["quantity"]): r for r in
                   rows(os.path.join(cmp, "compare_errors.csv"))}
            for t in (0.25, 0.5, 0.75):
                pr, pt = profile(ref, t), profile(rd, t)
                at = []
                for x in (0.5, 1.0):
                    k = min(pr, key=lambda q: abs(q - x - 0.0025))
                    ur, ut = pr[k][1], pt.get(k, (0, 0))[1]
                    at.append("%.2f %%" % (100 * (ut - ur) / ur) if ur > 1e-3 else "dry")
                e = err[(t, "u_mean")]
                md.append("| %d | %.2f | %.4f | %.4f | %s | %s | %s |" % (
                    d, t, float(e["l2_rel"]), float(e["max_rel"]), at[0], at[1],
                    "%.1f" % wall(rd) if t == 0.75 else ""))
            pr, pt = profile(ref, 0.75), profile(rd, 0.75)
            xs = sorted(k for k in pr if pr[k][0] > 1e-3 and k in pt and k < 1.45)
            ax[0].plot(xs, [pt[k][1] for k in xs], label="delta_1D = %d" % d)
            ax[1].plot(xs, [100 * (pt[k][1] - pr[k][1]) / pr[k][1] for k in xs],
                       label="delta_1D = %d" % d)
        xs = sorted(k for k in pr if pr[k][0] > 1e-3 and k < 1.45)
        ax[0].plot(xs, [pr[k][1] for k in xs], "k--", label="full 2D (delta = 22)")
        ax[0].set(xlabel="x [m]", ylabel="u_mean [m/s]", title="t = 0.75 s")
        ax[1].set(xlabel="x [m]", ylabel="(u_coupled - u_2D) / u_2D [%]",
                  title="relative error of u_mean, t = 0.75 s (cf. paper Fig. 12)")
        for q in ax:
            q.axvline(0.2, color="grey", lw=0.5)
            q.legend(fontsize=8)
            q.grid(alpha=0.3)
        fig.tight_layout()
        fig.savefig(os.path.join(out, "fig12_delta1d.png"), dpi=120)
        md.append("")

    if a.study in ("xif", "both"):
        fig, ax = plt.subplots(figsize=(7, 4.5))
        md += ["## x_IF (paper Fig. 14): 2D [0, x_IF], 1D beyond, delta_1D = delta_2D = 22 deg",
               "", "Relative error of the velocity averaged over [0, 0.2] m against the full 2D "
               "run.", "", "| x_IF [m] | " + " | ".join("t = %.2f" % t for t in
                                                      (0.1, 0.2, 0.3, 0.5, 0.75)) +
               " | max over t >= 0.3 s | wall [s] |", "|---" * 8 + "|"]
        for x in XIFS:
            name = "xif_%03d" % round(100 * x)
            rd = os.path.join(out, name)
            variant("setup1_coupled.xml", os.path.join(out, name + ".xml"), rd, a.interval, name,
                    ["2D", "1D"], [x])
            st = run(a.build, os.path.join(out, name + ".xml"), rd, a.reuse)
            cmp = os.path.join(out, "cmp_" + name)
            ts = output_times(rd, times)
            if not ts:
                md.append("| %.2f | %s |" % (x, st))
                continue
            compare(a.build, ref, rd, cmp, ts)
            av = [(float(r["t"]), float(r["rel_error"])) for r in
                  rows(os.path.join(cmp, "average_velocity.csv"))]
            ax.plot([t for t, _ in av], [100 * e for _, e in av], marker=".",
                    label="x_IF = %.2f m" % x)
            at = {round(t, 6): e for t, e in av}
            late = [e for t, e in av if t >= 0.3 - 1e-9]
            md.append("| %.2f | " % x + " | ".join(
                "%.2f %%" % (100 * at[t]) if t in at else "-" for t in (0.1, 0.2, 0.3, 0.5, 0.75)) +
                      " | %s | %.1f |" % ("%.2f %%" % (100 * max(late)) if late else "-",
                                          wall(rd)))
            if st != "completed":
                md.append("| | run %s |" % st)
        ax.set(xlabel="t [s]", ylabel="relative error of u averaged over [0, 0.2] m [%]",
               title="interface position (cf. paper Fig. 14)")
        ax.set_ylim(bottom=0)
        ax.legend()
        ax.grid(alpha=0.3, which="both")
        fig.tight_layout()
        fig.savefig(os.path.join(out, "fig14_xif.png"), dpi=120)
        md.append("")

    with open(os.path.join(out, "studies.md"), "w") as fh:
        fh.write("\n".join(md) + "\n")
    print("\n".join(md))
    print("wrote", os.path.join(out, "studies.md"), "and the PNG figures in", out)


if __name__ == "__main__":
    sys.exit(main())
