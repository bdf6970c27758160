#!/usr/bin/python3
"""The plug law of the 2D model at any layer depth: a sweep, not a test.

A Drucker-Prager layer on a periodic incline with a Coulomb bed, released from rest, slides as
a rigid plug when sin(phi) > tan(delta), and its velocity follows the model's own regularised
friction law (paper eq. 12),
    u' = g sin(zeta) - g cos(zeta) tan(delta) (1 - exp(-m_c u)),   u(0) = 0,
whatever its depth. The suite's plug tests take chosen depths (whole cells, half a cell, depths
ending on a marker row); this sweep takes the depths a user would (2.3 or 2.8 cells, ...) and
prints, for each run, the largest relative error of the layer's mean velocity (the depth-weighted
mean of profiles.csv's u_mean) against the law over the outputs from 0.05 s to the end, and the
error at the end.

  plug_law.py BUILD OUTDIR [--cell MM] [--depths CELLS ...] [--angles Z/D/P ...]
              [--forms F ...] [--my M ...] [--mc MC] [--end T] [--interval DT] [--set N=V ...]

  --depths   layer depths in cells (default 0.46 0.9 1.4 1.8 2.3 2.8 4.3)
  --angles   slope/bed friction/internal friction angles in degrees (default 30/22/33)
  --forms    'Surface cell mass' values: full, weight, share (default: all three)
  --my       'Rheology->Regularisation' m_y [s] (default 100)
  --set      any other parameter of the N-DAM list, e.g. --set 'Surface pressure=Ghost fluid'

The runs go to OUTDIR/<form>_<angles>_my<m_y>_d<depth>_<options>/ (40 columns, periodic, 6
cells high; about a second each at 5 mm), <options> a digest of the other settings, so that a
sweep with other options does not meet the runs of an earlier one. A run that fails is counted,
and the script then exits with 1. docs/validation.md ("The plug law at any depth") gives what
this printed on 2026-12-07.
"""
import argparse
import csv
import math
import os
import subprocess
import sys
import hashlib
from xml.sax.saxutils import escape as xml_escape
from collections import defaultdict

FORMS = {"full": "Full cell", "weight": "Full cell and weight", "share": "Material share"}

SCENE = """<ParameterList name="granflow">
  <Parameter name="Name" type="string" value="plug_law"/>
  <Parameter name="Model" type="string" value="N-DAM"/>
  <ParameterList name="Material">
    <Parameter name="Internal friction angle" type="double" value="{phi}"/>
    <Parameter name="Bed friction angle" type="double" value="{delta}"/>
  </ParameterList>
  <ParameterList name="Channel">
    <Parameter name="Length" type="double" value="{length}"/>
    <Parameter name="Slope angle" type="double" value="{zeta}"/>
    <ParameterList name="Left boundary"><Parameter name="Type" type="string" value="Periodic"/></ParameterList>
    <ParameterList name="Right boundary"><Parameter name="Type" type="string" value="Periodic"/></ParameterList>
  </ParameterList>
  <ParameterList name="N-DAM">
    <Parameter name="Cells x" type="int" value="40"/>
    <Parameter name="Cells z" type="int" value="{nz}"/>
    <Parameter name="Height" type="double" value="{height}"/>
    <Parameter name="Free surface" type="bool" value="true"/>
    <Parameter name="Initial depth" type="double" value="{depth}"/>
    <Parameter name="Friction regularisation" type="double" value="{mc}"/>
    <Parameter name="Surface cell mass" type="string" value="{form}"/>{extra}
    <ParameterList name="Boundaries">
      <Parameter name="Left" type="string" value="Periodic"/>
      <Parameter name="Right" type="string" value="Periodic"/>
      <Parameter name="Bottom" type="string" value="Coulomb"/>
      <Parameter name="Top" type="string" value="Free-slip"/>
    </ParameterList>
  </ParameterList>
  <ParameterList name="Rheology">
    <Parameter name="Model" type="string" value="Drucker-Prager"/>
    <Parameter name="Viscosity" type="double" value="0.003"/>
    <Parameter name="Regularisation" type="double" value="{my}"/>
  </ParameterList>
  <ParameterList name="Time"><Parameter name="End time" type="double" value="{end}"/></ParameterList>
  <ParameterList name="Output">
    <Parameter name="Directory" type="string" value="{out}"/>
    <Parameter name="Interval" type="double" value="{interval}"/>
  </ParameterList>
</ParameterList>
"""


def law(zeta, delta, mc, times, g=9.81):
    """u(t) of u' = g sin(zeta) - g cos(zeta) tan(delta) (1 - exp(-mc u)), u(0) = 0 (RK4)."""
    a, b = g * math.sin(zeta), g * math.cos(zeta) * math.tan(delta)
    f = lambda u: a - b * (1.0 - math.exp(-mc * u))
    out, u, t, h = {}, 0.0, 0.0, 1e-5
    for T in sorted(times):
        while t < T - 1e-12:
            s = min(h, T - t)
            k1 = f(u); k2 = f(u + s / 2 * k1); k3 = f(u + s / 2 * k2); k4 = f(u + s * k3)
            u += s / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            t += s
        out[T] = u
    return out


def layer_velocity(path):
    """The layer's mean velocity at each output: sum(h u_mean) / sum(h) over the columns."""
    rows = defaultdict(lambda: [0.0, 0.0])
    with open(path) as f:
        for r in csv.DictReader(f):
            h = float(r["h"])
            acc = rows[round(float(r["t"]), 9)]
            acc[0] += h * float(r["u_mean"])
            acc[1] += h
    return {t: (q / h if h > 0 else 0.0) for t, (q, h) in rows.items()}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("build")
    ap.add_argument("outdir")
    ap.add_argument("--cell", type=float, default=5.0, help="[mm] cell size (dx = dz)")
    ap.add_argument("--depths", type=float, nargs="+", default=[0.46, 0.9, 1.4, 1.8, 2.3, 2.8, 4.3])
    ap.add_argument("--angles", nargs="+", default=["30/22/33"])
    ap.add_argument("--forms", nargs="+", choices=sorted(FORMS), default=["full", "weight", "share"])
    ap.add_argument("--my", type=float, nargs="+", default=[100.0])
    ap.add_argument("--mc", type=float, default=100.0)
    ap.add_argument("--end", type=float, default=1.0)
    ap.add_argument("--interval", type=float, default=0.05)
    ap.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    args = ap.parse_args()
    exe = os.path.join(args.build, "apps", "granflow")
    if not os.access(exe, os.X_OK):
        ap.error("BUILD %s: no apps/granflow there" % args.build)
    for v, name in ((args.cell, "--cell"), (args.mc, "--mc"), (args.end, "--end"),
                    (args.interval, "--interval")):
        if not v > 0:
            ap.error("%s must be > 0 (got %g)" % (name, v))
    if any(not d > 0 or d >= 5 for d in args.depths):
        ap.error("--depths: in cells, each in (0, 5) (the box is 6 cells high)")
    # the type of each parameter of the N-DAM list (the section '### `N-DAM`' of model N-DAM in
    # the reference that granflow prints; a name from another list would be written into N-DAM
    # and refused there)
    ref = subprocess.run([exe, "--parameters"], capture_output=True, text=True).stdout
    types, model, section = {}, None, None
    for line in ref.splitlines():
        if line.startswith("## Model "):
            model = line.split("`")[1] if "`" in line else None
        elif line.startswith("#"):
            section = line.lstrip("#").strip().strip("`")
        cells = [c.strip() for c in line.split("|")]
        if (model == "N-DAM" and section == "N-DAM" and len(cells) > 3
                and cells[1].startswith("`") and cells[1].endswith("`")):
            types.setdefault(cells[1].strip("`"), cells[2])
    if not types:
        ap.error("BUILD %s: its granflow --parameters lists no N-DAM parameters" % args.build)
    extra = ""
    for item in args.set:
        name, eq, value = item.partition("=")
        if not eq or not name or not value:
            ap.error("--set '%s': NAME=VALUE" % item)
        if name not in types:
            ap.error("--set '%s': the N-DAM list has no parameter '%s'" % (item, name))
        extra += '\n    <Parameter name="%s" type="%s" value="%s"/>' % (
            xml_escape(name, {'"': "&quot;"}), types[name], xml_escape(value, {'"': "&quot;"}))
    if not args.end >= 0.05 + args.interval - 1e-12:
        ap.error("--end %g: the law is compared from 0.05 s on; allowed: at least 0.05 s plus "
                 "one --interval" % args.end)
    angles = []
    for ang in args.angles:
        try:
            zeta, delta, phi = (float(a) for a in ang.split("/"))
        except ValueError:
            ap.error("--angles '%s': ZETA/DELTA/PHI in degrees" % ang)
        if not math.sin(math.radians(phi)) > math.tan(math.radians(delta)) or not zeta > delta:
            ap.error("--angles '%s': a sliding plug needs sin(phi) > tan(delta) and "
                     "zeta > delta" % ang)
        angles.append((ang, zeta, delta, phi))
    digest = hashlib.sha1(repr((args.cell, args.mc, args.end, args.interval,
                                sorted(args.set))).encode()).hexdigest()[:8]
    dz = args.cell / 1000.0
    os.makedirs(args.outdir, exist_ok=True)
    print("| form | angles | m_y | depth [cells] | max error 0.05 s..end | error at end |")
    print("|---|---|---|---|---|---|")
    worst, failed = 0.0, 0
    for form in args.forms:
        for ang, zeta, delta, phi in angles:
            for my in args.my:
                for d in args.depths:
                    tag = "%s_%s_my%g_d%g_%s" % (form, ang.replace("/", "-"), my, d, digest)
                    run = os.path.abspath(os.path.join(args.outdir, tag))
                    scene = run + ".xml"
                    with open(scene, "w") as f:
                        f.write(SCENE.format(phi=phi, delta=delta, zeta=zeta, length=40 * dz,
                                             nz=6, height=6 * dz, depth=d * dz, mc=args.mc,
                                             form=FORMS[form], extra=extra, my=my,
                                             end=args.end, out=run, interval=args.interval))
                    p = subprocess.run([exe, scene], capture_output=True, text=True)
                    if p.returncode != 0:
                        failed += 1
                        last = (p.stderr.strip().splitlines() or ["(no message)"])[-1]
                        print("| %s | %s | %g | %g | run failed (exit %d): %s | |" % (
                            form, ang, my, d, p.returncode, last))
                        continue
                    u = layer_velocity(os.path.join(run, "profiles.csv"))
                    times = [t for t in sorted(u) if t >= 0.05 - 1e-9]
                    ref = law(math.radians(zeta), math.radians(delta), args.mc, times)
                    errs = {t: u[t] / ref[t] - 1.0 for t in times}
                    t_max = max(errs, key=lambda t: abs(errs[t]))
                    worst = max(worst, abs(errs[t_max]))
                    print("| %s | %s | %g | %g | %+.2f %% (t = %.2f s) | %+.2f %% |" % (
                        form, ang, my, d, 100 * errs[t_max], t_max, 100 * errs[times[-1]]))
    print("\nlargest |error| of the sweep: %.2f %%" % (100 * worst))
    if failed:
        print("%d run(s) failed; the largest error is over the others" % failed)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
