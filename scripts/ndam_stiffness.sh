#!/bin/sh
# Stiffness sweep of Setup II in full 2D (issue 4 item 7): m_y, m_c over three decades and nu
# from 0.0003 to 0.3 m^2/s, each to t = 0.75 s from inputs/setup2_ndam.xml. Prints one line per
# run: parameter, value, status, steps, dt_min, wall time. Usage: scripts/ndam_stiffness.sh BUILD_DIR WORK_DIR
set -e
B=${1:-build}; W=${2:-/tmp/ndam_stiffness}; SRC=$(cd "$(dirname "$0")/.." && pwd)
mkdir -p "$W"; cd "$W"
run() {  # name sed-expression
  sed -e "$2" -e "s|output/setup2_ndam|output/$1|" "$SRC/inputs/setup2_ndam.xml" > "$1.xml"
  "$B/apps/granflow" "$1.xml" > "$1.log" 2>&1 || true
  python3 - "$1" <<'PY'
import json, sys
n = sys.argv[1]
try:
    j = json.load(open(f"output/{n}/summary.json")); s = j["solver_statistics"]["ndam"]
    print(f"{n:14s} {j['status']:10s} t={j['final_time']:.3f} steps={s['steps']:5d} dt_min={s['dt_min']:.2e} "
          f"wall={j['wall_time']['total']:.1f}s max_nu_eff={s['max_nu_eff']:.3g} reason={j['reason']}")
except Exception as e:
    print(n, "no summary:", e)
PY
}
for my in 1 10 1000 10000; do run my_$my "s|name=\"Regularisation\" type=\"double\" value=\"100\"|name=\"Regularisation\" type=\"double\" value=\"$my\"|"; done
for mc in 1 10 1000 10000; do run mc_$mc "s|name=\"Friction regularisation\" type=\"double\" value=\"100\"|name=\"Friction regularisation\" type=\"double\" value=\"$mc\"|"; done
for nu in 0.0003 0.03 0.3; do run nu_$nu "s|name=\"Viscosity\" type=\"double\" value=\"0.003\"|name=\"Viscosity\" type=\"double\" value=\"$nu\"|"; done
