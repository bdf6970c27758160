#!/usr/bin/env bash
# An interface that flickers is counted and warned of (DomainManager::book_changes: a column
# given back to the DAM for the third time within twenty Hold times). An
# independent run (session 40) set the band between 'Lower threshold' and 'Shallowness
# threshold' to 0.09 - 0.1 and 'Hold time' to the 'Check interval' on a steady open chute: the
# gate part's interface moved 0.16 <-> 0.165 m every 2-3 checks (61 moves in steady flow) and the
# run said nothing. Asserted:
# 1. that scene (dynamic_flicker.xml, 10 mm, to 1 s) warns, naming the column, both thresholds
#    and the hold time, and summary.json counts the flickers (6 at this build; at least one: any
#    count proves the detection, the number depends on the noise);
# 2. a restart from its checkpoint at 0.5 s reports the straight run's count, first flicker and
#    moves (the counters are part of the manager's state in the checkpoint);
# 3. the same chute with the shipped hysteresis (0.05 - 0.1, Hold time 0.05 s) moves as it
#    needs (16 moves here) but no column changes model a third time: no count, no warning.
source "$SRC/record_lib.sh"
rm -rf dynamic_flicker && mkdir dynamic_flicker && cd dynamic_flicker || exit 1
dm="s['solver_statistics']['coupled']['domain_manager']"
cp "$SRC/dynamic_flicker.xml" narrow.xml
expect 0 "column at x = [0-9.]+ m went back to the 1D model for the third time.*'Lower threshold' \(0.09\) and 'Shallowness threshold' \(0.1\) held for 'Hold time' \(0.01 s\)" narrow.xml
n=$(json flicker/summary.json "$dm['flickers']")
first=$(json flicker/summary.json "$dm['first_flicker']")
moves=$(json flicker/summary.json "$dm['moves']")
echo "narrow band: $moves moves, $n flickers, first $first"
[ "$n" -ge 1 ] || fail "the flickering interface was not counted"

scene narrow.xml half.xml -e 's|name="End time" type="double" value="1"|name="End time" type="double" value="0.5"|' \
  -e 's|name="Directory" type="string" value="flicker"|name="Directory" type="string" value="half"|'
expect 0 "completed at t = 0.5 s" half.xml
scene narrow.xml resumed.xml -e 's|name="Directory" type="string" value="flicker"|name="Directory" type="string" value="resumed"|' \
  -e 's|<Parameter name="Fields"|<Parameter name="Restart from" type="string" value="half/checkpoint.h5"/>&|'
expect 0 "completed at t = 1 s" resumed.xml
for k in flickers first_flicker moves; do
  a=$(json flicker/summary.json "$dm['$k']"); b=$(json resumed/summary.json "$dm['$k']")
  echo "$k: straight $a, restarted $b"
  [ "$a" = "$b" ] || fail "$k differs after a restart: $a against $b"
done

scene narrow.xml shipped.xml -e 's|"Lower threshold" type="double" value="0.09"|"Lower threshold" type="double" value="0.05"|' \
  -e 's|"Hold time" type="double" value="0.01"|"Hold time" type="double" value="0.05"|' \
  -e 's|name="Directory" type="string" value="flicker"|name="Directory" type="string" value="shipped"|'
out=$("$EXE" shipped.xml 2>&1) || fail "the shipped band's run failed: $out"
echo "$out" | grep -q "flickers" && fail "a warning with the shipped band: $out"
n=$(json shipped/summary.json "$dm['flickers']")
moves=$(json shipped/summary.json "$dm['moves']")
echo "shipped band: $moves moves, $n flickers"
[ "$n" = 0 ] || fail "$n flickers with the shipped band"
[ "$moves" -ge 1 ] || fail "the shipped band made no move (the check would be empty)"
echo "flicker test passed"
