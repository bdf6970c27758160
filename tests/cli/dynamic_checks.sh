#!/usr/bin/env bash
# The domain manager's checks on a chute that is empty at t = 0 (an independent run,
# 2026-12-07): with a long 'Check interval' (10 s, allowed) nothing on the channel bounded the
# next check, so the layout of t = 0 was held for the whole run, and the shock piled up at a
# fixed interface (eps 0.14 in the last 1D cell against the threshold 0.1). The gate's inflow
# now bounds it too: the next check comes before a signal from the gate, at |u_in| +
# sqrt(g cos(zeta) K_act h_in), can cross the margin. Setup II at 10 mm, all 1D at the gate
# ({1D, 2D} at 0.95 m): the manager must create the gate's 2D part early, within the first
# few checks, as it does with the shipped 5 ms interval.
source "$SRC/record_lib.sh"
rm -rf dynamic_checks && mkdir dynamic_checks && cd dynamic_checks || exit 1
# dyn XML DIR CHECK_INTERVAL: the record scene as a dynamic coupled run to 0.1 s
dyn() {
  scene "$SRC/record_ndam.xml" "$1" -e "s|value=\"record_dir\"/>|value=\"$2\"/>|" \
    -e 's|"End time" type="double" value="0.02"|"End time" type="double" value="0.1"|' \
    -e 's|"Model" type="string" value="N-DAM"|"Model" type="string" value="Coupled"|' \
    -e "s|<ParameterList name=\"Material\">|<ParameterList name=\"Decomposition\"><Parameter name=\"Layout\" type=\"string\" value=\"Dynamic\"/><Parameter name=\"Models\" type=\"Array(string)\" value=\"{1D, 2D}\"/><Parameter name=\"Interfaces\" type=\"Array(double)\" value=\"{0.95}\"/><Parameter name=\"Check interval\" type=\"double\" value=\"$3\"/><Parameter name=\"Hold time\" type=\"double\" value=\"$3\"/></ParameterList><ParameterList name=\"DAM\"><Parameter name=\"Cells\" type=\"int\" value=\"100\"/></ParameterList>&|"
}
dyn short.xml short 0.005
expect 0 "completed at t = 0.1 s" short.xml
dyn long.xml long 10
expect 0 "completed at t = 0.1 s" long.xml
t_short=$(gate_part_created short); t_long=$(gate_part_created long)
early=$(json long/summary.json "s['solver_statistics']['coupled']['domain_manager']['checks_brought_forward']")
echo "gate part created at $t_short s (Check interval 5 ms) and $t_long s (10 s, $early checks brought forward)"
# The signal from the gate needs max(Margin, slot) / (u_in + sqrt(beta h_in)) = 0.05 / 0.86 s =
# 58 ms to cross the default margin, so the first check after t = 0 comes at the end of the
# step that reaches 58 ms (steps of 5 ms here: 60 ms), and the gate part is created there; the
# 5 ms interval creates it at its second check (10 ms). Before, the 10 s interval never
# created it (-1). Bounds: one step beyond each.
python3 -c "import sys; sys.exit(0 if 0 < $t_short < 0.0151 and 0 < $t_long < 0.0651 and $early >= 1 else 1)" ||
  fail "with a 10 s Check interval the gate's 2D part came at $t_long s ($early checks brought forward)"
echo "dynamic check tests passed"
