#!/usr/bin/env bash
# Runs the libFuzzer harnesses of a fuzz build for a set time each and reports executions and coverage.
#   fuzz/run.sh BUILD_DIR SECONDS [HARNESS...]        (make fuzz: FUZZ_SECONDS, default 600; make test: 5)
# $FUZZ_JOBS harnesses run at once (default 1; make test-fuzz: 2, one a core): each is one single-threaded
# process for its SECONDS whatever else runs, so two at a time halve the wall time and keep every harness's
# time; on a busy machine each gets fewer executions (the report's exec/s says so).
# Each harness starts from the checked-in corpus fuzz/corpus/<h> and grows its own working corpus in
# BUILD_DIR/fuzz-out/corpus/<h> (kept between runs, never checked in). A crash leaves its input in
# BUILD_DIR/fuzz-out/artifacts/ and makes the run fail. Python harnesses under fuzz/python/ (the CLI and
# the log tools) run for the same time with $UAVBUS_PYTHON (default .venv/bin/python).
set -uo pipefail
build=${1:?usage: fuzz/run.sh BUILD_DIR SECONDS [HARNESS...]}
secs=${2:?usage: fuzz/run.sh BUILD_DIR SECONDS [HARNESS...]}
shift 2
here=$(cd "$(dirname "$0")" && pwd)
harnesses=${*:-node_rx nodecfg log_reader codecs mixed_stream ident origin pairs}
jobs=${FUZZ_JOBS:-1}
out=$build/fuzz-out
mkdir -p "$out/artifacts"
report=$out/report.md
{
  echo "fuzz run: $(date -u +%Y-%m-%dT%H:%MZ), ${secs} s per harness, $(nproc) cores"
  echo
  echo "| harness | executions | exec/s | edges covered | features | corpus (files/bytes) | result |"
  echo "|---|---|---|---|---|---|---|"
} > "$report"
status=0

# The last "#N DONE cov: C ft: F corp: K/B ..." line and the final stats of a libFuzzer log, as a table row.
row() { # name log rc
  local name=$1 log=$2 rc=$3 execs rate done cov ft corp result
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
  done=$(grep -E '^#[0-9]+[[:space:]]+(DONE|pulse|NEW|REDUCE|INITED)' "$log" | tail -1)
  cov=$(sed -n 's/.* cov: \([0-9]*\).*/\1/p' <<< "$done")
  ft=$(sed -n 's/.* ft: \([0-9]*\).*/\1/p' <<< "$done")
  corp=$(sed -n 's/.* corp: \([0-9]*\/[0-9]*[a-zA-Z]*\).*/\1/p' <<< "$done")
  result=ok
  if [ "$rc" -ne 0 ]; then result="FAILED (exit $rc, see $log)"; fi
  echo "| $name | ${execs:-?} | ${rate:-?} | ${cov:-?} | ${ft:-?} | ${corp:-?} | $result |" >> "$report"
}

# Each harness writes its row into $out/rows/<n> and its status into $out/rows/<n>.rc, so the report
# keeps the harnesses' order whatever order they finish in.
rows=$out/rows
rm -rf "$rows" && mkdir -p "$rows"

fuzz_c() { # n harness
  local n=$1 h=$2 bin=$build/fuzz/fuzz_$2 log=$out/$2.log rc
  "$bin" -max_total_time="$secs" -print_final_stats=1 -timeout=10 -rss_limit_mb=2048 \
    -artifact_prefix="$out/artifacts/$h-" "$out/corpus/$h" "$here/corpus/$h" > "$log" 2>&1
  rc=$?
  report=$rows/$n row "$h" "$log" "$rc"
  echo "$rc" > "$rows/$n.rc"
}

# Python harnesses under fuzz/python/ (the command line and the log tools; docs/tools.md): each takes
# --seconds N and ends with "<runs> runs in <t> s ...; <k> finding(s)", exit status 1 on a finding, 2 when
# it cannot run (atheris missing). $UAVBUS_FUZZ_OUT tells them where to keep a corpus and put artifacts.
py=${UAVBUS_PYTHON:-$here/../.venv/bin/python}
fuzz_py() { # n file
  local n=$1 f=$2 name log rc runs took rate result cov pcov pft pcorp
  name=$(basename "$f" .py)
  log=$out/$name.log
  UAVBUS_FUZZ_OUT=$out "$py" "$f" --seconds "$secs" > "$log" 2>&1
  rc=$?
  runs=$(sed -n 's/.*: \([0-9]*\) runs in \([0-9.]*\) s.*/\1/p' "$log" | tail -1)
  took=$(sed -n 's/.*: \([0-9]*\) runs in \([0-9.]*\) s.*/\2/p' "$log" | tail -1)
  rate=$( [ -n "$runs" ] && [ -n "$took" ] && awk -v r="$runs" -v t="$took" 'BEGIN { if (t > 0) printf "%d", r / t }')
  result=ok
  if [ "$rc" -ne 0 ]; then result="FAILED (exit $rc, see $log)"; fi
  # A coverage-guided harness (atheris) adds "(libFuzzer: cov C, ft F, corpus K/B)" to its line.
  cov=$(sed -n 's/.*(libFuzzer: cov \([0-9]*\), ft \([0-9]*\), corpus \([^)]*\)).*/\1|\2|\3/p' "$log" | tail -1)
  IFS='|' read -r pcov pft pcorp <<< "$cov"
  echo "| $name (python) | ${runs:-?} | ${rate:-?} | ${pcov:--} | ${pft:--} | ${pcorp:--} | $result |" > "$rows/$n"
  echo "$rc" > "$rows/$n.rc"
}

# At most $jobs at once: wait for one to end before starting the next.
running=0
start() { # function args...
  if [ "$running" -ge "$jobs" ]; then wait -n; running=$((running - 1)); fi
  "$@" &
  running=$((running + 1))
}

n=0
for h in $harnesses; do
  bin=$build/fuzz/fuzz_$h
  if [ ! -x "$bin" ]; then echo "fuzz/run.sh: $bin missing: build the fuzz_all target of a -DUAVBUS_FUZZ=ON build" >&2; exit 2; fi
  mkdir -p "$out/corpus/$h"
  echo "fuzz: $h for ${secs} s"
  n=$((n + 1))
  start fuzz_c "$(printf %03d $n)" "$h"
done
shopt -s nullglob
pyh=("$here"/python/fuzz_*.py)
if [ ${#pyh[@]} -gt 0 ] && [ $# -eq 0 ]; then
  for f in "${pyh[@]}"; do
    echo "fuzz: $(basename "$f" .py) (python) for ${secs} s"
    n=$((n + 1))
    start fuzz_py "$(printf %03d $n)" "$f"
  done
fi
wait

for r in "$rows"/[0-9][0-9][0-9]; do
  cat "$r" >> "$report"
  rc=$(cat "$r.rc")
  if [ "$rc" -ne 0 ]; then
    status=1
    log=$(sed -n 's/.*see \([^)]*\)).*/\1/p' "$r")
    [ -n "$log" ] && tail -30 "$log" >&2
  fi
done
cat "$report"
exit $status
