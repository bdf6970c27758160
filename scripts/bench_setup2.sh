#!/usr/bin/env bash
# Speed benchmark (not a test): Setup II in full 2D (inputs/setup2_ndam.xml, Drucker-Prager,
# implicit momentum) to t = 0.75 s at several resolutions and rank counts, one run at a time,
# then a table of wall time, steps, per-phase seconds and Krylov iterations from summary.json.
#
# Usage: scripts/bench_setup2.sh [BUILD_DIR=build] [OUT_DIR=/tmp/granflow_bench] [RUNS...]
#   RUNS are CELLSX:CELLSZ:NP triples; default "384:58:1 768:116:1" (2.6 mm and 1.3 mm, np 1).
#   GRANFLOW=/path/to/granflow overrides BUILD_DIR/apps/granflow (to compare two builds).
# Example: scripts/bench_setup2.sh build /tmp/bench 200:30:1 384:58:1 768:116:1 768:116:2
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-build}
out=${2:-/tmp/granflow_bench}
shift $(( $# >= 2 ? 2 : $# )) || true
runs=("$@")
[ ${#runs[@]} -eq 0 ] && runs=(384:58:1 768:116:1)
exe=${GRANFLOW:-$build/apps/granflow}
mkdir -p "$out"
for r in "${runs[@]}"; do
  IFS=: read -r nx nz np <<<"$r"
  name="setup2_${nx}x${nz}_np${np}"
  scene="$out/$name.xml"
  sed -e "s#name=\"Cells x\" type=\"int\" value=\"[0-9]*\"#name=\"Cells x\" type=\"int\" value=\"$nx\"#" \
      -e "s#name=\"Cells z\" type=\"int\" value=\"[0-9]*\"#name=\"Cells z\" type=\"int\" value=\"$nz\"#" \
      -e "s#name=\"Directory\" type=\"string\" value=\"[^\"]*\"#name=\"Directory\" type=\"string\" value=\"$out/$name\"#" \
      "$here/inputs/setup2_ndam.xml" >"$scene"
  echo "bench: $name" >&2
  if [ "$np" -gt 1 ]; then
    mpiexec --allow-run-as-root --oversubscribe -n "$np" "$exe" "$scene" >"$out/$name.log" 2>&1 || true
  else
    "$exe" "$scene" >"$out/$name.log" 2>&1 || true
  fi
done
/usr/bin/python3 - "$out" "${runs[@]}" <<'EOF'
import json, sys
out, runs = sys.argv[1], sys.argv[2:]
print("| cells | np | wall [s] | steps | momentum | pressure | markers | output | other | "
      "Krylov/solve p / m | precond. setups p / m | status |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|")
for r in runs:
    nx, nz, np_ = r.split(":")
    d = f"{out}/setup2_{nx}x{nz}_np{np_}"
    try:
        s = json.load(open(f"{d}/summary.json"))
    except OSError:
        print(f"| {nx} x {nz} | {np_} | - | - | - | - | - | - | - | - | - | no summary |")
        continue
    n = s["solver_statistics"]["ndam"]
    sec = n["seconds"]
    out_s = sec.get("output", s["wall_time"].get("output", 0.0))
    setups = (f'{n.get("pressure_preconditioner_setups", "-")} / '
              f'{n.get("momentum_preconditioner_setups", "-")}')
    print(f'| {nx} x {nz} | {np_} | {s["wall_time"]["total"]:.1f} | {n["steps"]} | '
          f'{sec["momentum"]:.1f} | {sec["pressure"]:.1f} | {sec["markers"]:.1f} | {out_s:.1f} | '
          f'{sec["other"]:.1f} | {n["pressure_krylov_iterations_per_solve"]:.1f} / '
          f'{n["momentum_krylov_iterations_per_solve"]:.1f} | {setups} | {s["status"]} |')
EOF
