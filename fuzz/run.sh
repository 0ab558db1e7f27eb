#!/usr/bin/env bash
# Runs the libFuzzer harnesses of a fuzz build for a set time each and reports executions and coverage.
#   fuzz/run.sh BUILD_DIR SECONDS [HARNESS...]        (make fuzz: FUZZ_SECONDS, default 600; make test: 5)
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

for h in $harnesses; do
  bin=$build/fuzz/fuzz_$h
  if [ ! -x "$bin" ]; then echo "fuzz/run.sh: $bin missing: build the fuzz_all target of a -DUAVBUS_FUZZ=ON build" >&2; exit 2; fi
  mkdir -p "$out/corpus/$h"
  log=$out/$h.log
  echo "fuzz: $h for ${secs} s"
  "$bin" -max_total_time="$secs" -print_final_stats=1 -timeout=10 -rss_limit_mb=2048 \
    -artifact_prefix="$out/artifacts/$h-" "$out/corpus/$h" "$here/corpus/$h" > "$log" 2>&1
  rc=$?
  row "$h" "$log" "$rc"
  if [ "$rc" -ne 0 ]; then status=1; tail -30 "$log" >&2; fi
done

# Python harnesses under fuzz/python/ (the command line and the log tools; docs/tools.md): each takes
# --seconds N and ends with "<runs> runs in <t> s ...; <k> finding(s)", exit status 1 on a finding, 2 when
# it cannot run (atheris missing). $UAVBUS_FUZZ_OUT tells them where to keep a corpus and put artifacts.
py=${UAVBUS_PYTHON:-$here/../.venv/bin/python}
shopt -s nullglob
pyh=("$here"/python/fuzz_*.py)
if [ ${#pyh[@]} -gt 0 ] && [ $# -eq 0 ]; then
  for f in "${pyh[@]}"; do
    name=$(basename "$f" .py)
    log=$out/$name.log
    echo "fuzz: $name (python) for ${secs} s"
    UAVBUS_FUZZ_OUT=$out "$py" "$f" --seconds "$secs" > "$log" 2>&1
    rc=$?
    runs=$(sed -n 's/.*: \([0-9]*\) runs in \([0-9.]*\) s.*/\1/p' "$log" | tail -1)
    took=$(sed -n 's/.*: \([0-9]*\) runs in \([0-9.]*\) s.*/\2/p' "$log" | tail -1)
    rate=$( [ -n "$runs" ] && [ -n "$took" ] && awk -v r="$runs" -v t="$took" 'BEGIN { if (t > 0) printf "%d", r / t }')
    result=ok
    if [ "$rc" -ne 0 ]; then result="FAILED (exit $rc, see $log)"; status=1; tail -30 "$log" >&2; fi
    # A coverage-guided harness (atheris) adds "(libFuzzer: cov C, ft F, corpus K/B)" to its line.
    cov=$(sed -n 's/.*(libFuzzer: cov \([0-9]*\), ft \([0-9]*\), corpus \([^)]*\)).*/\1|\2|\3/p' "$log" | tail -1)
    IFS='|' read -r pcov pft pcorp <<< "$cov"
    echo "| $name (python) | ${runs:-?} | ${rate:-?} | ${pcov:--} | ${pft:--} | ${pcorp:--} | $result |" >> "$report"
  done
fi
cat "$report"
exit $status
