#!/usr/bin/env bash
# One bench sample with a deadline (issue #28: a bench that survives a busy machine).
#
#   bench/tools/sample.sh OUT DEADLINE_S command...
#
# Runs the command under `timeout` (TERM at the deadline, KILL 5 s later; timeout signals the command's
# whole process group, so forked children go too), appending its stdout to OUT and passing stderr on.
# A sample that fails or times out never stops the run: one line goes to failures.txt beside OUT
# (status=failed|timeout, exit code, deadline, command, the last line it wrote to stderr), which
# bench/tables.py reports in results.md; the script then exits 0.
set -u
out=$1 dl=$2
shift 2
failures=$(dirname "$out")/failures.txt
err=$(mktemp)
timeout -k 5 "$dl" "$@" >>"$out" 2>"$err"
rc=$?
cat "$err" >&2
if [ "$rc" -ne 0 ]; then
  if [ "$rc" -eq 124 ] || [ "$rc" -eq 137 ]; then status=timeout; else status=failed; fi
  reason=$(grep -v '^\s*$' "$err" | tail -n 1 | tr '"' "'")
  [ "$status" = timeout ] && reason="no result within the ${dl}-second deadline${reason:+; last words: $reason}"
  echo "status=$status exit=$rc deadline_s=$dl out=$(basename "$out") cmd=\"$*\" reason=\"$reason\"" >>"$failures"
  echo "bench: sample $status (exit $rc): $*: $reason" >&2
fi
rm -f "$err"
exit 0
