# Helpers of the run-record tests (restart_checks.sh, run_directory.sh, interrupt.sh).
# Usage: source it with EXE (granflow) and SRC (tests/cli) set; the tests run in a scratch
# directory of the build tree.
set -u
fail() { echo "FAIL: $*" >&2; exit 1; }

# expect CODE REGEX ARGS...: granflow ARGS must exit with CODE and print a line matching REGEX
# (grep -E), and no HDF5 library diagnostic ("HDF5-DIAG") may reach the user.
expect() {
  local code=$1 regex=$2
  shift 2
  local out rc
  out=$("$EXE" "$@" 2>&1)
  rc=$?
  echo "granflow $* -> $rc"
  echo "$out" | grep -v '^t = ' | sed 's/^/  | /'
  [ "$rc" = "$code" ] || fail "expected exit code $code, got $rc"
  echo "$out" | grep -Eq -- "$regex" || fail "output does not match '$regex'"
  if echo "$out" | grep -q "HDF5-DIAG"; then fail "an HDF5 diagnostic reached the user"; fi
}

# scene SRC_XML OUT_XML SED_EXPRESSIONS...: a variant of a test scene
scene() {
  local in=$1 out=$2
  shift 2
  sed "$@" "$in" > "$out"
}

# json FILE EXPR: a value of a summary.json (python3's json module; the file is `s`)
json() { python3 -c "import json,sys; s=json.load(open('$1')); print($2)"; }

# gate_part_created DIR: when the domain manager first made the channel's upstream end 2D (-1:
# never), from DIR/summary.json's move log
gate_part_created() {
  json "$1/summary.json" "min((m['t'] for m in s['solver_statistics']['coupled']['domain_manager']['log'] if m['after'].startswith('2D')), default=-1)"
}

# rows_at FILE T: the profiles.csv rows of output time T
rows_at() { grep -E "^$2," "$1"; }
