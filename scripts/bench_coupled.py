#!/usr/bin/python3
"""Speed benchmark (issue 5 item 8): the coupled 2D/1D/2D run beside the full 2D run of the same
scene at the same resolution, with the per-phase timers of every 2D subdomain.

    scripts/bench_coupled.py BUILD_DIR OUT_DIR [--cells 5 2.5] [--pairs setup2 setup1 setup2_bingham]

For each pair (full 2D scene, coupled scene) and each cell size [mm] the scenes are rewritten
with 'Cells x' = L / dx, 'Cells z' = Height / dx (2D) and the DAM's 'Cells' of the 1D part at the
same dx, run one after the other with build/apps/granflow, and compared with granflow-study.
Prints a Markdown table: wall time, steps, seconds per phase (momentum, pressure, markers, other
summed over the 2D subdomains; the DAM's share is the remainder of the step time), material
cells solved in 2D at the end, and the coupled run's u_mean L2 error against full 2D at 0.75 s.
"""
import argparse
import csv
import json
import os
import re
import subprocess
import sys

PAIRS = {
    "setup2": ("setup2_ndam.xml", "setup2_coupled.xml"),
    "setup1": ("setup1_ndam.xml", "setup1_coupled.xml"),
    "setup2_bingham": ("setup2_ndam_bingham.xml", "setup2_coupled_bingham.xml"),
}


def param(xml, name):
    m = re.search(r'<Parameter name="%s" type="\w+" value="([^"]+)"' % re.escape(name), xml)
    return m.group(1) if m else None


def set_param(xml, name, value):
    pat = r'(<Parameter name="%s" type="\w+" value=")[^"]+(")' % re.escape(name)
    new, n = re.subn(pat, r"\g<1>%s\g<2>" % value, xml)
    if n == 0:
        raise SystemExit("parameter %s not found" % name)
    return new


def variant(src, dst, dx, outdir):
    xml = open(src).read()
    length = float(param(xml, "Length"))
    height = float(param(xml, "Height"))
    xml = set_param(xml, "Cells x", int(round(length / dx)))
    xml = set_param(xml, "Cells z", int(round(height / dx)))
    if param(xml, "Cells") is not None:  # the DAM of the coupled scene: cells over [0, L]
        xml = set_param(xml, "Cells", int(round(length / dx)))
    xml = set_param(xml, "Directory", outdir)
    xml = set_param(xml, "Interval", "0.25")
    open(dst, "w").write(xml)


def phases(summary):
    st = summary["solver_statistics"]
    parts = [p["statistics"] for p in st["coupled"]["subdomains"]] if "coupled" in st else [st]
    tot = {"momentum": 0.0, "pressure": 0.0, "markers": 0.0, "other": 0.0}
    for p in parts:
        for k, v in p.get("ndam", {}).get("seconds", {}).items():
            tot[k] = tot.get(k, 0.0) + v
    return tot


def u_l2_at(csv_path, t):
    if not os.path.exists(csv_path):
        return float("nan")
    for row in csv.DictReader(open(csv_path)):
        if abs(float(row["t"]) - t) < 1e-9 and row["quantity"].startswith("u"):
            return float(row["l2_rel"])
    return float("nan")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("build")
    ap.add_argument("out")
    ap.add_argument("--cells", type=float, nargs="+", default=[5.0, 2.5], help="cell sizes [mm]")
    ap.add_argument("--pairs", nargs="+", default=["setup2"], choices=sorted(PAIRS))
    a = ap.parse_args()
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    exe = os.path.join(a.build, "apps", "granflow")
    study = os.path.join(a.build, "apps", "granflow-study")
    os.makedirs(a.out, exist_ok=True)
    rows = []
    for pair in a.pairs:
        for mm in a.cells:
            runs = {}
            for kind, scene in zip(("full 2D", "coupled"), PAIRS[pair]):
                tag = "%s_%s_%gmm" % (pair, "2d" if kind == "full 2D" else "coupled", mm)
                xml = os.path.join(a.out, tag + ".xml")
                outdir = os.path.join(a.out, tag)
                variant(os.path.join(root, "inputs", scene), xml, mm / 1000.0, outdir)
                print("running", tag, file=sys.stderr, flush=True)
                subprocess.run([exe, xml], check=False, stdout=subprocess.DEVNULL,
                               stderr=open(os.path.join(a.out, tag + ".log"), "w"))
                runs[kind] = outdir
            cmp_dir = os.path.join(a.out, "%s_%gmm_compare" % (pair, mm))
            subprocess.run([study, "compare", runs["full 2D"], runs["coupled"], "--times", "0.25",
                            "0.5", "0.75", "--out", cmp_dir], check=False,
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            for kind, outdir in runs.items():
                s = json.load(open(os.path.join(outdir, "summary.json")))
                ph = phases(s)
                step = s["wall_time"]["step"]
                err = u_l2_at(os.path.join(cmp_dir, "compare_errors.csv"), 0.75) \
                    if kind == "coupled" else float("nan")
                rows.append((pair, mm, kind, s["status"], s["wall_time"]["total"], s["steps"],
                             ph["momentum"], ph["pressure"], ph["markers"], ph["other"],
                             max(0.0, step - sum(ph.values())), err))
    print("| scene | dx [mm] | model | status | wall [s] | steps | momentum [s] | pressure [s] "
          "| markers [s] | other 2D [s] | DAM + coupling [s] | u_mean L2 vs 2D at 0.75 s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print("| %s | %g | %s | %s | %.1f | %d | %.1f | %.1f | %.1f | %.1f | %.1f | %s |" % (
            r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8], r[9], r[10],
            "-" if r[11] != r[11] else "%.3f" % r[11]))


if __name__ == "__main__":
    main()
