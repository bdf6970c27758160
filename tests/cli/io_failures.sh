#!/usr/bin/env bash
# What an independent run (session 40) found in long campaigns, each failing with the build
# before:
# 1. a reader holding fields.h5 open (ParaView, h5py, a monitoring script) stopped the run at
#    its next output ("unable to lock file, errno = 11", exit 4): the writer no longer locks
#    the file, the run completes and writes its snapshots while the reader holds it;
# 2. a restart into its own directory, killed before it wrote its summary, left the earlier
#    part's summary.json ("completed" at 0.3 s) beside profiles.csv rows past it: a continued
#    run removes the earlier summary when it starts (run.json says "running");
# 3. SIGHUP (a closed terminal) ended the run by the default action without a summary: it now
#    stops as an interrupt does, exit 129, status interrupted, with a checkpoint.
source "$SRC/record_lib.sh"
rm -rf io_failures && mkdir io_failures && cd io_failures || exit 1
PY=/usr/bin/python3  # with h5py (install-deps.sh)

# 1. a reader holds fields.h5 from the first snapshots to the end of the run
scene "$SRC/io_ndam10.xml" held.xml -e 's|value="io_run"|value="held"|' \
  -e 's|name="Interval" type="double" value="0.05"|name="Interval" type="double" value="0.01"|'
"$EXE" held.xml > held.log 2>&1 &
pid=$!
for _ in $(seq 1 600); do [ -s held/fields.xdmf ] && break; sleep 0.05; done
$PY - "$pid" <<'PYEOF' > reader.log 2>&1
import h5py, os, sys, time
pid = int(sys.argv[1])
f = h5py.File("held/fields.h5", "r")   # held open, as a viewer does
n0 = len(f)
while os.path.exists("/proc/%d" % pid) and open("/proc/%d/stat" % pid).read().split()[2] != "Z":
    time.sleep(0.05)
f.close()
print("snapshots when opened:", n0)
PYEOF
wait $pid
rc=$?
cat held.log | grep -v '^t = ' | sed 's/^/  | /'
cat reader.log
[ "$rc" = 0 ] || fail "the run with a reader holding fields.h5 ended with exit $rc"
n0=$(sed -n 's/snapshots when opened: //p' reader.log)
n1=$(json held/summary.json "s['outputs']['field_snapshots']")
echo "snapshots: $n0 when the reader opened the file, $n1 at the end"
[ -n "$n0" ] && [ "$n1" -gt "$n0" ] || fail "no snapshot was written while the reader held the file"

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
echo "io failures test passed"
