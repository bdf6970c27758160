#!/usr/bin/env python3
"""Holes in the material of a free-surface 2D run, from its fields.h5 (issue 11).

A hole is an Empty cell whose 4-connected region of Empty cells reaches neither the top row of
the box (the atmosphere) nor an open side: an enclosed void, with material or a wall on every
path out. The air under a free jet's overhang reaches the atmosphere around the jet and is not
a hole. Open sides, in a coupled run's channel-wide mesh (flag -1 in the 1D columns): a 2D
part's outflow into a 1D part (every row), and a 2D part's inflow from a 1D part above the 1D
layer (the rows whose bottom is at or above the DAM depth of the 1D cell next to it: over the
depth-averaged layer lies the atmosphere, not a wall); the channel's right end when its Right
boundary is an Outflow (read from the run's summary.json). The same definition as
ndam::enclosed_voids with NdamSolver::void_sides (include/granflow/markers/markers.hpp), which
the test suite applies at every step (the solver opens the inflow side above the DAM depth at
the interface; the output has the DAM depth of the 1D cell next to it); this
script applies it to every output of a run. Also prints the bottom pressure of the
last column of the last 2D mesh (the wall column in a chute ending at a wall).

Uses h5dump/h5ls (hdf5-tools), no Python HDF5 module.
Usage: scripts/find_holes.py OUTPUT_DIR [--quiet]
Exit status 1 if any hole was found, 0 if none, 2 if the directory holds no 2D fields."""
import argparse
import bisect
import json
import os
import re
import subprocess
import sys
from collections import deque

EMPTY, FLUID, SURFACE, ONE_D = 3, 1, 2, -1


def run(*args):
    return subprocess.run(args, capture_output=True, text=True, check=True).stdout


def members(f, g):
    """h5ls of snapshot g of fields.h5: its meshes. fields.h5 links each snapshot to its own
    file in fields.h5.d (an external link, which h5ls shows rather than enters)."""
    out = run("h5ls", f"{f}/{g}")
    link = re.search(r"External Link \{(.+?)//\}", out)
    return run("h5ls", os.path.join(os.path.dirname(f), link.group(1))) if link else out


def dataset(f, path):
    txt = run("h5dump", "-w", "0", "-y", "-d", path, f)
    dims = [int(v) for v in re.search(r"SIMPLE \{ \( ([\d, ]+) \)", txt).group(1).split(",")]
    body = txt[txt.index("DATA {") + 6:txt.rindex("}")]
    vals = [float(v) for v in re.findall(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?", body)]
    if len(dims) == 2:  # z-major: value (k, i) at k * nx + i
        nz, nx = dims
        return [[vals[k * nx + i] for i in range(nx)] for k in range(nz)]
    return vals


def holes(flag, open_right, z_nodes=None, depth_1d=None):
    """Cells (k, i) of enclosed voids; flag[k][i] the cell flags of one mesh (ONE_D in the 1D
    columns of a channel-wide mesh, whose depths depth_1d[i] open the sides next to them)."""
    nz, nx = len(flag), len(flag[0])
    reached = [[False] * nx for _ in range(nz)]
    todo = deque()

    def seed(k, i):
        if flag[k][i] == EMPTY and not reached[k][i]:
            reached[k][i] = True
            todo.append((k, i))

    for i in range(nx):
        seed(nz - 1, i)
    if open_right:
        for k in range(nz):
            seed(k, nx - 1)
    for i in range(nx):
        if flag[0][i] == ONE_D:
            continue
        for k in range(nz):
            if i + 1 < nx and flag[k][i + 1] == ONE_D:  # outflow into a 1D part
                seed(k, i)
            if i > 0 and flag[k][i - 1] == ONE_D and z_nodes[k] >= depth_1d[i - 1]:
                seed(k, i)  # inflow from a 1D part, above its layer: the atmosphere
    while todo:
        k, i = todo.popleft()
        for kk, ii in ((k + 1, i), (k - 1, i), (k, i + 1), (k, i - 1)):
            if 0 <= kk < nz and 0 <= ii < nx:
                seed(kk, ii)
    return [(k, i) for k in range(nz) for i in range(nx) if flag[k][i] == EMPTY and not reached[k][i]]


def main():
    # argparse: -h/--help print the usage, and a second directory or an unknown option is
    # refused (an independent run: -h was taken as a run directory, a second directory ignored)
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("output_dir", help="a granflow run directory with field output")
    ap.add_argument("--quiet", action="store_true", help="print only the summary line")
    a = ap.parse_args()
    out, quiet = a.output_dir, a.quiet
    f = f"{out}/fields.h5"
    # a run directory with 2D fields, or a message and exit 2 (not 1: that means holes found)
    try:
        steps = re.findall(r"^(step_\d+)", run("h5ls", f), re.M)
    except (OSError, subprocess.CalledProcessError):
        print(f"find_holes: no readable {f} (a granflow run directory with field output?)",
              file=sys.stderr)
        return 2
    if not any(re.search(r"^ndam", members(f, g), re.M) for g in steps):
        print(f"find_holes: {out} has no 2D (N-DAM) mesh in its fields: a DAM run has no cells "
              "to look for holes in", file=sys.stderr)
        return 2
    # the channel's right end: an outflow is open on every row (NdamConfig::outflow_right)
    outflow_end = False
    try:
        with open(f"{out}/summary.json") as sj:
            params = json.load(sj).get("parameters", {})
        outflow_end = params.get("Channel", {}).get("Right boundary", {}).get("Type") == "Outflow"
    except (OSError, ValueError):
        pass
    total, outputs_with_holes = 0, 0
    for g in steps:
        t = float(re.search(r"\(0\): ([-+\deE.]+)", run("h5dump", "-a", f"/{g}/time", f)).group(1))
        meshes = re.findall(r"^(ndam\S*)", members(f, g), re.M)
        found = []
        for j, m in enumerate(meshes):
            flag = [[int(v) for v in row] for row in dataset(f, f"/{g}/{m}/flag")]
            x = dataset(f, f"/{g}/{m}/x_nodes")
            z = dataset(f, f"/{g}/{m}/z_nodes")
            # every 2D mesh but the last one of a coupled run drains into its neighbour
            depth_1d = None
            if any(v == ONE_D for v in flag[0]):  # channel-wide mesh: the DAM's depth per column
                xd, hd = dataset(f, f"/{g}/dam/x_nodes"), dataset(f, f"/{g}/dam/h")
                hd = hd[0] if isinstance(hd[0], list) else hd
                last = len(hd) - 1  # the DAM cell holding each 2D column's centre
                depth_1d = [hd[max(0, min(last, bisect.bisect_right(xd, 0.5 * (x[i] + x[i + 1])) - 1))]
                            for i in range(len(x) - 1)]
            open_right = j + 1 < len(meshes) or outflow_end
            for k, i in holes(flag, open_right=open_right, z_nodes=z, depth_1d=depth_1d):
                found.append(f"{m}: x = {0.5 * (x[i] + x[i + 1]):.4f} m, z = {0.5 * (z[k] + z[k + 1]):.4f} m")
        p = dataset(f, f"/{g}/{meshes[-1]}/p_Pa")
        total += len(found)
        outputs_with_holes += 1 if found else 0
        if not quiet or found:
            print(f"t = {t:.4f} s: {len(found)} hole cells; wall-column bottom p = {p[0][-1]:.0f} Pa"
                  + ("".join("\n    " + s for s in found)))
    print(f"{out}: {total} hole cells in {outputs_with_holes} of {len(steps)} outputs")
    return 1 if total else 0


if __name__ == "__main__":
    sys.exit(main())
