#!/usr/bin/env bash
# A run owns its directory (issue 13, item 6): run.json records the scene identity and the
# files; a rerun of the same scene replaces all the earlier files (also those it no longer
# writes); another scene's files are refused (exit 2, --check too) unless --overwrite; a
# restart cuts profiles.csv, fields.h5 and fields.xdmf back to the checkpoint time. Also the
# DAM's XDMF declares its 1-D datasets as 1-D (item 7) and summary.json carries provenance
# (item 10).
source "$SRC/record_lib.sh"
rm -rf run_directory && mkdir run_directory && cd run_directory || exit 1
dam() { scene "$SRC/restart_first.xml" "$1" -e "s|value=\"restart_first\"/>|value=\"$2\"/>|" "${@:3}"; }

# 1. A DAM run, then a 2D run without fields and checkpoint into the same directory.
dam dam.xml mixed
scene "$SRC/record_ndam.xml" ndam.xml -e 's|value="record_dir"/>|value="mixed"/>|'
expect 0 "completed" dam.xml
for f in run.json summary.json profiles.csv fields.h5 fields.h5.d fields.xdmf checkpoint.h5; do
  [ -e mixed/$f ] || fail "the DAM run did not write $f"
done
grep -q '"identity": "[0-9a-f]\{16\}"' mixed/run.json || fail "run.json has no scene identity"
expect 2 "Output->Directory' = \"mixed\": it holds the run of a different scene \('mixed'; 'Model' = \"DAM\" there, \"N-DAM\" here\): run.json, summary.json, profiles.csv, fields.h5, fields.h5.d, fields.xdmf, checkpoint.h5. Allowed: another directory, or the option --overwrite" --check ndam.xml
expect 2 "holds the run of a different scene" ndam.xml
grep -q '"model": "DAM"' mixed/summary.json || fail "the refused run touched summary.json"
expect 0 "completed" --overwrite ndam.xml
for f in fields.h5 fields.h5.d fields.xdmf checkpoint.h5; do
  [ -e mixed/$f ] && fail "--overwrite left the DAM run's $f"
done
grep -q '"model": "N-DAM"' mixed/summary.json || fail "summary.json is not the 2D run's"

# 2. The same scene again, now without fields and checkpoint: the earlier ones go; its
#    default command stays repeatable.
dam same.xml same
expect 0 "completed" same.xml
expect 0 "completed" same.xml
dam same_nofields.xml same -e 's|<Parameter name="Interval" type="double" value="0.05"/>|&<Parameter name="Fields" type="bool" value="false"/><Parameter name="Checkpoint" type="bool" value="false"/>|'
expect 0 "completed" same_nofields.xml
for f in fields.h5 fields.h5.d fields.xdmf checkpoint.h5; do
  [ -e same/$f ] && fail "a rerun of the same scene left the earlier run's $f"
done
# A slope change is a different scene, also for the directory.
dam steeper.xml same -e 's|<Parameter name="Length" type="double" value="1.0"/>|&<Parameter name="Slope angle" type="double" value="55"/>|'
expect 2 "Directory' = \"same\": it holds the run of a different scene \('same'; 'Channel->Slope angle' = 50 there, 55 here\)" steeper.xml
# granflow files without run.json and without a summary.json of this scene: refused.
mkdir legacy && echo "t,x,h,u_mean,eps,model" > legacy/profiles.csv
dam legacy.xml legacy
expect 2 "Directory' = \"legacy\": it holds granflow output files without a run record \(run.json\).*: profiles.csv" legacy.xml
# A directory of a granflow before run.json (here: run.json removed): its summary.json records
# the parameters, so the same scene reruns (the README's command stays repeatable across the
# upgrade) and a changed one is refused.
dam old.xml old
expect 0 "completed" old.xml
rm old/run.json
dam old_steeper.xml old -e 's|<Parameter name="Length" type="double" value="1.0"/>|&<Parameter name="Slope angle" type="double" value="55"/>|'
expect 2 "Directory' = \"old\": it holds granflow output files without a run record" old_steeper.xml
expect 0 "completed" old.xml
[ -e old/run.json ] || fail "the rerun did not write run.json"
# A directory that is a file.
: > plainfile
dam file.xml plainfile
expect 2 "Directory' = \"plainfile\": exists and is not a directory" --check file.xml

# 3. A run stopped between its output at t = 0.15 s and its checkpoint (made here by putting
#    the run's own t = 0.1 s checkpoint back), restarted into the same directory to 0.2 s:
#    every output time once in profiles.csv and fields.h5, and the rows equal to a straight
#    run's.
dam cut.xml cut
expect 0 "completed" cut.xml                        # to 0.1 s: cut/checkpoint.h5 at 0.1
cp cut/checkpoint.h5 ck_0.1.h5
dam cut_on.xml cut -e 's|"End time" type="double" value="0.1"|"End time" type="double" value="0.15"|' \
    -e 's|<Parameter name="Interval" type="double" value="0.05"/>|&<Parameter name="Restart from" type="string" value="cut/checkpoint.h5"/>|'
expect 0 "completed" cut_on.xml                     # to 0.15 s, outputs 0 .. 0.15
cp ck_0.1.h5 cut/checkpoint.h5
# (a checkpoint of a sibling run of the scene, copied in, is not this directory's history:
#  its continuation joined the directory's earlier outputs of another trajectory; an
#  independent run. The files are replaced, with a note.)
dam sib.xml sib
expect 0 "completed" sib.xml
mkdir -p sibdir && cp -r cut/. sibdir/ && cp sib/checkpoint.h5 sibdir/checkpoint.h5
dam sib_restart.xml sibdir -e 's|"End time" type="double" value="0.1"|"End time" type="double" value="0.2"|' \
    -e 's|<Parameter name="Interval" type="double" value="0.05"/>|&<Parameter name="Restart from" type="string" value="sibdir/checkpoint.h5"/>|'
expect 0 "the restart's checkpoint \"sibdir/checkpoint.h5\" was written by another run of this scene .*: its files \(.*profiles.csv.*\) are replaced, not continued" sib_restart.xml
[ "$(cut -d, -f1 sibdir/profiles.csv | uniq | tr '\n' ' ')" = "t 0.15 0.2 " ] ||
  fail "the sibling's continuation kept the directory's earlier rows: $(cut -d, -f1 sibdir/profiles.csv | uniq | tr '\n' ' ')"
dam cut_restart.xml cut -e 's|"End time" type="double" value="0.1"|"End time" type="double" value="0.2"|' \
    -e 's|<Parameter name="Interval" type="double" value="0.05"/>|&<Parameter name="Restart from" type="string" value="cut/checkpoint.h5"/>|'
expect 0 "completed at t = 0.2 s" cut_restart.xml
dam straight.xml straight -e 's|"End time" type="double" value="0.1"|"End time" type="double" value="0.2"|'
expect 0 "completed at t = 0.2 s" straight.xml
times=$(cut -d, -f1 cut/profiles.csv | uniq | tr '\n' ' ')
[ "$times" = "t 0 0.05 0.1 0.15 0.2 " ] || fail "profiles.csv output times after the restart: $times"
cmp cut/profiles.csv straight/profiles.csv || fail "the restarted profiles.csv differs from the straight run's"
snaps=$(h5ls cut/fields.h5 | grep -c '^step_')
[ "$snaps" = 5 ] || fail "fields.h5 has $snaps snapshots, expected 5 (t = 0, 0.05, 0.1, 0.15, 0.2)"
# each snapshot is a file of fields.h5.d; the one at 0.15 s that the restart wrote again is
# there once (the cut-back removed the first one's file)
files=$(ls cut/fields.h5.d | tr '\n' ' ')
[ "$files" = "step_000000.h5 step_000001.h5 step_000002.h5 step_000003.h5 step_000004.h5 " ] ||
  fail "fields.h5.d after the restart: $files"
xtimes=$(grep -o 'Time Value="[^"]*"' cut/fields.xdmf | tr '\n' ' ')
[ "$xtimes" = 'Time Value="0" Time Value="0.05" Time Value="0.1" Time Value="0.15" Time Value="0.2" ' ] ||
  fail "fields.xdmf times after the restart: $xtimes"

# 4. The DAM's XDMF declares the shape its cell datasets have: one row of 100 cells, 1 x 100
#    (h5ls: {1, 100}), the shape ParaView's XDMF reader maps onto the strip's cells.
h5ls cut/fields.h5/step_000000/dam | grep -q '^h  *Dataset {1, 100}' || fail "dam/h is not a 1 x 100 dataset"
grep -q 'Dimensions="1 100" NumberType="Float" Precision="8" Format="HDF">fields.h5.d/step_000000.h5:/dam/h<' cut/fields.xdmf ||
  fail "fields.xdmf does not declare dam/h as 1 x 100"

# 5. Provenance in summary.json.
for k in granflow_version git_commit build_type compiler trilinos_version hdf5_version host; do
  grep -Eq "\"$k\": \"[^\"]+\"" straight/summary.json || fail "summary.json has no provenance '$k'"
done
grep -Eq '"ranks": 1' straight/summary.json || fail "summary.json has no provenance 'ranks'"
grep -q '"files": \[' straight/summary.json || fail "summary.json has no file manifest"

# 6. Every restart of a run and what it changed (summary.json recorded only the last leg's
#    parameters, so a run continued with another end time or output interval did not say so):
#    cut (0 -> 0.1 s from cut_a's checkpoint, End time 0.1 -> 0.2), then 0.2 -> 0.3 s with the
#    Interval 0.05 -> 0.1; the chain is carried in the checkpoint.
dam chain.xml cut -e 's|"End time" type="double" value="0.1"|"End time" type="double" value="0.3"|' \
    -e 's|<Parameter name="Interval" type="double" value="0.05"/>|<Parameter name="Interval" type="double" value="0.1"/><Parameter name="Restart from" type="string" value="cut/checkpoint.h5"/>|'
expect 0 "completed at t = 0.3 s" chain.xml
python3 - cut/summary.json <<'PYEOF' || fail "summary.json's restarts (above)"
import json, sys
r = json.load(open(sys.argv[1]))["restarts"]
print(json.dumps(r))
assert [round(x["t"], 9) for x in r] == [0.1, 0.2], r
assert all(x["from"] == "cut/checkpoint.h5" for x in r), r
assert r[0]["changed"] == [{"parameter": "Time->End time", "before": "0.1", "after": "0.2"}], r[0]
assert r[1]["changed"] == [{"parameter": "Output->Interval", "before": "0.05", "after": "0.1"},
                           {"parameter": "Time->End time", "before": "0.2", "after": "0.3"}], r[1]
PYEOF
# A continuation with Checkpoint off says that the directory's checkpoint stays the earlier
# part's (a restart from it cuts this part's outputs back)
dam nockpt.xml cut -e 's|"End time" type="double" value="0.1"|"End time" type="double" value="0.35"|' \
    -e 's|<Parameter name="Interval" type="double" value="0.05"/>|<Parameter name="Interval" type="double" value="0.1"/><Parameter name="Checkpoint" type="bool" value="false"/><Parameter name="Restart from" type="string" value="cut/checkpoint.h5"/>|'
expect 0 "note: Output->Checkpoint is off: cut/checkpoint.h5 stays the earlier part's \(t = 0.3 s\)" nockpt.xml
echo "run directory checks passed"
