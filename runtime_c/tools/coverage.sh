#!/usr/bin/env bash
# Line and branch coverage of runtime_c/src from a --coverage build whose tests have run (make coverage).
# Prints the totals, each file's figures and its missed lines, and writes build-cov/coverage/index.html.
# Goals (issue #17): >= 90 % of lines, >= 80 % of branches; the run fails below COV_MIN_LINES /
# COV_MIN_BRANCHES (default: the goals).
#   runtime_c/tools/coverage.sh BUILD_DIR
set -euo pipefail
build=${1:?usage: runtime_c/tools/coverage.sh BUILD_DIR}
root=$(cd "$(dirname "$0")/../.." && pwd)
min_lines=${COV_MIN_LINES:-90}
min_branches=${COV_MIN_BRANCHES:-80}
mkdir -p "$build/coverage"
# Branches the compiler adds for exceptions or that no input can take are left out, as cFS's lcov runs do.
# The measurement tools (ub_router_bench, ub_frame_bench, ub_far) compile runtime sources themselves at -O2
# and are not tests: their never-run copies would add branches of another shape, so they are not read.
common=(-r "$root" --object-directory "$build" -f "$root/runtime_c/src/" --exclude-unreachable-branches
        --exclude-throw-branches --gcov-ignore-parse-errors
        --exclude-directories '.*/(ub_router_bench|ub_frame_bench|ub_far)\.dir'
        --exclude-directories '.*/CompilerIdC')
gcovr "${common[@]}" --txt "$build/coverage/lines.txt" --html-details "$build/coverage/index.html" \
      --json-summary "$build/coverage/summary.json" --print-summary > "$build/coverage/summary.txt"
gcovr "${common[@]}" --branches --txt "$build/coverage/branches.txt"
echo "== missed lines per file (runtime_c/src) =="
cat "$build/coverage/lines.txt"
echo "== branches per file =="
cat "$build/coverage/branches.txt"
echo "== totals =="
cat "$build/coverage/summary.txt"
echo "details: $build/coverage/index.html"
gcovr "${common[@]}" --fail-under-line "$min_lines" --fail-under-branch "$min_branches" > /dev/null || {
  echo "coverage below the goal (lines >= $min_lines %, branches >= $min_branches %)" >&2
  exit 1
}
