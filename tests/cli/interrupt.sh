#!/usr/bin/env bash
# SIGINT and SIGTERM end the step in progress, write checkpoint.h5 of the last accepted state
# and summary.json with status "interrupted", and exit with 128 + signal (issue 13, item 5);
# a restart from that checkpoint reproduces the straight run bit for bit (DAM). Logs are
# line-buffered: with stdout and stderr redirected to files, the scene line and one plain
# progress line per output time are there while the run goes on. With NP set (e.g. 2), the
# 2D case runs under mpiexec and one rank alone gets the signal: all ranks stop at one step.
# The signal is sent once a progress line shows that the time loop runs; the runs would take
# minutes otherwise, so nothing here depends on timing.
source "$SRC/record_lib.sh"
work=interrupt${NP:+_np$NP}
rm -rf $work && mkdir $work && cd $work || exit 1

# wait_for FILE REGEX PID: until FILE has a line matching REGEX, or fail when the process has
# ended (a child that ended is a zombie until waited for: kill -0 still finds it).
wait_for() {
  until grep -Eq -- "$2" "$1" 2> /dev/null; do
    local st
    st=$(ps -o stat= -p "$3" 2> /dev/null)
    if [ -z "$st" ] || [ "${st#Z}" != "$st" ]; then
      cat "${1%.err}.out" "$1" 2> /dev/null | tail -5
      fail "the run ended before '$2' appeared in $1"
    fi
    sleep 0.05
  done
}
# A failing check must not leave the long run behind.
pid=
trap '[ -n "$pid" ] && kill -KILL $pid 2> /dev/null' EXIT

status_of() { sed -n 's/^ *"status": "\([a-z_]*\)".*/\1/p' "$1"; }

if [ -z "${NP:-}" ]; then
  # A DAM run to 50 s (4000 cells: minutes) with outputs every 0.02 s.
  long() { scene "$SRC/restart_first.xml" "$1" -e "s|value=\"restart_first\"/>|value=\"$2\"/>|" \
           -e 's|"End time" type="double" value="0.1"|"End time" type="double" value="50"|' \
           -e 's|"Cells" type="int" value="100"|"Cells" type="int" value="4000"|' \
           -e 's|"Interval" type="double" value="0.05"|"Interval" type="double" value="0.02"|' "${@:3}"; }
  for sig in INT TERM; do
    long $sig.xml run_$sig
    "$EXE" $sig.xml > $sig.out 2> $sig.err &
    pid=$!
    wait_for $sig.err "^t = 0\.0200 / 50\.0000 s" $pid
    grep -q "^granflow: scene '.*', model DAM" $sig.out || fail "stdout is not line-buffered: the scene line is not in the log yet"
    # While it runs, the directory is locked: a second run of the same scene (which would
    # replace its files) is refused, in --check too.
    expect 2 "Directory' = \"run_$sig\": another granflow run is writing into it now" --check $sig.xml
    expect 2 "another granflow run is writing into it now" $sig.xml
    kill -$sig $pid
    wait $pid
    rc=$?
    cat $sig.out $sig.err
    expected=$((128 + $(kill -l $sig)))
    [ $rc = $expected ] || fail "SIG$sig: exit code $rc, expected $expected"
    grep -q $'\r' $sig.err && fail "the progress in a log has carriage returns"
    grep -q "^granflow: SIG$sig received; stopped after step [0-9]* at t = " $sig.err || fail "no interrupt message"
    [ "$(status_of run_$sig/summary.json)" = interrupted ] || fail "summary.json status is not interrupted"
    grep -q "\"exit_code\": $expected" run_$sig/summary.json || fail "summary.json exit_code is not $expected"
    [ -s run_$sig/checkpoint.h5 ] || fail "no checkpoint.h5"
  done
  # A second signal ends the run at once, with a line that says so (before, silently). SIGINT
  # and SIGTERM sent back to back are both pending when the run next gets the processor (two of
  # one kind would merge into one), so the second is handled while the first only set the
  # flag: the process ends by the second's default action (exit 128 + that signal).
  long twice.xml run_twice
  "$EXE" twice.xml > twice.out 2> twice.err &
  pid=$!
  wait_for twice.err "^t = 0\.0200 / 50\.0000 s" $pid
  kill -INT $pid; kill -TERM $pid
  wait $pid
  rc=$?
  pid=
  [ $rc = 130 ] || [ $rc = 143 ] || fail "SIGINT and SIGTERM: exit code $rc, expected 130 or 143"
  grep -q "^granflow: a second interrupt: stopping at once" twice.err ||
    { cat twice.err; fail "no message for the second signal"; }
  # Resume the SIGINT run into its own directory; a straight run to the same end time.
  t_int=$(sed -n 's/^ *"final_time": \(.*\),/\1/p' run_INT/summary.json)
  # Resume to two output times after the interrupt (where it happened depends on the machine).
  t_end=$(awk -v t="$t_int" 'BEGIN { printf "%g", (int(t / 0.02) + 2) * 0.02 }')
  echo "interrupted at t = $t_int s; resumed and straight runs to $t_end s"
  long resume.xml run_INT -e "s|\"End time\" type=\"double\" value=\"50\"|\"End time\" type=\"double\" value=\"$t_end\"|" \
       -e 's|<Parameter name="Interval" type="double" value="0.02"/>|&<Parameter name="Restart from" type="string" value="run_INT/checkpoint.h5"/>|'
  long straight.xml straight -e "s|\"End time\" type=\"double\" value=\"50\"|\"End time\" type=\"double\" value=\"$t_end\"|"
  expect 0 "completed at t = $t_end s" resume.xml
  expect 0 "completed at t = $t_end s" straight.xml
  # profiles.csv: the interrupted run's rows up to t_int, the resumed ones after: each output
  # time once, every row equal to the straight run's (the schedule origin + k Interval and the
  # state continue exactly).
  cmp run_INT/profiles.csv straight/profiles.csv || fail "the resumed run differs from the straight run"
  grep -q '"steps": ' run_INT/summary.json
  s1=$(sed -n 's/^ *"steps": \([0-9]*\).*/\1/p' run_INT/summary.json)
  s2=$(sed -n 's/^ *"steps": \([0-9]*\).*/\1/p' straight/summary.json)
  [ "$s1" = "$s2" ] || fail "steps: resumed $s1, straight $s2"
else
  # The 2D chute (10 mm) to 5 s under mpiexec; SIGTERM to the second rank only.
  scene "$SRC/record_ndam.xml" mpi.xml -e 's|value="record_dir"/>|value="run_mpi"/>|' \
        -e 's|"End time" type="double" value="0.02"|"End time" type="double" value="5"|'
  mpiexec -n $NP --allow-run-as-root --oversubscribe "$EXE" mpi.xml > mpi.out 2> mpi.err &
  pid=$!
  wait_for mpi.err "^t = 0\.0200 / 5\.0000 s" $pid
  ranks=$(pgrep -f "^$EXE mpi.xml")
  [ $(echo $ranks | wc -w) = $NP ] || fail "found ranks '$ranks'"
  kill -TERM $(echo $ranks | awk '{print $NF}')
  wait $pid
  cat mpi.out mpi.err | grep -v '^t = '
  [ "$(status_of run_mpi/summary.json)" = interrupted ] || fail "summary.json status is not interrupted"
  grep -q '"exit_code": 143' run_mpi/summary.json || fail "summary.json exit_code is not 143"
  grep -q '"ranks": '$NP run_mpi/summary.json || fail "summary.json ranks is not $NP"
  grep -q "^granflow: SIGTERM received; stopped after step" mpi.err || fail "no interrupt message"
  # All ranks wrote one checkpoint of one step: it restarts on NP ranks.
  scene mpi.xml resume.xml -e 's|"End time" type="double" value="5"|"End time" type="double" value="0.4"|' \
        -e 's|<Parameter name="Fields"|<Parameter name="Restart from" type="string" value="run_mpi/checkpoint.h5"/>&|'
  out=$(mpiexec -n $NP --allow-run-as-root --oversubscribe "$EXE" resume.xml 2>&1) || fail "the resumed run failed: $out"
  times=$(cut -d, -f1 run_mpi/profiles.csv | uniq | sort | uniq -d)
  [ "$times" = "" ] || fail "profiles.csv has output times in two blocks: $times"
fi
echo "interrupt checks passed"
