#!/usr/bin/env bash
# What an independent run (session 40) found in long campaigns, each failing with the build
# before:
# 1. a reader holding fields.h5 open (ParaView, h5py, a monitoring script) stopped the run at
#    its next output ("unable to lock file, errno = 11", exit 4): the writer no longer locks
#    the file, the run completes and writes its snapshots while the reader holds it (a
#    continuation, so that the reader opens a whole file before the run touches it);
# 2. a restart into its own directory, killed before it wrote its summary, left the earlier
#    part's summary.json ("completed" at 0.3 s) beside profiles.csv rows past it: a continued
#    run removes the earlier summary when it starts (run.json says "running");
# 3. SIGHUP (a closed terminal) ended the run by the default action without a summary: it now
#    stops as an interrupt does, exit 129, status interrupted, with a checkpoint;
# 4. ... unless it runs under nohup (SIGHUP ignored), which it respects;
# 5. a snapshot that cannot be read made every restart fail;
# 6. (not a finding) a run directory of an older granflow, with the snapshots inside fields.h5.
source "$SRC/record_lib.sh"
rm -rf io_failures && mkdir io_failures && cd io_failures || exit 1
PY=/usr/bin/python3  # with h5py (install-deps.sh)

# 1. a reader holds fields.h5 (written by a first part to 0.3 s) while a continuation of that
#    run opens it, cuts it back and writes its snapshots into it (to 0.75 s, every 0.01 s)
scene "$SRC/io_ndam10.xml" held1.xml -e 's|value="io_run"|value="held"|' \
  -e 's|name="Interval" type="double" value="0.05"|name="Interval" type="double" value="0.01"|' \
  -e 's|name="End time" type="double" value="0.75"|name="End time" type="double" value="0.3"|'
expect 0 "completed at t = 0.3 s" held1.xml
scene "$SRC/io_ndam10.xml" held2.xml -e 's|value="io_run"|value="held"|' \
  -e 's|name="Interval" type="double" value="0.05"|name="Interval" type="double" value="0.01"|' \
  -e 's|<Parameter name="Progress"|<Parameter name="Restart from" type="string" value="held/checkpoint.h5"/>&|'
$PY - <<'PYEOF' > reader.log 2>&1 &
import h5py, os, time
f = h5py.File("held/fields.h5", "r")   # held open, as a viewer does
print("opened", len(f), flush=True)
while not os.path.exists("run.done"):
    time.sleep(0.05)
f.close()
PYEOF
rpid=$!
for _ in $(seq 1 600); do grep -q opened reader.log && break; sleep 0.05; done
grep -q opened reader.log || fail "the reader did not open fields.h5: $(cat reader.log)"
"$EXE" held2.xml > held.log 2>&1
rc=$?
touch run.done
wait $rpid
grep -v '^t = ' held.log | sed 's/^/  | /'
[ "$rc" = 0 ] || fail "the continuation with a reader holding fields.h5 ended with exit $rc"
n0=$(sed -n 's/^opened //p' reader.log)
n1=$(json held/summary.json "s['outputs']['field_snapshots']")
echo "snapshots: $n0 when the reader opened the file, $n1 at the end"
[ "$n1" -gt "$n0" ] || fail "no snapshot was written while the reader held the file"

# 2. a killed continuation leaves no earlier summary behind
scene "$SRC/io_ndam10.xml" first.xml -e 's|value="io_run"|value="cont"|' \
  -e 's|name="End time" type="double" value="0.75"|name="End time" type="double" value="0.3"|'
expect 0 "completed at t = 0.3 s" first.xml
scene "$SRC/io_ndam10.xml" second.xml -e 's|value="io_run"|value="cont"|' \
  -e 's|<Parameter name="Progress"|<Parameter name="Restart from" type="string" value="cont/checkpoint.h5"/>&|'
"$EXE" second.xml > second.log 2>&1 &
pid=$!
for _ in $(seq 1 600); do
  grep -q '^0.35,' cont/profiles.csv 2>/dev/null && break
  sleep 0.02
done
kill -KILL $pid
wait $pid 2>/dev/null
grep -q '^0.35,' cont/profiles.csv || fail "the continuation did not reach 0.35 s before it was killed"
[ -e cont/summary.json ] && fail "the killed continuation left a summary.json: $(json cont/summary.json "s['status'], s['final_time']")"
status=$(json cont/run.json "s['status']")
echo "killed continuation: no summary.json, run.json status '$status'"
[ "$status" = running ] || fail "run.json says '$status'"

# 3. SIGHUP stops the run with a checkpoint
scene "$SRC/io_ndam10.xml" hup.xml -e 's|value="io_run"|value="hup"|'
"$EXE" hup.xml > hup.log 2>&1 &
pid=$!
for _ in $(seq 1 600); do [ -s hup/checkpoint.h5 ] && break; sleep 0.02; done
kill -HUP $pid
wait $pid
rc=$?
cat hup.log | grep -v '^t = ' | sed 's/^/  | /'
[ "$rc" = 129 ] || fail "SIGHUP: exit $rc, expected 129"
[ "$(json hup/summary.json "s['status']")" = interrupted ] || fail "SIGHUP: summary status $(json hup/summary.json "s['status']")"
grep -q "SIGHUP received" hup.log || fail "SIGHUP: no line that says so"

# 4. under nohup (SIGHUP ignored) the run goes on
scene "$SRC/io_ndam10.xml" nohup.xml -e 's|value="io_run"|value="nohup"|'
(trap '' HUP; exec "$EXE" nohup.xml > nohup.log 2>&1) &
pid=$!
for _ in $(seq 1 600); do [ -s nohup/checkpoint.h5 ] && break; sleep 0.02; done
# the signal must reach the running process, or the case tests nothing (an audit, session 44)
kill -HUP $pid || fail "under nohup: the run had ended before SIGHUP could reach it"
wait $pid
rc=$?
[ "$rc" = 0 ] || fail "under nohup: exit $rc after SIGHUP; $(cat nohup.log)"
[ "$(json nohup/summary.json "s['status']")" = completed ] || fail "under nohup: $(json nohup/summary.json "s['status']")"

# 5. a snapshot that cannot be read made every restart fail ("cannot open step_000015"; an
#    independent run: a group left by a disk that filled inside HDF5's write). Snapshots are
#    now files of fields.h5.d written whole, and fields.h5 is their index, rebuilt from them at
#    a restart: here the last kept snapshot (t = 0.3 s) is damaged and the index deleted. The
#    restart names the damaged one, leaves it out, and lists the other 6 up to the checkpoint.
scene "$SRC/io_ndam10.xml" broken1.xml -e 's|value="io_run"|value="broken"|' \
  -e 's|name="End time" type="double" value="0.75"|name="End time" type="double" value="0.3"|'
expect 0 "completed at t = 0.3 s" broken1.xml
[ "$(ls broken/fields.h5.d | wc -l)" = 7 ] || fail "broken1: fields.h5.d holds $(ls broken/fields.h5.d)"
head -c 100 broken/fields.h5.d/step_000006.h5 > cut && mv cut broken/fields.h5.d/step_000006.h5
rm broken/fields.h5
scene "$SRC/io_ndam10.xml" broken2.xml -e 's|value="io_run"|value="broken"|' \
  -e 's|<Parameter name="Progress"|<Parameter name="Restart from" type="string" value="broken/checkpoint.h5"/>&|'
expect 0 "note: the field output in broken at the restart: step_000006 cannot be read \(kept as step_000006.h5.broken\); fields.h5 is missing: rebuilt from the files; fields.h5 lists the 6 snapshots up to the checkpoint" broken2.xml
[ -e broken/fields.h5.d/step_000006.h5.broken ] || fail "the damaged snapshot was not kept aside: $(ls broken/fields.h5.d)"
$PY - broken <<'PYEOF' || fail "broken: the index after the restart (above)"
import h5py, os, sys
run = sys.argv[1]
with h5py.File(run + "/fields.h5", "r") as f:
    times = [round(float(f[s].attrs["time"]), 9) for s in sorted(f)]
want = [0.0, 0.05, 0.1, 0.15, 0.2, 0.25] + [round(0.35 + 0.05 * k, 9) for k in range(9)]
assert times == want, times
import re
xt = sorted({round(float(v), 9) for v in re.findall(r'Time Value="([^"]+)"', open(run + "/fields.xdmf").read())})
assert xt == want, xt
files = sorted(f for f in os.listdir(run + "/fields.h5.d") if not f.endswith(".broken"))
assert files == sorted(s + ".h5" for s in h5py.File(run + "/fields.h5", "r")), files
PYEOF
# A file fields.h5 does not list is not a snapshot of the run (an independent run copied
# step_000001.h5 to step_000099.h5: it was taken as a second snapshot at t = 0.05 s)
cp broken/fields.h5.d/step_000001.h5 broken/fields.h5.d/step_000099.h5
scene "$SRC/io_ndam10.xml" broken3.xml -e 's|value="io_run"|value="broken"|' \
  -e 's|name="End time" type="double" value="0.75"|name="End time" type="double" value="0.76"|' \
  -e 's|<Parameter name="Progress"|<Parameter name="Restart from" type="string" value="broken/checkpoint.h5"/>&|'
expect 0 "step_000099 repeats the time 0.05 s of step_000001 \(kept as step_000099.h5.duplicate\)" broken3.xml
[ -e broken/fields.h5.d/step_000099.h5 ] && fail "a copy of a snapshot was kept as a second one"
# a snapshot of the run put back by hand (it was deleted without a word: an independent run)
for te in 0.77 0.78; do
  scene "$SRC/io_ndam10.xml" broken$te.xml -e 's|value="io_run"|value="broken"|' \
    -e "s|name=\"End time\" type=\"double\" value=\"0.75\"|name=\"End time\" type=\"double\" value=\"$te\"|" \
    -e 's|<Parameter name="Progress"|<Parameter name="Restart from" type="string" value="broken/checkpoint.h5"/>&|'
done
mv broken/fields.h5.d/step_000002.h5 step_000002.backup
expect 0 "step_000002 is listed but has no file" broken0.77.xml
mv step_000002.backup broken/fields.h5.d/step_000002.h5
expect 0 "step_000002 \(t = 0.1 s\) was not listed in fields.h5: taken back" broken0.78.xml
$PY -c "import h5py, sys; f = h5py.File('broken/fields.h5', 'r'); t = sorted(round(float(f[s].attrs['time']), 9) for s in f); sys.exit((len(t) != 18 or len(set(t)) != 18 or 0.1 not in t) and f'times {t}: not 15 + 0.76, 0.77, 0.78 once each')" ||
  fail "the index after the restarts with a stray copy and a file put back"


# 6. a run directory of a granflow before fields.h5.d (its snapshots are groups in fields.h5):
#    a restart copies the ones it keeps into files of fields.h5.d, each value unchanged
expect 0 "completed at t = 0.3 s" broken1.xml
$PY - broken <<'PYEOF' || fail "could not make an old-style fields.h5 (above)"
import h5py, shutil, sys
run = sys.argv[1]
with h5py.File(run + "/fields.h5", "a") as f:
    for s in sorted(f):
        with h5py.File(f"{run}/fields.h5.d/{s}.h5", "r") as src:
            del f[s]
            g = f.create_group(s)
            g.attrs["time"] = src.attrs["time"]
            for m in src:
                src.copy(src[m], g, name=m)
shutil.copytree(run + "/fields.h5.d", "old_snapshots")
shutil.rmtree(run + "/fields.h5.d")
PYEOF
cp broken/fields.h5 old_fields.h5
head -c 2000 old_fields.h5 > broken/fields.h5   # an older fields.h5, cut: nothing to rebuild from
expect 4 "cannot read '[^']*fields.h5'.*and '[^']*fields.h5.d' holds no snapshot files, so the snapshots before the checkpoint cannot be kept" broken2.xml
cmp -s broken/fields.h5 <(head -c 2000 old_fields.h5) || fail "the unreadable fields.h5 was replaced"
cp old_fields.h5 broken/fields.h5
expect 0 "completed at t = 0.75 s" broken2.xml
$PY - broken <<'PYEOF' || fail "old-style fields.h5: the snapshots after the restart (above)"
import h5py, numpy as np, os, sys
run = sys.argv[1]
with h5py.File(run + "/fields.h5", "r") as f:
    names = sorted(f)
    assert len(names) == 16, names
    for s in names[:7]:  # the copied ones, value for value
        with h5py.File(f"old_snapshots/{s}.h5", "r") as old:
            assert f[s].attrs["time"] == old.attrs["time"]
            for m in old:
                for d in old[m]:
                    assert np.array_equal(f[s][m][d][()], old[m][d][()]), (s, m, d)
assert sorted(os.listdir(run + "/fields.h5.d")) == [s + ".h5" for s in names]
PYEOF

# 7. A run directory copied with cp -r copies a linked fields.h5.d as the link: both copies
#    share one directory, and a run in the copy removed the original's snapshots (a review).
#    The linked directory is marked with its run; another run is refused while it holds them.
mkdir -p shared_target linked
ln -s "$(pwd)/shared_target" linked/fields.h5.d
scene "$SRC/io_ndam10.xml" linked.xml -e 's|value="io_run"|value="linked"|' \
  -e 's|name="End time" type="double" value="0.75"|name="End time" type="double" value="0.2"|'
expect 0 "completed at t = 0.2 s" linked.xml
cp -r linked linked_copy
[ -L linked_copy/fields.h5.d ] || fail "cp -r did not copy the link (the case this tests)"
scene "$SRC/io_ndam10.xml" copy.xml -e 's|value="io_run"|value="linked_copy"|' \
  -e 's|name="End time" type="double" value="0.75"|name="End time" type="double" value="0.2"|'
expect 2 "linked_copy/fields.h5.d' links to '[^']*shared_target', which holds the field snapshots of the run in '[^']*/linked': two runs cannot share it" copy.xml
[ "$(ls shared_target | grep -c '^step_')" = 5 ] || fail "the copy's run touched the original's snapshots: $(ls shared_target)"
# A link that points nowhere (a disk not mounted) is named, in --check too, before anything of
# the directory is removed (a fresh run removed fields.h5 and then failed on the link).
mv shared_target shared_away
expect 2 "'linked/fields.h5.d' is a link to '[^']*shared_target', which does not exist" --check linked.xml
expect 2 "'linked/fields.h5.d' is a link to '[^']*shared_target', which does not exist" linked.xml
[ -e linked/fields.h5 ] || fail "the refused run removed fields.h5"
mv shared_away shared_target

# 8. fields.h5 copied without its fields.h5.d, read from inside another run's directory: HDF5
#    looks for each snapshot's file beside fields.h5 and then in the current directory, and
#    granflow-study read the other run's snapshots without a word (an independent run). Each
#    snapshot's file carries its run's id, which the reader checks.
mkdir -p only && cp linked/fields.h5 linked/fields.xdmf linked/profiles.csv linked/summary.json linked/run.json only/
study=$(dirname "$EXE")/granflow-study
out=$(cd broken && "$study" budget ../only --from 0.05 --to 0.2 2>&1); rc=$?
echo "granflow-study budget ../only (from broken/) -> $rc"; echo "$out" | tail -2 | sed 's/^/  | /'
[ "$rc" != 0 ] || fail "granflow-study read another run's snapshots through a copied fields.h5"
echo "$out" | grep -q "snapshot step_000000 read through ../only/fields.h5 is another run's" ||
  fail "granflow-study did not say why"
out=$("$study" budget linked --from 0.05 --to 0.2 2>&1) || fail "granflow-study on the run itself: $out"

# A link into another run directory's own fields.h5.d: --overwrite replaced that run's snapshots
mkdir -p into && ln -s "$(pwd)/broken/fields.h5.d" into/fields.h5.d
scene "$SRC/io_ndam10.xml" into.xml -e 's|value="io_run"|value="into"|'
expect 2 "'into/fields.h5.d' links to '[^']*broken/fields.h5.d', inside the field snapshots of the run directory '[^']*broken'" --overwrite into.xml
mkdir -p broken/fields.h5.d/sub && rm into/fields.h5.d && ln -s "$(pwd)/broken/fields.h5.d/sub" into/fields.h5.d
expect 2 "'into/fields.h5.d' links to '[^']*broken/fields.h5.d/sub', inside the field snapshots of the run directory '[^']*broken'" --check into.xml
rmdir broken/fields.h5.d/sub

# 10. Another run's fields.h5 copied over this run's before a restart: the restart took the
#     other's list and id and deleted four of its own snapshots without a word (an independent
#     run). The checkpoint records the field output's run id; the index is rebuilt from the
#     run's own files and the copy is named.
scene "$SRC/io_ndam10.xml" other.xml -e 's|value="io_run"|value="other"|' \
  -e 's|name="End time" type="double" value="0.75"|name="End time" type="double" value="0.1"|'
expect 0 "completed at t = 0.1 s" other.xml
cp other/fields.h5 linked/fields.h5
scene "$SRC/io_ndam10.xml" linked2.xml -e 's|value="io_run"|value="linked"|' \
  -e 's|name="End time" type="double" value="0.75"|name="End time" type="double" value="0.3"|' \
  -e 's|<Parameter name="Progress"|<Parameter name="Restart from" type="string" value="linked/checkpoint.h5"/>&|'
expect 0 "fields.h5 is another run's index \(run id [0-9a-f]+, this run's [0-9a-f]+\): rebuilt from the files; fields.h5 lists the 5 snapshots up to the checkpoint" linked2.xml
$PY -c "import h5py, sys; f = h5py.File('linked/fields.h5', 'r'); t = sorted(round(float(f[s].attrs['time']), 9) for s in f); sys.exit(t != [0.0, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3] and f'times {t}')" ||
  fail "the restart over another run's index"

# 9. A run directory moved without its fields.h5.d and restarted: the index lists snapshots
#    whose files are not there; it was replaced by an empty one without a word (a review)
mkdir moved && cp linked/*.h5 linked/*.csv linked/*.json linked/fields.xdmf moved/
scene "$SRC/io_ndam10.xml" moved.xml -e 's|value="io_run"|value="moved"|' \
  -e 's|<Parameter name="Progress"|<Parameter name="Restart from" type="string" value="moved/checkpoint.h5"/>&|'
expect 4 "'moved/fields.h5' lists 7 snapshots and 'moved/fields.h5.d' holds none of their files" moved.xml
echo "io failures test passed"
