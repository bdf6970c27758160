#!/usr/bin/env bash
# A restart must continue the same scene from an intact checkpoint (issue 13, item 4): a
# changed scene, another model, an end time before the checkpoint, a truncated or corrupted
# checkpoint stop with exit 2 and a message naming the parameter, in --check too, and no HDF5
# library dump reaches the user.
source "$SRC/record_lib.sh"
rm -rf restart_checks && mkdir restart_checks && cd restart_checks || exit 1
scene "$SRC/restart_first.xml" first.xml -e 's|value="restart_first"/>|value="first"/>|'
"$EXE" first.xml > /dev/null 2>&1 || fail "first.xml did not run"
ck=first/checkpoint.h5
# The restart scene: restart_second into its own directory.
base() { scene "$SRC/restart_second.xml" "$1" -e "s|restart_first/checkpoint.h5|$2|" \
         -e "s|value=\"restart_second\"/>|value=\"$3\"/>|" "${@:4}"; }

# 1. Changed physics: the slope (not in the file: the default 50 deg) and the rheology-like DAM
#    numerics; each difference is named with both values.
base slope.xml $ck slope -e 's|<Parameter name="Length" type="double" value="1.0"/>|&<Parameter name="Slope angle" type="double" value="45"/>|'
expect 2 "Restart from' = \"first/checkpoint.h5\": the checkpoint belongs to a different scene: 'Channel->Slope angle' = 50 there, 45 here" --check slope.xml
expect 2 "'Channel->Slope angle' = 50 there, 45 here" slope.xml
[ -e slope ] && fail "a refused restart created its run directory"
base cells.xml $ck cells -e 's|"Cells" type="int" value="100"|"Cells" type="int" value="120"|' \
     -e 's|"Bed friction angle" type="double" value="22"|"Bed friction angle" type="double" value="20"|'
expect 2 "'DAM->Cells' = 100 there, 120 here.*'Material->Bed friction angle' = 22 there, 20 here" cells.xml

# 2. What may change: time, output and solver tolerances (here End time, Interval, Name, the
#    output directory) restarts with exit 0.
base ok.xml $ck ok -e 's|"Interval" type="double" value="0.05"|"Interval" type="double" value="0.025"|'
expect 0 "completed at t = 0.2 s" ok.xml

# 3. An end time at or before the checkpoint's time.
base early.xml $ck early -e 's|"End time" type="double" value="0.2"|"End time" type="double" value="0.05"|'
expect 2 "Time->End time' = 0.05: the checkpoint first/checkpoint.h5 is at t = 0.1 s; allowed: an end time after it" --check early.xml
expect 2 "End time' = 0.05" early.xml

# 4. A DAM checkpoint into an N-DAM scene.
scene "$SRC/record_ndam.xml" ndam.xml -e 's|value="record_dir"/>|value="ndam"/>|' \
      -e "s|<Parameter name=\"Fields\"|<Parameter name=\"Restart from\" type=\"string\" value=\"$ck\"/>&|" \
      -e 's|"End time" type="double" value="0.02"|"End time" type="double" value="0.3"|'
expect 2 "the checkpoint belongs to a different scene: 'Model' = \"DAM\" there, \"N-DAM\" here" --check ndam.xml
expect 2 "'Model' = \"DAM\" there, \"N-DAM\" here" ndam.xml

# A 2D checkpoint: another box height or rheology is refused, a solver tolerance may change.
scene "$SRC/record_ndam.xml" nd_first.xml -e 's|value="record_dir"/>|value="nd_first"/>|' \
      -e 's|"Checkpoint" type="bool" value="false"|"Checkpoint" type="bool" value="true"|'
expect 0 "completed at t = 0.02 s" nd_first.xml
nd() { scene "$SRC/record_ndam.xml" "$1" -e "s|value=\"record_dir\"/>|value=\"$2\"/>|" \
       -e 's|<Parameter name="Fields"|<Parameter name="Restart from" type="string" value="nd_first/checkpoint.h5"/>&|' \
       -e 's|"End time" type="double" value="0.02"|"End time" type="double" value="0.04"|' "${@:3}"; }
nd nd_height.xml nd_height -e 's|"Height" type="double" value="0.15"|"Height" type="double" value="0.2"|'
expect 2 "the checkpoint belongs to a different scene: 'N-DAM->Height' = 0.15 there, 0.2 here" nd_height.xml
nd nd_rheo.xml nd_rheo -e 's|"Viscosity" type="double" value="0.003"|"Viscosity" type="double" value="0.005"|'
expect 2 "'Rheology->Viscosity' = 0.003 there, 0.005 here" --check nd_rheo.xml
nd nd_tol.xml nd_tol -e 's|<Parameter name="Free surface"|<ParameterList name="Pressure solver"><Parameter name="Tolerance" type="double" value="1e-8"/><Parameter name="Max iterations" type="int" value="500"/></ParameterList>&|'
expect 0 "completed at t = 0.04 s" nd_tol.xml

# 5. A truncated checkpoint (a copy cut at 3000 of its bytes): --check and the run say so.
head -c 3000 $ck > truncated.h5
base trunc.xml truncated.h5 trunc
expect 2 "Restart from' = \"truncated.h5\": 'truncated.h5' cannot be read \(truncated or corrupted\?\).*truncated file" --check trunc.xml
expect 2 "cannot be read \(truncated or corrupted\?\)" trunc.xml
: > empty.h5
base empty.xml empty.h5 empty
expect 2 "'empty.h5' is not an HDF5 file" empty.xml

# An HDF5 file that is not a checkpoint (the run's fields.h5).
base fields.xml first/fields.h5 fieldsck
expect 2 "'first/fields.h5' is an HDF5 file but not a granflow checkpoint" --check fields.xml

# 6. Flipped data bytes: 1.0 written over h of cell 5 (inside the dataset, found with h5dump).
cp $ck flipped.h5
offset=$(h5dump -p -H -d "/arrays/dam:h" flipped.h5 | sed -n 's/^ *OFFSET \([0-9]*\).*/\1/p')
[ -n "$offset" ] || fail "no OFFSET of /arrays/dam:h from h5dump"
printf '\x00\x00\x00\x00\x00\x00\xf0\x3f' | dd of=flipped.h5 bs=1 seek=$((offset + 40)) conv=notrunc status=none
cmp -s $ck flipped.h5 && fail "the data were not changed"
base flip.xml flipped.h5 flip
expect 2 "'flipped.h5' is corrupted: its data have the checksum fnv1a64:[0-9a-f]*, the file records fnv1a64:" --check flip.xml
expect 2 "is corrupted" flip.xml

# 7. Any single byte changed anywhere in the file: exit 0 (a byte HDF5 does not read: the
#    content and its checksum are intact) or 2 with a message; never another code or a dump.
size=$(stat -c %s $ck)
n0=0 n2=0
step=$((size / 12 + 1))  # 12 positions spread over the file (superblock, headers, data)
for ((k = 0; k < size; k += step)); do
  cp $ck byte.h5
  printf '\x5a' | dd of=byte.h5 bs=1 seek=$k conv=notrunc status=none
  base byte.xml byte.h5 byte
  out=$("$EXE" --check byte.xml 2>&1); rc=$?
  case $rc in
    0) n0=$((n0 + 1)) ;;
    2) n2=$((n2 + 1)); echo "$out" | grep -q "Restart from' = \"byte.h5\"" || fail "byte $k: $out" ;;
    *) fail "byte $k: exit code $rc: $out" ;;
  esac
  echo "$out" | grep -q "HDF5-DIAG" && fail "byte $k: an HDF5 diagnostic reached the user"
done
echo "single-byte changes: $n2 refused, $n0 in bytes HDF5 does not read"
[ $n2 -gt 0 ] || fail "no changed byte was detected"
# 8. The inflow series is part of the scene by its content: the same file name with edited
#    rows is another scene (a hostile-user run restarted after editing the CSV), the same
#    content restarts.
printf 't,h,u\n0,0.06,0.37\n' > series.csv
series() { scene "$SRC/$1" "$2" -e "s|value=\"restart_[a-z]*\"/>|value=\"$3\"/>|" \
           -e 's|<Parameter name="Inflow depth" type="double" value="0.06"/>|<Parameter name="Inflow series file" type="string" value="series.csv"/>|' \
           -e '/<Parameter name="Inflow velocity"/d' "${@:4}"; }
series restart_first.xml s_first.xml s_first
expect 0 "completed at t = 0.1 s" s_first.xml
# the record names the series and not the unused inflow depth and velocity (their defaults)
[ "$(json s_first/summary.json "sorted(s['parameters']['Channel']['Left boundary'])")" = \
  "['Inflow series file', 'Type']" ] ||
  fail "summary.json's Left boundary: $(json s_first/summary.json "s['parameters']['Channel']['Left boundary']")"
series restart_second.xml s_same.xml s_same -e "s|restart_first/checkpoint.h5|s_first/checkpoint.h5|"
expect 0 "completed at t = 0.2 s" s_same.xml
printf 't,h,u\n0,0.06,0.37\n0.15,0.08,0.5\n' > series.csv
series restart_second.xml s_edit.xml s_edit -e "s|restart_first/checkpoint.h5|s_first/checkpoint.h5|"
expect 2 "the checkpoint belongs to a different scene: 'Channel->Left boundary->Inflow series file content' = [0-9a-f]* there, [0-9a-f]* here" --check s_edit.xml
expect 2 "Inflow series file content' = " s_edit.xml
# 9. A restart from elsewhere into a directory that holds another run of the same scene starts
#    that directory's files afresh: before, it kept that run's rows up to the checkpoint time
#    and joined them to a continuation of a different trajectory (a hostile-user run).
base r_a.xml $ck r_join
expect 0 "completed at t = 0.2 s" r_a.xml                       # rows 0.15, 0.2 after 0.1
scene "$SRC/restart_first.xml" mid.xml -e 's|value="restart_first"/>|value="mid"/>|' \
      -e 's|"End time" type="double" value="0.1"|"End time" type="double" value="0.15"|'
expect 0 "completed at t = 0.15 s" mid.xml
base r_b.xml mid/checkpoint.h5 r_join
expect 0 "completed at t = 0.2 s" r_b.xml                       # from mid's 0.15
# ... and says so (an independent run lost 4000 rows without a word restarting from a copy of
# the directory's own checkpoint): the note names the checkpoint, the directory and the files
expect 0 "note: the restart's checkpoint \"mid/checkpoint.h5\" lies outside \"r_join\", which holds a run of this scene: its files \(.*profiles.csv.*\) are replaced" r_b.xml
awk -F, 'NR > 1 && $1 <= 0.15 + 1e-12 { bad = 1 } END { exit bad }' r_join/profiles.csv ||
  fail "r_join/profiles.csv keeps rows at or before the checkpoint time 0.15 s of another history"
grep -q '^0.2,' r_join/profiles.csv || fail "r_join/profiles.csv has no row at 0.2 s"
echo "restart checks passed"
