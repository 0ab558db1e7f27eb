#!/usr/bin/env bash
# make bench: builds the runtime's measurement tools optimised (Release) and writes bench/results.md.
# Figures are medians over repeated runs on this machine; compare ratios, not absolute values.
# Peers (MAVLink, LCM) join this run with the benchmark issue; until then this records our own costs.
set -euo pipefail
cd "$(dirname "$0")/.."
build=build-bench
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DUAVBUS_PYTHON="$PWD/.venv/bin/python" >/dev/null
cmake --build "$build" --target ub_frame_bench ub_router_bench ub_far >/dev/null
out=bench/results.md
run() {  # run "title" command...: appends the command and its output to results.md
  local title=$1; shift
  echo "running: $*" >&2
  { echo "## $title"; echo; echo '```'; echo "\$ $*"; "$@"; echo '```'; echo; } >>"$out"
}
{
  echo "# uavbus benchmark results"
  echo
  echo "Written by \`make bench\` (bench/run.sh) on $(date -u +%Y-%m-%d), $(nproc) cores,"
  echo "$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), gcc $(gcc -dumpversion), Release (-O3)."
  echo "Peer figures for the same machine kind are in ../shared/anchors/peers.md (MAVLink C pack 78-164 ns,"
  echo "parse+decode 218-358 ns for 40-75 byte frames); the side-by-side run arrives with the benchmark issue."
  echo
} >"$out"
run "Frame codec (build = header + both checks; parse = verify + header decode)" "$build/runtime_c/ub_frame_bench"
run "Router, in-process (forward / deliver / originate)" "$build/runtime_c/ub_router_bench"
run "Checksum false-accept rate under random corruption (paper's 8-bit sums vs CRC-32C)" "$build/runtime_c/ub_far" 1000000
echo "wrote $out" >&2
