#!/usr/bin/env python3
"""Full 2D, static, a priori and dynamic layouts of one scene family, side by side.

  compare_layouts.py BUILD OUTDIR [--family setup2|lab_chute] [--cell MM] [--end T]
                     [--height H] [--interval DT] [--times T ...] [--rerun]
                     [--variants V ...] [--set NAME=VALUE ...]

Runs (or reuses, when OUTDIR/<variant>/summary.json of the same scene says 'completed' and is newer
than BUILD's granflow) the
four variants of the family at one resolution:
  full     full 2D (N-DAM), the reference
  static   the paper's layout (Setup II: 2D [0, 0.2] / 1D [0.2, 0.7] / 2D [0.7, 1] m; lab
           chute: 2D [0, 0.2] / 1D [0.2, 1.8] / 2D [1.8, 2] m)
  apriori  the a priori layout of a DAM run (paper section 4.1)
  dynamic  the domain manager, starting from the static layout
and writes OUTDIR/comparison.md and comparison.csv: per output time the relative errors of h and
u_mean against full 2D (L2 and max over the flowing part, h > 1 mm and |u| > 1 mm/s, as
granflow-study compare), the deposit depth at the wall (the wall column's, and the mean over the
last --wall-width metres, 1 cm by default: the single column of a marker deposit scatters by
2-3.5 % rms from its neighbours and carries a one-column run-up at the wall; both are given, each
also relative to full 2D), the shock position (where the arriving
material meets the material stopped at the wall: the steepest drop of u_mean over two columns
downstream of the fastest flow, once the wall column has stopped, |u_mean| < 0.05 m/s), and per run the mass defect, wall
time, steps and moves; plus the share of the full 2D run's material that lies in the dynamic
run's 1D parts (the ideal saving: the depth summed over the columns and the outputs, i.e. the
marker area; a count of material cells, partly filled surface cells counted whole, gives a few
points more) against the saving the dynamic run achieved; and
OUTDIR/xt.png, an x-t picture of the depth field of the dynamic run with the interface positions
of the coupled runs and the shock trajectory of full 2D.
"""
import argparse
import csv
import json
import math
import os
import re
import subprocess
import sys
import time
import xml.etree.ElementTree as ET

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

FAMILIES = {
    "setup2": {"full": "setup2_ndam.xml", "static": "setup2_coupled.xml",
               "apriori": "setup2_coupled.xml", "dynamic": "setup2_dynamic.xml",
               "length": 1.0},
    "lab_chute": {"full": "lab_chute_ndam.xml", "static": "lab_chute_static.xml",
                  "apriori": "lab_chute_apriori.xml", "dynamic": "lab_chute_dynamic.xml",
                  "length": 2.0},
}
VARIANTS = ["full", "static", "apriori", "dynamic"]
SETTABLE = {"Decomposition", "DAM"}  # the lists of the dynamic run that --set may change


def set_param(text, name, typ, value):
    pat = r'(<Parameter name="%s" type="%s" value=")[^"]*(")' % (re.escape(name), typ)
    new, n = re.subn(pat, r"\g<1>%s\g<2>" % value, text)
    if n == 0:
        raise SystemExit("compare_layouts: the scene has no parameter '%s'" % name)
    return new


_PARAMETERS = {}


def coupled_parameters(build):
    """{list name: {parameter: type}} of the Coupled model's settable lists, from BUILD's
    `granflow --parameters` (the types as the code declares them; nothing copied here)."""
    if build not in _PARAMETERS:
        out = subprocess.run([os.path.join(build, "apps", "granflow"), "--parameters"],
                             capture_output=True, text=True).stdout
        lists, model, current = {}, None, None
        for line in out.splitlines():
            m = re.match(r"## Model `([^`]*)`", line)
            if m:
                model, current = m.group(1), None
                continue
            m = re.match(r"#+ `([^`]*)`", line)
            if m:
                current = m.group(1) if model == "Coupled" and m.group(1) in SETTABLE else None
                continue
            m = re.match(r"\| `([^`]*)` \| ([^|]*) \|", line)
            if m and current:
                lists.setdefault(current, {})[m.group(1)] = m.group(2).strip()
        _PARAMETERS[build] = lists
    return _PARAMETERS[build]


def add_default_param(build, text, name):
    """(text with NAME added, empty, at the head of the settable list that declares it, its
    type); (text, None) when no settable list of the scene has it."""
    for lst, params in coupled_parameters(os.path.abspath(build)).items():
        if name in params and '<ParameterList name="%s">' % lst in text:
            text = text.replace('<ParameterList name="%s">' % lst,
                                '<ParameterList name="%s">\n    <Parameter name="%s" type="%s" '
                                'value=""/>' % (lst, name, params[name]), 1)
            return text, params[name]
    return text, None


def variant_xml(family, variant, args, outdir):
    spec = FAMILIES[family]
    text = open(os.path.join(ROOT, "inputs", spec[variant])).read()
    L = spec["length"]
    if variant == "apriori" and family == "setup2":
        text = re.sub(r'<ParameterList name="Decomposition">.*?</ParameterList>',
                      '<ParameterList name="Decomposition">\n    <Parameter name="Layout" '
                      'type="string" value="A priori"/>\n  </ParameterList>', text, flags=re.S)
    if args.cell:
        dx = args.cell / 1000.0
        nx = int(round(L / dx))
        text = set_param(text, "Cells x", "int", nx)
        if 'name="DAM"' in text:
            text = set_param(text, "Cells", "int", nx)
    height = args.height
    if height or args.cell:
        h = height or float(re.search(r'name="Height" type="double" value="([^"]*)"', text).group(1))
        dz = (args.cell / 1000.0) if args.cell else None
        if dz is None:
            nz0 = int(re.search(r'name="Cells z" type="int" value="([^"]*)"', text).group(1))
            h0 = float(re.search(r'name="Height" type="double" value="([^"]*)"', text).group(1))
            dz = h0 / nz0
        text = set_param(text, "Height", "double", h)
        text = set_param(text, "Cells z", "int", int(round(h / dz)))
    if args.end:
        text = set_param(text, "End time", "double", args.end)
    if args.surface_cell_mass:
        # every variant, the reference too: the forms are compared each against its own full 2D
        if 'name="Surface cell mass"' in text:
            text = set_param(text, "Surface cell mass", "string", args.surface_cell_mass)
        else:
            text = text.replace('<ParameterList name="N-DAM">',
                                '<ParameterList name="N-DAM">\n    <Parameter name="Surface cell '
                                'mass" type="string" value="%s"/>' % args.surface_cell_mass, 1)
    if variant == "dynamic":
        for item in args.set or []:
            name, _, value = item.partition("=")
            found = re.search(r'<Parameter name="%s" type="([^"]*)"' % re.escape(name), text)
            typ = found.group(1) if found else None
            if not typ and value:
                # a parameter the scene leaves at its default (Margin, Hold time, ...): added
                # to its list with the type granflow --parameters gives it (it was refused as
                # unknown, although the dynamic run takes it)
                text, typ = add_default_param(args.build, text, name)
            if not typ or not value:
                raise SystemExit("compare_layouts: --set '%s': the dynamic scene has no "
                                 "parameter of that name (or no value given)" % item)
            # only the layout's and the 1D grid's parameters: a slope or a material set on the
            # dynamic run alone made every figure of the table a comparison of two scenes (an
            # independent run: 'Slope angle=30' against the 50 deg reference, exit 0)
            lists = {pl.get("name") for pl in ET.fromstring(text).iter("ParameterList")
                     if any(q.get("name") == name for q in pl.findall("Parameter"))}
            if not lists <= SETTABLE:
                raise SystemExit("compare_layouts: --set '%s': '%s' is a parameter of %s, which "
                                 "the reference run shares; --set takes the parameters of the "
                                 "dynamic run's own lists only: %s" % (
                                     item, name, ", ".join(sorted(lists)),
                                     ", ".join(sorted(SETTABLE))))
            text = set_param(text, name, typ, value)
    if args.interval:
        text = set_param(text, "Interval", "double", args.interval)
    d = os.path.abspath(os.path.join(outdir, variant))
    text = set_param(text, "Directory", "string", d)
    return text, d


def scene_parameters(text):
    """The parameters a scene's XML sets: {path tuple: (type, value text)}."""
    out = {}

    def walk(pl, prefix):
        for ch in pl:
            if ch.tag == "Parameter":
                out[prefix + (ch.get("name"),)] = (ch.get("type"), ch.get("value"))
            elif ch.tag == "ParameterList":
                walk(ch, prefix + (ch.get("name"),))

    walk(ET.fromstring(text), ())
    return out


def same_value(typ, text, value):
    """Whether the scene's text of a parameter of type `typ` is the value summary.json records."""
    def num(a, b):
        a, b = float(a), float(b)
        return a == b or abs(a - b) <= 1e-12 * max(abs(a), abs(b))
    try:
        if typ in ("double", "int"):
            return num(text, value)
        if typ == "bool":
            return (text.strip().lower() == "true") == bool(value)
        if typ.startswith("Array"):
            items = lambda v: [q.strip() for q in str(v).strip().strip("{}").split(",") if q.strip()]
            a, b = items(text), items(value)
            if typ == "Array(string)":
                return a == b
            return len(a) == len(b) and all(num(x, y) for x, y in zip(a, b))
        return str(text) == str(value)
    except (TypeError, ValueError):
        return False


def reuse_refusal(build, scene, text, summary, statuses=("completed",)):
    """Why the run in summary's directory is not a run of `text` made by BUILD's granflow that
    can stand in the report, or None when it is: the scene file the same text, summary.json
    readable, with a status in `statuses` (by default: it completed), newer than the binary (an
    older one is another build's), and recording every parameter the scene sets with the
    scene's value (a run directory copied from another scene, grid or end time was taken
    before: an independent run); profiles.csv whole: whole rows of numbers ending in a newline,
    its output times as many as summary.json counts, each reaching the channel's end, the last
    at the run's final time when it completed (a cut file gave a table of 0.008 against 0.067
    before). A run that is not reusable is run again."""
    exe = os.path.join(build, "apps", "granflow")
    if not (os.path.exists(summary) and os.path.exists(scene) and open(scene).read() == text):
        return "no earlier run of this scene"
    if os.path.getmtime(summary) < os.path.getmtime(exe):
        return "made by another build"
    try:
        s = json.load(open(summary))
    except (OSError, ValueError, UnicodeDecodeError) as e:
        return "summary.json unreadable (%s)" % e.__class__.__name__
    if not isinstance(s, dict) or s.get("status") not in statuses:
        return "summary.json: status %s" % (s.get("status") if isinstance(s, dict) else "missing")
    try:
        recorded = s["parameters"]
        for path, (typ, value) in scene_parameters(text).items():
            v = recorded
            for key in path:
                v = v[key]
            if not same_value(typ, value, v):
                return "summary.json records %s = %s, the scene %s" % ("->".join(path), v, value)
        final, count = float(s["final_time"]), int(s["outputs"]["output_times"])
        s["wall_time"]["total"], s["steps"], s["mass_balance"]["defect"]
    except (KeyError, TypeError, ValueError) as e:
        return "summary.json incomplete (%s %s)" % (e.__class__.__name__, e)
    prof = os.path.join(os.path.dirname(summary), "profiles.csv")
    try:
        ends = {}  # per output time: its first and last two x
        with open(prof) as f:
            text_p = f.read()
        if not text_p.endswith("\n"):
            raise ValueError("its last row is cut")  # (a cut inside a number still parses)
        for r in csv.DictReader(text_p.splitlines()):
            if any(r.get(k) in (None, "") for k in ("t", "x", "h", "u_mean", "eps", "model")):
                raise ValueError("a row with missing fields")
            vals = [float(r[k]) for k in ("t", "x", "h", "u_mean")]
            if not all(math.isfinite(v) for v in vals):
                raise ValueError("a value not finite")
            e = ends.setdefault(round(vals[0], 9), [vals[1], None, vals[1]])
            e[1], e[2] = e[2], vals[1]
    except (OSError, ValueError, TypeError, KeyError, UnicodeDecodeError) as e:
        return "profiles.csv unreadable (%s)" % e
    if len(ends) != count:
        return "profiles.csv holds %d output times, summary.json counts %d" % (len(ends), count)
    # every output spans the channel: its last point half a cell short of the channel's end (a
    # file cut inside an output ended mid-channel; the count of rows may change with a move
    # where the 1D cells are not the 2D columns' width)
    reach = {t: x1 + 0.5 * (x1 - x0 if x0 is not None else 0.0) for t, (_, x0, x1) in ends.items()}
    end = max(reach.values())
    short = [t for t, r in reach.items() if r < end - 1e-6 * max(1.0, abs(end))]
    if short:
        return "profiles.csv ends before the channel's end at t = %g s" % min(short)
    if s["status"] == "completed" and abs(max(ends) - final) > 1e-6 * max(1.0, final):
        return "profiles.csv ends at t = %g s, the run at %g s" % (max(ends), final)
    return None


def reusable(build, scene, text, summary, statuses=("completed",)):
    """A run of `text` already made by BUILD's granflow that the report can take as it is
    (reuse_refusal); says why not when an earlier run is there but cannot be taken."""
    why = reuse_refusal(build, scene, text, summary, statuses)
    if why and os.path.exists(os.path.dirname(summary)) and why != "no earlier run of this scene":
        print("  %s: not reused (%s); running it again" % (os.path.dirname(summary), why),
              flush=True)
    return why is None


def cost_seconds(s):
    """A run's cost from its summary.json: its CPU time from the start of the run
    (cpu_time.run_seconds: without the process's start-up of 0.25-0.4 s, which was 35-45 % of
    a 10 mm 2D run's figure and 7-10 times a 1D run's computing; an independent run), else the
    process's CPU time, else the wall time. Shared with pareto.py."""
    c = s.get("cpu_time", {})
    return c.get("run_seconds", c.get("process_seconds", s["wall_time"]["total"]))


def check_scene(build, args):
    """The dynamic variant (the one --set edits) through `granflow --check` before any run: an
    unknown --set name exits here, a value granflow refuses (e.g. 'Check interval=abc', found
    after three runs before; an independent run) exits with granflow's message and code 2."""
    text, _ = variant_xml(args.family, "dynamic", args, args.outdir)
    os.makedirs(args.outdir, exist_ok=True)
    scene = os.path.join(args.outdir, "dynamic.check.xml")
    open(scene, "w").write(text)
    # --overwrite as the run itself (run_variant): OUTDIR may hold another variant's run, which
    # that run replaces (without it the check refused a changed --set; an independent run)
    p = subprocess.run([os.path.join(build, "apps", "granflow"), "--check", "--overwrite", scene],
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    os.remove(scene)
    if p.returncode != 0:
        print(p.stdout[-2000:], file=sys.stderr)
        raise SystemExit(2)


def run_variant(build, family, variant, args, outdir):
    text, d = variant_xml(family, variant, args, outdir)
    os.makedirs(outdir, exist_ok=True)
    scene = os.path.join(outdir, variant + ".xml")
    summary = os.path.join(d, "summary.json")
    if not args.rerun and reusable(build, scene, text, summary):
        print(f"{variant:8s} reused {d}", flush=True)
        return d
    open(scene, "w").write(text)
    t0 = time.time()
    p = subprocess.run([os.path.join(build, "apps", "granflow"), "--overwrite", scene],
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    print(f"{variant:8s} exit {p.returncode} in {time.time() - t0:.1f} s", flush=True)
    if p.returncode != 0:
        print(p.stdout[-2000:])
        if variant in ("full", "dynamic"):  # the reference and the ideal saving need both
            raise SystemExit(f"compare_layouts: the {variant} run failed")
        # another layout that stops (exit 3, e.g. the static lab chute once the shock is in its
        # 1D part) is a result: reported, and left out of the tables
        print(f"compare_layouts: the {variant} run stopped (exit {p.returncode}); left out",
              flush=True)
        return None
    return d


def profiles(d):
    out = {}
    for r in csv.DictReader(open(os.path.join(d, "profiles.csv"))):
        out.setdefault(round(float(r["t"]), 9), []).append(
            (float(r["x"]), float(r["h"]), float(r["u_mean"]), r["model"]))
    return out


def wall_columns(p, L, width):
    """The depths of the columns whose centres lie within `width` of the wall at x = L (at least
    the wall column; a centre on the edge counts)."""
    return [h for x, h, *_ in p if x > L - width - 1e-9 * L] or [p[-1][1]]


def wall_mean(p, L, width):
    """The deposit depth at the wall on a width that does not shrink with the cells."""
    sel = wall_columns(p, L, width)
    return sum(sel) / len(sel)


def on_grid(ref, test):
    """test's (h, u) at ref's x (nearest point: the coupled runs' 1D cells may be finer)."""
    xs = [p[0] for p in test]
    out = []
    j = 0
    for x, *_ in ref:
        while j + 1 < len(xs) and abs(xs[j + 1] - x) <= abs(xs[j] - x):
            j += 1
        out.append(test[j])
    return out


def errors(ref, test):
    t = on_grid(ref, test)
    num_h = den_h = num_u = den_u = 0.0
    mh = mu = 0.0
    for (x, h, u, _), (_, h2, u2, _) in zip(ref, t):
        if h <= 1e-3 or abs(u) <= 1e-3:
            continue
        num_h += (h2 - h) ** 2
        den_h += h * h
        num_u += (u2 - u) ** 2
        den_u += u * u
        mh = max(mh, abs(h2 - h) / h)
        mu = max(mu, abs(u2 - u) / abs(u))
    f = lambda n, d: math.sqrt(n / d) if d > 0 else 0.0
    return f(num_h, den_h), mh, f(num_u, den_u), mu


def shock(prof, L):
    """The shock: where arriving material meets the material stopped at the wall (Pudasaini et
    al. 2007), taken as the steepest drop of u_mean over two columns among the columns deeper
    than 1 mm downstream of the fastest flow; None when nothing has stopped at the wall
    yet (the table shows '-'; it showed L, a shock at the wall, before)."""
    wet = [p for p in prof if p[1] > 1e-3]
    if len(wet) < 3 or abs(prof[-1][2]) > 0.05 or prof[-1][1] <= 1e-3:
        return None
    i_fast = max(range(len(wet)), key=lambda i: wet[i][2])
    best, x = 0.0, L
    for i in range(max(i_fast, 1), len(wet) - 1):
        drop = wet[i - 1][2] - wet[i + 1][2]
        if drop > best:
            best, x = drop, wet[i][0]
    return x


def interfaces(prof, summary=None, t=None):
    """The interfaces at output time t: from summary.json's layout record when it has one (the
    subdomains' ends exactly), else the midpoints between profile points of different models
    (a few mm off where the 1D cells are coarser than the 2D columns)."""
    hist = (summary or {}).get("interfaces", {}).get("positions_over_time") if t is not None else None
    if hist:
        past = [e for e in hist if e["t"] <= t + 1e-9]
        if past:
            return [p["x1"] for p in past[-1]["subdomains"][:-1]]
    out = []
    for (x0, _, _, m0), (x1, _, _, m1) in zip(prof, prof[1:]):
        if m0 != m1:
            out.append(0.5 * (x0 + x1))
    return out


def check_build(ap, build):
    """BUILD must hold apps/granflow (a missing one ended in a traceback after the option
    checks; an independent run). Shared with pareto.py."""
    if not os.access(os.path.join(build, "apps", "granflow"), os.X_OK):
        ap.error("BUILD %s: no apps/granflow there (give granflow's build directory)" % build)


def check_outdir(ap, outdir):
    """OUTDIR must be a directory or a path that can be one (an existing file ended in a
    FileExistsError traceback, a file among its parents in a NotADirectoryError; independent
    runs). Shared with pareto.py."""
    p = os.path.abspath(outdir)
    while not os.path.exists(p):
        p = os.path.dirname(p)
    if not os.path.isdir(p):
        ap.error("OUTDIR %s: %s is a file; allowed: a directory, or a path where one can be "
                 "made" % (outdir, "it" if p == os.path.abspath(outdir) else p))


def check_options(ap, args, positive=()):
    """Refuses (argparse's exit 2) --end, --height and --interval unless >= 1e-9 (the run's
    time resolution; smaller positive numbers overflowed the grid arithmetic), the given
    (option, value, smallest) triples below their smallest, and --times unless >= 0 and
    multiples of --interval or --end (the output times; a time beyond the end is found after
    the runs). Shared with pareto.py."""
    for opt, v, least in tuple(positive) + (("--end", args.end, 1e-9),
                                            ("--height", args.height, 1e-9),
                                            ("--interval", args.interval, 1e-9)):
        if v is not None and not (v >= least and math.isfinite(v)):
            ap.error("%s %g: allowed: a number >= %g" % (opt, v, least))
    # (t = 0: nothing flows yet, and the errors over the flowing part were nan; an independent run)
    if args.times is not None and not all(t > 0 and math.isfinite(t) for t in args.times):
        ap.error("--times %s: allowed: output times > 0 s (at t = 0 nothing flows)" %
                 " ".join("%g" % t for t in args.times))
    on_grid = lambda t: (abs(t / args.interval - round(t / args.interval)) <= 1e-6 or
                         (args.end is not None and abs(t - args.end) <= 1e-9 * max(1.0, t)))
    off = [t for t in args.times or [] if not on_grid(t)]
    if off:
        ap.error("--times %s: not multiples of --interval %g s (nor the --end time); allowed: "
                 "output times" % (" ".join("%g" % t for t in off), args.interval))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("build")
    ap.add_argument("outdir")
    ap.add_argument("--family", default="setup2", choices=sorted(FAMILIES))
    ap.add_argument("--cell", type=float, help="[mm] cell size of both models (default: the scenes')")
    ap.add_argument("--end", type=float, help="[s] end time")
    ap.add_argument("--height", type=float, help="[m] N-DAM box height")
    ap.add_argument("--interval", type=float, default=0.05, help="[s] output interval")
    ap.add_argument("--times", type=float, nargs="*", help="[s] times of the error table")
    ap.add_argument("--wall-width", type=float, default=0.01,
                    help="[m] width of the wall's deposit mean (at least one column; default 0.01)")
    ap.add_argument("--rerun", action="store_true", help="run even where a result exists")
    ap.add_argument("--set", action="append", metavar="NAME=VALUE",
                    help="set a parameter of the dynamic scene's Decomposition or DAM list "
                         "(repeatable), e.g. --set 'Shallowness threshold=0.05'; one the scene "
                         "leaves at its default is added with the type granflow gives it")
    ap.add_argument("--surface-cell-mass", choices=["Full cell", "Full cell and weight",
                                                    "Material share"],
                    help="N-DAM->Surface cell mass of every variant, full 2D included (default: "
                         "the scenes', i.e. the code's default)")
    ap.add_argument("--variants", nargs="+", default=VARIANTS, choices=VARIANTS,
                    help="the layouts to run (full and dynamic always: the reference and the "
                         "ideal saving)")
    args = ap.parse_args()
    # The options' ranges, and the --set names, before any run (an independent run: --cell 0
    # ran the scenes' own grid, --times between outputs were taken as the nearest output, and a
    # misspelt --set name was found after three variants had run)
    check_options(ap, args, (("--cell", args.cell, 1e-3), ("--wall-width", args.wall_width, 1e-9)))
    check_build(ap, args.build)
    check_outdir(ap, args.outdir)
    coarsest = 100.0 * FAMILIES[args.family]["length"]  # [mm] 10 cells along the channel
    if args.cell is not None and args.cell > coarsest:
        ap.error("--cell %g: allowed: a cell size in [0.001, %g] mm (10 cells along the channel "
                 "or more)" % (args.cell, coarsest))
    check_scene(os.path.abspath(args.build), args)  # an unknown --set name or a bad value
    variants = [v for v in VARIANTS if v in set(args.variants) | {"full", "dynamic"}]
    build = os.path.abspath(args.build)
    L = FAMILIES[args.family]["length"]
    dirs = {v: run_variant(build, args.family, v, args, args.outdir) for v in variants}
    failed = [v for v, d in dirs.items() if d is None]
    variants = [v for v in variants if v not in failed]
    dirs = {v: d for v, d in dirs.items() if d is not None}
    prof = {v: profiles(d) for v, d in dirs.items()}
    summ = {v: json.load(open(os.path.join(d, "summary.json"))) for v, d in dirs.items()}
    times = sorted(prof["full"])
    table_times = sorted(set(args.times)) if args.times else [t for t in times if t > 0][-4:]
    table_times = [min(times, key=lambda s: abs(s - t)) for t in table_times]
    late = [t for t in sorted(set(args.times or [])) if min(abs(s - t) for s in times) > 1e-6]
    if late:
        sys.exit("compare_layouts: --times %s: not output times of the full 2D run (every %g s "
                 "to %g s)" % (" ".join("%g" % t for t in late), args.interval, times[-1]))

    rows = []
    for t in table_times:
        ref = prof["full"][t]
        for v in variants:
            if t not in prof[v]:
                continue
            p = prof[v][t]
            eh, mh, eu, mu = errors(ref, p) if v != "full" else (0, 0, 0, 0)
            rows.append({"t": t, "run": v, "h_L2": eh, "h_max": mh, "u_L2": eu, "u_max": mu,
                         "wall_depth": p[-1][1], "wall_mean": wall_mean(p, L, args.wall_width),
                         "shock": shock(p, L),
                         "interfaces": " ".join("%.3f" % x for x in interfaces(p, summ[v], t))})
    # ideal saving: the full run's material (its depth) that lies in the dynamic run's 1D
    # parts, summed over the columns and the outputs (equal time weights)
    nz_dz = None
    s_full = summ["full"]["parameters"]
    mat_all = mat_1d = 0.0
    for t in times:
        if t not in prof["dynamic"]:
            continue
        dyn = on_grid(prof["full"][t], prof["dynamic"][t])
        for (x, h, u, _), (_, _, _, m) in zip(prof["full"][t], dyn):
            mat_all += h
            if m == "1D":
                mat_1d += h
    ideal = mat_1d / mat_all if mat_all > 0 else 0.0
    wall = {v: summ[v]["wall_time"]["total"] for v in variants}
    # the saving from the runs' CPU time where both report it (cost_seconds), else from wall
    # time
    cpu = {v: (cost_seconds(summ[v]) if "cpu_time" in summ[v] else None) for v in variants}
    cost = cpu if cpu["dynamic"] and cpu["full"] else wall
    cost_name = "CPU time" if cost is cpu else "wall time"
    achieved = 1.0 - cost["dynamic"] / cost["full"] if cost["full"] > 0 else 0.0

    os.makedirs(args.outdir, exist_ok=True)
    with open(os.path.join(args.outdir, "comparison.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    md = [f"# Layouts compared: {args.family}" + (f", {args.cell:g} mm" if args.cell else ""), ""]
    md.append(f"| t [s] | run | h L2 | h max | u_mean L2 | u_mean max | wall column [m] | "
              f"wall, last {100 * args.wall_width:g} cm [m] | shock [m] | interfaces [m] |")
    md.append("|---|---|---|---|---|---|---|---|---|---|")
    ref_wall = {(r["t"], k): r[k] for r in rows if r["run"] == "full"
                for k in ("wall_depth", "wall_mean")}

    def wall_cell(r, k):
        ref = ref_wall.get((r["t"], k))
        rel = (f" ({100 * (r[k] / ref - 1):+.1f} %)" if r["run"] != "full" and ref else "")
        return f"{r[k]:.4f}{rel}"

    for r in rows:
        md.append(f"| {r['t']:g} | {r['run']} | {r['h_L2']:.3f} | {r['h_max']:.3f} | "
                  f"{r['u_L2']:.3f} | {r['u_max']:.3f} | {wall_cell(r, 'wall_depth')} | "
                  f"{wall_cell(r, 'wall_mean')} | "
                  f"{'-' if r['shock'] is None else '%.3f' % r['shock']} | {r['interfaces']} |")
    # (an independent run at 10 mm found the two wall figures equal in every row, with no word
    # why: the width is one column there)
    if len(wall_columns(prof["full"][table_times[0]], L, args.wall_width)) <= 1:
        md += ["", f"At this grid the last {100 * args.wall_width:g} cm is the wall column alone: "
                   "the two wall figures are the same (a wider --wall-width averages more)."]
    md += ["", "| run | wall time [s] | CPU time [s] | steps | moves | mass defect [m^2] | relative defect |",
           "|---|---|---|---|---|---|---|"]
    for v in variants:
        s = summ[v]
        moves = s.get("interfaces", {}).get("moves", 0)
        c = f"{cpu[v]:.1f}" if cpu[v] else "-"
        md.append(f"| {v} | {wall[v]:.1f} | {c} | {s['steps']} | {moves} | "
                  f"{s['mass_balance']['defect']:.2e} | {s['mass_balance']['relative_defect']:.2e} |")
    md += ["", f"Ideal saving (share of the full 2D run's material, its depth summed over the columns and "
           f"the outputs, that lies in the dynamic run's 1D parts): {100 * ideal:.1f} %; achieved (1 - {cost_name} dynamic / "
           f"full): {100 * achieved:.1f} %; achieved / ideal: "
           f"{(achieved / ideal if ideal > 0 else float('nan')):.2f}.", ""]
    for v in failed:
        md.append(f"The {v} run stopped before the end (see OUTDIR/{v}/summary.json); it is not "
                  f"in the tables.")
    open(os.path.join(args.outdir, "comparison.md"), "w").write("\n".join(md) + "\n")
    print("\n".join(md))

    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("compare_layouts: no matplotlib, no xt.png")
        return
    fig, ax = plt.subplots(figsize=(7, 5))
    ts = [t for t in times if t in prof["dynamic"]]
    # the depth on the full run's columns: a dynamic run whose 1D cells are not the columns'
    # width has other points after each move (numpy refused the ragged field; a review)
    xs = [p[0] for p in prof["full"][ts[0]]]
    H = [[p[1] for p in on_grid(prof["full"][ts[0]], prof["dynamic"][t])] for t in ts]
    if len(ts) > 1:
        from matplotlib.colors import PowerNorm
        m = ax.pcolormesh(xs, ts, H, shading="nearest", cmap="Greys", norm=PowerNorm(0.5))
        fig.colorbar(m, ax=ax, label="h (dynamic run) [m]")
    for v, colour, size in (("static", "b", 3), ("apriori", "g", 3), ("dynamic", "r", 5)):
        pts = [(x, t) for t in ts if v in prof and t in prof[v]
               for x in interfaces(prof[v][t], summ.get(v), t)]
        if pts:
            ax.plot([p[0] for p in pts], [p[1] for p in pts], colour + "o", ms=size,
                    mfc="none" if v == "dynamic" else colour, label=f"interfaces, {v}")
    sh = [(shock(prof["full"][t], L), t) for t in times if shock(prof["full"][t], L) is not None]
    if sh:
        ax.plot([p[0] for p in sh], [p[1] for p in sh], "k-", lw=2, label="shock, full 2D")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("t [s]")
    ax.set_title(f"{args.family}: interfaces and shock")
    ax.legend(loc="best", fontsize=8)  # upper left hid the gate part's interfaces late in a run
    fig.tight_layout()
    fig.savefig(os.path.join(args.outdir, "xt.png"), dpi=120)
    print("wrote", os.path.join(args.outdir, "xt.png"))


if __name__ == "__main__":
    main()
