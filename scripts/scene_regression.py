#!/usr/bin/env python3
"""Run every shipped scene with one build and compare its physics output with another run.

  scene_regression.py run  BUILD OUTDIR [--scenes a.xml b.xml ...] [--skip NAME ...]
  scene_regression.py diff OUTDIR_A OUTDIR_B [--tolerance REL]

`run` copies each scene of inputs/ to OUTDIR/<scene>/scene.xml with its Output->Directory
pointed at OUTDIR/<scene>/out and runs BUILD/apps/granflow on it.  `diff` compares two such
trees: profiles.csv and wall.csv (when both have it) value by value and the physics numbers of
summary.json (final time, steps, mass balance, layout, solver iteration counts; wall times,
dates and host data are left out).
With the default tolerance 0 the comparison is bit for bit (the numbers are printed with
round-trip precision); a refactoring that keeps the arithmetic order must pass it. A change
that reorders arithmetic states its per-scene tolerance and passes `--tolerance`.

Exit code 0 when every scene matches, 1 otherwise (the differing scenes and quantities are
printed).
"""
import argparse
import csv
import json
import math
import os
import re
import shutil
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# summary.json keys that measure the machine, not the physics
VOLATILE = re.compile(r"(seconds|cpu_time|wall|time_s|date|host|started|finished|elapsed|memory|rss|"
                      r"version|commit|compiler|build|provenance|directory|file|peak)", re.I)


def scenes(selected):
    names = selected or sorted(f for f in os.listdir(os.path.join(ROOT, "inputs"))
                               if f.endswith(".xml"))
    return [os.path.join(ROOT, "inputs", n) if not os.path.isabs(n) else n for n in names]


def run(args):
    exe = os.path.join(os.path.abspath(args.build), "apps", "granflow")
    os.makedirs(args.outdir, exist_ok=True)
    failed = 0
    for path in scenes(args.scenes):
        name = os.path.splitext(os.path.basename(path))[0]
        if name in (args.skip or []):
            continue
        d = os.path.abspath(os.path.join(args.outdir, name))
        if os.path.isdir(d):
            shutil.rmtree(d)
        os.makedirs(d)
        text = open(path).read()
        text = re.sub(r'(<Parameter name="Directory" type="string" value=")[^"]*(")',
                      r"\g<1>" + os.path.join(d, "out") + r"\g<2>", text)
        # series files and other relative paths resolve against the scene's directory
        scene = os.path.join(d, "scene.xml")
        open(scene, "w").write(text)
        for aux in os.listdir(os.path.dirname(path)):
            if not aux.endswith(".xml") and os.path.isfile(os.path.join(os.path.dirname(path), aux)):
                shutil.copy(os.path.join(os.path.dirname(path), aux), d)
        t0 = time.time()
        p = subprocess.run([exe, scene], cwd=d, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                           text=True)
        print(f"{name:28s} exit {p.returncode}  {time.time() - t0:7.1f} s", flush=True)
        open(os.path.join(d, "stdout.txt"), "w").write(p.stdout + p.stderr)
        failed += p.returncode != 0
    return 0 if failed == 0 else 1


def physics(obj, prefix=""):
    """Flatten summary.json to {path: number or string}, without the machine's numbers."""
    out = {}
    if isinstance(obj, dict):
        for k, v in obj.items():
            if VOLATILE.search(k):
                continue
            out.update(physics(v, f"{prefix}{k}."))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            out.update(physics(v, f"{prefix}{i}."))
    elif isinstance(obj, bool) or obj is None or isinstance(obj, str):
        out[prefix[:-1]] = obj
    else:
        out[prefix[:-1]] = float(obj)
    return out


def close(a, b, tol):
    if isinstance(a, float) and isinstance(b, float):
        if a == b or (math.isnan(a) and math.isnan(b)):
            return True
        return abs(a - b) <= tol * max(abs(a), abs(b), 1e-300)
    return a == b


def diff(args):
    bad = 0
    names = sorted(n for n in os.listdir(args.a) if os.path.isdir(os.path.join(args.a, n)))
    for n in names:
        pa, pb = os.path.join(args.a, n, "out"), os.path.join(args.b, n, "out")
        problems = []
        if not os.path.isdir(pb):
            problems.append("missing in B")
        else:
            ca = list(csv.reader(open(os.path.join(pa, "profiles.csv"))))
            cb = list(csv.reader(open(os.path.join(pb, "profiles.csv"))))
            if len(ca) != len(cb):
                problems.append(f"profiles.csv: {len(ca)} rows against {len(cb)}")
            else:
                worst = 0.0
                for ra, rb in zip(ca, cb):
                    for va, vb in zip(ra, rb):
                        if va == vb:
                            continue
                        try:
                            fa, fb = float(va), float(vb)
                        except ValueError:
                            problems.append(f"profiles.csv: '{va}' against '{vb}'")
                            continue
                        rel = abs(fa - fb) / max(abs(fa), abs(fb), 1e-300)
                        worst = max(worst, rel)
                if worst > args.tolerance:
                    problems.append(f"profiles.csv: largest relative difference {worst:.3g}")
            # wall.csv (chutes that end at a wall): the wall load at every step
            wa, wb = os.path.join(pa, "wall.csv"), os.path.join(pb, "wall.csv")
            if os.path.exists(wa) and os.path.exists(wb):
                ra_, rb_ = list(csv.reader(open(wa))), list(csv.reader(open(wb)))
                if len(ra_) != len(rb_):
                    problems.append(f"wall.csv: {len(ra_)} rows against {len(rb_)}")
                else:
                    worst = 0.0
                    for x, y in zip(ra_[1:], rb_[1:]):
                        for va, vb in zip(x, y):
                            if va != vb:
                                fa, fb = float(va), float(vb)
                                worst = max(worst, abs(fa - fb) / max(abs(fa), abs(fb), 1e-300))
                    if worst > args.tolerance:
                        problems.append(f"wall.csv: largest relative difference {worst:.3g}")
            sa = physics(json.load(open(os.path.join(pa, "summary.json"))))
            sb = physics(json.load(open(os.path.join(pb, "summary.json"))))
            for k in sorted(set(sa) | set(sb)):
                if k not in sa or k not in sb:
                    continue  # a new or removed statistic is not a change of result
                if not close(sa[k], sb[k], args.tolerance):
                    problems.append(f"summary.json {k}: {sa[k]} against {sb[k]}")
        print(f"{n:28s} {'same' if not problems else 'DIFFERENT'}")
        for p in problems[:12]:
            print("    " + p)
        bad += bool(problems)
    return 0 if bad == 0 else 1


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("build")
    r.add_argument("outdir")
    r.add_argument("--scenes", nargs="*")
    r.add_argument("--skip", nargs="*")
    d = sub.add_parser("diff")
    d.add_argument("a")
    d.add_argument("b")
    d.add_argument("--tolerance", type=float, default=0.0)
    args = ap.parse_args()
    sys.exit(run(args) if args.cmd == "run" else diff(args))


if __name__ == "__main__":
    main()
