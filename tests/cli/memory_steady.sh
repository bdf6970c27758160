#!/usr/bin/env bash
# Memory does not grow with the steps (issue 14 item 5): Setup I in full 2D (10 mm cells, steady
# from about t = 1 s) run to 0.75 s and 10x longer, to 7.5 s (5500 steps). The longer run's peak
# (VmHWM) must stay within 2 % of the shorter one's: measured 84.91 against 84.60 MB (+0.4 %,
# malloc's arenas settling; also without field output). 2 % = 1.7 MB is what a leak of 300 B
# per step would add over the 5500 steps; a field of the grid per step (18 kB) would add 100 MB.
# And the resident set at the outputs of the steady part (t >= 1.5 s) grows by less than 1.5 %
# (measured 0.6-0.85 MB, 0.7-1.0 %: malloc settling, 0.4 MB of it in the first 1.5 s), and by
# less than 0.5 % over its last 3 s (measured 0.12 MB, 0.14 %), where a leak of 200 B per step
# (about 2200 steps there) would add 0.44 MB; while the material area stays within 1 % of its
# mean (the run is steady: the memory does not follow anything else). (Until 2026-12-02 one
# bound of 1 % over the whole steady part, which a run failed at 1.0 %.)
# The peak of one short run varies between identical runs (83.1-84.1 MB on 2026-12-02: malloc's
# arenas and the MPI runtime), by up to half the 2 % margin, and one CI run failed at +2.05 % on
# a low short run; so the short run is made three times and the 10x longer run is held against
# the highest of their peaks (the short run's peak with its noise).
source "$SRC/record_lib.sh"
rm -rf memory_steady && mkdir memory_steady && cd memory_steady || exit 1
for R in 0.75_1 0.75_2 0.75_3 7.5; do
  T=${R%_*}
  scene "$SRC/../../inputs/setup1_ndam.xml" s$R.xml -e 's#"Cells x" type="int" value="300"#"Cells x" type="int" value="150"#' \
        -e 's#"Cells z" type="int" value="30"#"Cells z" type="int" value="15"#' \
        -e "s#\"End time\" type=\"double\" value=\"0.75\"#\"End time\" type=\"double\" value=\"$T\"#" \
        -e "s#name=\"Directory\" type=\"string\" value=\"[^\"]*\"#name=\"Directory\" type=\"string\" value=\"r$R\"#"
  grep -q "value=\"$T\"" s$R.xml || fail "the scene variant did not take End time $T"
  expect 0 "completed at t = $T s" s$R.xml
done
/usr/bin/python3 - <<'PY' || fail "memory grows with the steps"
import json
short = [json.load(open("r0.75_%d/summary.json" % i))["memory"]["peak_resident_bytes_rank0"]
         for i in (1, 2, 3)]
b = json.load(open("r7.5/summary.json"))["memory"]
pa, pb = max(short), b["peak_resident_bytes_rank0"]
print("peak: 0.75 s %s MB (highest %.2f), 7.5 s %.2f MB (%+.2f %%)"
      % (" / ".join("%.2f" % (v / 1e6) for v in short), pa / 1e6, pb / 1e6, 100 * (pb / pa - 1)))
assert pb <= 1.02 * pa, "the 10x longer run peaks %.1f %% higher" % (100 * (pb / pa - 1))
steady = [m for m in b["at_outputs"] if m["t"] >= 1.5 - 1e-9]
assert len(steady) >= 20, len(steady)
area = [m["material_m2"] for m in steady]
mean = sum(area) / len(area)
assert max(abs(x - mean) for x in area) <= 0.01 * mean, "not steady: material %s" % area
r0, r1 = steady[0]["resident_bytes"], max(m["resident_bytes"] for m in steady)
late = [m for m in steady if m["t"] >= 4.5 - 1e-9]
l0, l1 = late[0]["resident_bytes"], max(m["resident_bytes"] for m in late)
print("resident over the steady part: %.2f -> at most %.2f MB (%+.2f %%); from 4.5 s %.2f -> %.2f MB (%+.2f %%)"
      % (r0 / 1e6, r1 / 1e6, 100 * (r1 / r0 - 1), l0 / 1e6, l1 / 1e6, 100 * (l1 / l0 - 1)))
assert r1 <= 1.015 * r0, "the resident set grows by %.1f %% while the flow is steady" % (100 * (r1 / r0 - 1))
assert l1 <= 1.005 * l0, "the resident set grows by %.2f %% over the last 3 s" % (100 * (l1 / l0 - 1))
PY
echo "memory steady checks passed"
