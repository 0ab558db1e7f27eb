#!/usr/bin/env bash
# Instruction counts of figures 1-3 (callgrind), the load-independent side of make bench's before-and-after.
#
#   bench/tools/counts.sh BIN_DIR OUT_DIR FIGURE...     FIGURE: 1 (codec_bench), 2 (router_hops), 3 (loop_bench)
#
# Runs BIN_DIR's programs under valgrind --tool=callgrind over a fixed amount of work (codec_bench callgrind:
# 20,000 operations per case; router_hops H callgrind: 20,000 frames through 1 and 3 hops; loop_bench rtt
# udp|tcp 2000 same: 2,000 round trips, each process dumping its measured loop) into OUT_DIR/cg.PID, which
# bench/tables.py reads by dump name. Each run is a sample (bench/tools/sample.sh) logged to
# OUT_DIR/../counts-NAME.log: one that fails or passes its deadline is a line of failures.txt beside it, and the
# script goes on to the next and exits 0, as every sample of the bench does.
set -u
bin=$(realpath "$1") out=$2
shift 2
sample=$(dirname "$(realpath "$0")")/sample.sh
mkdir -p "$out"
out=$(realpath "$out")
log=$(dirname "$out")/counts-$(basename "$out").log
cd "$out" || exit 2
cg=(valgrind -q --tool=callgrind --callgrind-out-file=cg.%p)
for f in "$@"; do
  case $f in
    1) "$sample" "$log" 1800 "${cg[@]}" "$bin/codec_bench" callgrind 2>/dev/null ;;
    2) for h in 1 3; do "$sample" "$log" 600 "${cg[@]}" "$bin/router_hops" "$h" callgrind 2>/dev/null; done ;;
    3) for t in udp tcp; do
         LOOP_BENCH_DEADLINE_S=300 "$sample" "$log" 400 "${cg[@]}" "$bin/loop_bench" rtt "$t" 2000 same 2>/dev/null
       done ;;
    *) echo "counts.sh: figure $f: use 1, 2 or 3" >&2; exit 2 ;;
  esac
done
exit 0
