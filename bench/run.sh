#!/usr/bin/env bash
# make bench: uavbus side by side with MAVLink, LCM and the floors, in one run on this machine;
# writes bench/results.md (bench/tables.py turns the raw outputs in build-bench/raw/ into tables).
# Compare ratios, not absolute values: figures drift between runs and machines.
#
#   bench/run.sh            everything (~8 minutes on 2 vCPUs)
#   RUNS=3 bench/run.sh     fewer loopback rounds
#   BENCH_BASE=REF bench/run.sh   also figures 1-3 with the runtime of git REF (e.g. the commit before a core
#                           change), interleaved with ours in the same run: results.md gains "Before and after"
#                           (make bench BENCH_BASE=REF), with time (noisy on a shared machine) and callgrind
#                           instruction counts of both runtimes (the same on a busy machine as on a quiet one)
#   BENCH_COUNTS_AT="REF ..." bench/run.sh  also figures 1-3 by instruction count over the runtime of each REF
#                           (oldest first), beside this tree's: which commit changed the frame path's cost
#   BENCH_ONLY=core bench/run.sh  figures 1-3 only (and their before-and-after with BENCH_BASE), written to
#                           bench/results-core.md; bench/results.md is left as it is (make bench-core)
#
# Issue #28's goals are judged in results.md's Goals table from this run's raw outputs (bench/goal_tables.py), and
# each in-process one has a profile from this run in its appendix (bench/profile_tables.py): figure 1's callgrind
# dumps, router_hops 1|3 under callgrind, bench/py_profile.py (cProfile) and perf record around the 1,000-vehicle
# sample; together under a minute on 2 vCPUs. bench/results_notes.md keeps the next step for each goal by hand.
#
# A sample that fails or passes its deadline is listed in results.md and the run goes on; the run exits 0
# with the failures stated in the file (and on stderr as they happen): a bench is a measurement, and one
# lost sample must not throw away the hour of figures around it. A failed build or missing peer still stops it.
#
# Peers are installed at run time from PyPI into .venv (the `bench` extra: pymavlink, lcm); their
# generated code goes to build-bench/peers/ and is never committed. valgrind (Debian) is installed
# here if missing, for callgrind instruction counts; it is not part of `make test`.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
build=build-bench
raw=$build/raw
peers=$build/peers
gen=$build/bench-gen
bin=$build/bench-bin
VPY=$root/.venv/bin/python
RUNS=${RUNS:-5}
ONLY=${BENCH_ONLY:-all}
case $ONLY in all | core) ;; *) echo "bench: BENCH_ONLY=$ONLY: use core (figures 1-3) or leave it unset" >&2; exit 2 ;; esac
mkdir -p "$raw" "$peers" "$gen" "$bin"
rm -rf "${raw:?}"/*   # raw/callgrind is a directory: a second run must not stop here

say() { echo "bench: [$(date +%T)] $*" >&2; }   # the time: how long each figure took
# Every child of the bench runs with a deadline (bench/tools/sample.sh): a sample that fails or times out is
# written to $raw/failures.txt, reported in results.md ("Failed or timed-out samples"), and the run goes on.
# Deadlines are generous (several times a quiet run's duration): they exist so a hung child cannot stop the run.
SAMPLE=$root/bench/tools/sample.sh
sample() { # sample OUT DEADLINE_S command...: records the command for results.md, then runs it with a deadline
  local out=$1 dl=$2; shift 2
  echo "$*" >>"$raw/commands.txt"
  "$SAMPLE" "$out" "$dl" "$@"
}
: >"$raw/failures.txt"

# ---- 0. peers and tools ----
if ! command -v valgrind >/dev/null; then
  say "installing valgrind (Debian)"
  SUDO=""; [ "$(id -u)" = 0 ] || SUDO=sudo
  $SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq valgrind >/dev/null
fi
# perf (Debian's linux-perf) profiles the 1,000-vehicle fleet run; without it that profile is reported missing.
if ! command -v perf >/dev/null; then
  say "installing perf (Debian linux-perf) for the 1,000-vehicle profile"
  SUDO=""; [ "$(id -u)" = 0 ] || SUDO=sudo
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq linux-perf >/dev/null 2>&1 || say "perf not installed: no fleet profile"
fi
say "installing the bench extra (pymavlink, lcm) into .venv"
timeout -k 5 1800 "$VPY" -m pip install -q -e '.[bench]' --no-build-isolation 2>&1 | grep -v -i -E "warning|^ *!!|^ *\*|^ *$|corresp|wheel_obj|Please|By 2027|See https|name as your package" >&2 || true
site=$("$VPY" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')
lcm_inc=$site/include
lcm_lib=$site/lib
test -f "$lcm_inc/lcm/lcm.h" -a -f "$lcm_lib/liblcm.so" || { echo "bench: the lcm wheel has no liblcm/lcm.h under $site" >&2; exit 2; }

say "generating the peers' code into $peers"
rm -rf "$peers/mavlink" "$peers/lcmgen" "$peers/lcmpy"
mkdir -p "$peers/lcmgen" "$peers/lcmpy"
timeout -k 5 600 "$root/.venv/bin/mavgen.py" --lang=C --wire-protocol=2.0 --output="$peers/mavlink" \
  "$site/pymavlink/dialects/v20/common.xml" >/dev/null
(cd "$peers" && "$root/.venv/bin/lcm-gen" -c --c-cpath lcmgen --c-hpath lcmgen "$root/bench/catalogue/bench_msgs.lcm" \
  && "$root/.venv/bin/lcm-gen" -p --ppath lcmpy "$root/bench/catalogue/bench_msgs.lcm") >/dev/null

# ---- 1. our side: runtime (Release), bench catalogue, bench programs ----
say "building the runtime (Release) and the bench catalogue"
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DUAVBUS_PYTHON="$VPY" >/dev/null
[ "$ONLY" = core ] || cmake --build "$build" --target ub_frame_bench ub_router_bench ub_far >/dev/null
# The runtime for the bench programs: every runtime_c/src/*/*.c at -O2 (as the peers are built), in one archive.
mkdir -p "$build/bench-lib"
rm -f "$build"/bench-lib/*
for f in runtime_c/src/*/*.c; do
  gcc -O2 -std=c11 -D_POSIX_C_SOURCE=200809L -DUB_SECURITY=1 -Iruntime_c/include -Iruntime_c/src -c "$f" \
    -o "$build/bench-lib/$(basename "$f" .c).o"
done
ar rcs "$build/bench-lib/libub.a" "$build"/bench-lib/*.o
SODIUM=$(pkg-config --libs libsodium)   # frame security (ub_sec.c); the same libsodium the runtime links
timeout -k 5 600 "$root/.venv/bin/uavbus" gen bench/catalogue/bench_msgs.h --name benchcat -o "$gen" >/dev/null
echo "uavbus gen bench/catalogue/bench_msgs.h --name benchcat -o $gen" >>"$raw/commands.txt"
CFLAGS=(-O2 -std=gnu11 -Wall -Wextra -Werror -D_POSIX_C_SOURCE=200809L -Iruntime_c/include -Ibench/catalogue -I"$gen")
LIBUB=$build/bench-lib/libub.a
gcc "${CFLAGS[@]}" -Wno-address-of-packed-member -I"$peers/mavlink" -I"$peers/lcmgen" -I"$lcm_inc" \
  bench/src/codec_bench.c "$gen/benchcat.c" "$peers"/lcmgen/*.c "$LIBUB" $SODIUM -L"$lcm_lib" -llcm \
  -Wl,-rpath,"$lcm_lib" -o "$bin/codec_bench"
gcc "${CFLAGS[@]}" bench/src/router_hops.c "$gen/benchcat.c" "$LIBUB" $SODIUM -ldl -o "$bin/router_hops"
gcc "${CFLAGS[@]}" bench/src/loop_bench.c "$gen/benchcat.c" "$LIBUB" $SODIUM -o "$bin/loop_bench"
[ "$ONLY" = core ] || gcc "${CFLAGS[@]}" bench/src/origin_bench.c "$LIBUB" $SODIUM -o "$bin/origin_bench"
gcc "${CFLAGS[@]}" -I"$lcm_inc" bench/src/lcm_loop.c -L"$lcm_lib" -llcm -Wl,-rpath,"$lcm_lib" -o "$bin/lcm_loop"

# ---- the same bench programs over the runtime of BENCH_BASE (a git ref), for figures 1-3 before and after ----
# Only the runtime differs: the bench sources, the generated catalogue and the peers are this tree's, so a
# difference between the two columns is the runtime's. bench/tools/runtime_at.sh finds the base's sources
# wherever its tree put them; a bench case the base's API lacks is left out by the program (__has_include).
base_bin=""
if [ -n "${BENCH_BASE:-}" ]; then
  base=$build/base
  base_bin=$bin/base
  say "building the runtime of BENCH_BASE=$BENCH_BASE for figures 1-3 before and after"
  rm -rf "$base_bin" && mkdir -p "$base_bin"
  "$root/bench/tools/runtime_at.sh" "$BENCH_BASE" "$base"
  git rev-parse --short "$BENCH_BASE" >"$raw/base_ref.txt"
  BCFLAGS=("${CFLAGS[@]/-Iruntime_c\/include/-I$base/src/runtime_c/include}")
  gcc "${BCFLAGS[@]}" -Wno-address-of-packed-member -I"$peers/mavlink" -I"$peers/lcmgen" -I"$lcm_inc" \
    bench/src/codec_bench.c "$gen/benchcat.c" "$peers"/lcmgen/*.c "$base/lib/libub.a" $SODIUM -L"$lcm_lib" -llcm \
    -Wl,-rpath,"$lcm_lib" -o "$base_bin/codec_bench"
  gcc "${BCFLAGS[@]}" bench/src/router_hops.c "$gen/benchcat.c" "$base/lib/libub.a" $SODIUM -ldl -o "$base_bin/router_hops"
  gcc "${BCFLAGS[@]}" bench/src/loop_bench.c "$gen/benchcat.c" "$base/lib/libub.a" $SODIUM -o "$base_bin/loop_bench"
  echo "BENCH_BASE=$BENCH_BASE: the same bench programs over bench/tools/runtime_at.sh $BENCH_BASE, interleaved" >>"$raw/commands.txt"
fi

# ---- figure 1: C codecs (3 processes x 11 interleaved samples; callgrind once) ----
say "figure 1: C codecs"
for p in 1 2 3; do
  sample "$raw/codec.tsv" 600 taskset -c 0 "$bin/codec_bench"
  if [ -n "$base_bin" ]; then "$SAMPLE" "$raw/base_codec.tsv" 600 taskset -c 0 "$base_bin/codec_bench"; fi
done
# Instruction counts (callgrind): figure 1's cases here; with BENCH_BASE, the base's too and figures 2 and 3's
# (counts_for, after figure 3): what the before-and-after is judged on when the machine is not quiet.
counts_for() { "$root/bench/tools/counts.sh" "$@"; }   # BIN_DIR OUT_DIR FIGURES...: callgrind dumps
counts_for "$bin" "$raw/callgrind" 1
echo "valgrind --tool=callgrind $bin/codec_bench callgrind" >>"$raw/commands.txt"

# ---- figure 1c: origin authentication (per-frame cost, pairwise derivation, RAM) ----
if [ "$ONLY" = all ]; then
  say "figure 1c: origin authentication"
  for p in 1 2 3; do sample "$raw/origin.tsv" 600 taskset -c 0 "$bin/origin_bench"; done
fi

# ---- figure 2: router in-process over memlinks ----
# With BENCH_BASE, RUNS rounds alternate this tree's process and the base's (ABAB...), so a change of the
# machine's state during the run (another process, a frequency step) falls on both columns alike; one
# process each, back to back, once showed 10 % between two builds whose instruction counts differ by 1 %.
say "figure 2: router, 1 and 3 hops"
rounds=1
[ -n "$base_bin" ] && rounds=$RUNS
for h in 1 3; do
  for r in $(seq "$rounds"); do
    sample "$raw/router.txt" 600 taskset -c 0 "$bin/router_hops" "$h"
    if [ -n "$base_bin" ]; then "$SAMPLE" "$raw/base_router.txt" 600 taskset -c 0 "$base_bin/router_hops" "$h"; fi
  done
done
# The profile of figure 2 (results.md's appendix, issue #28: a miss explained by a profile of the same run):
# router_hops 1 and 3 under callgrind, 20,000 frames each (~10 s); also the before-and-after's count of figure 2.
counts_for "$bin" "$raw/callgrind" 2
echo "valgrind --tool=callgrind $bin/router_hops 1|3 callgrind (figure 2's profile)" >>"$raw/commands.txt"

# ---- figure 3: loopback between 2 processes, in a private network namespace (only lo) ----
say "figure 3: loopback UDP/TCP/raw UDP/LCM udpm, $RUNS interleaved rounds"
unshare -rn bash -c '
  set -e
  ip link set lo up
  ip route add 224.0.0.0/4 dev lo
  if ip -o link | grep -v " lo:" | grep -q .; then echo "bench: namespace has more than lo" >&2; exit 2; fi
  bin=$1; runs=$2; base_bin=$3; raw=$4; S=$5
  # Each sample: its own deadline inside loop_bench/lcm_loop (LOOP_BENCH_DEADLINE_S), and timeout around it.
  export LOOP_BENCH_DEADLINE_S=120
  L=$raw/loop.txt
  for r in $(seq "$runs"); do
    for pl in split same; do
      if [ -n "$base_bin" ]; then
        for t in udp tcp; do "$S" "$raw/base_loop.txt" 150 "$base_bin/loop_bench" blast $t 1000000 $pl; done
        for t in udp tcp; do "$S" "$raw/base_loop.txt" 150 "$base_bin/loop_bench" rtt $t 10000 $pl; done
      fi
      "$S" "$L" 150 "$bin/loop_bench" blast udp 1000000 $pl
      "$S" "$L" 150 "$bin/loop_bench" blast tcp 1000000 $pl
      "$S" "$L" 150 "$bin/loop_bench" blast udp 300000 $pl nobatch
      "$S" "$L" 150 "$bin/loop_bench" blast raw-udp 300000 $pl
      "$S" "$L" 150 "$bin/lcm_loop" blast 200000 $pl
      "$S" "$L" 150 "$bin/loop_bench" rtt udp 10000 $pl
      "$S" "$L" 150 "$bin/loop_bench" rtt tcp 10000 $pl
      "$S" "$L" 150 "$bin/loop_bench" rtt raw-udp 10000 $pl
      "$S" "$L" 150 "$bin/lcm_loop" rtt 10000 $pl
    done
  done' _ "$bin" "$RUNS" "$base_bin" "$raw" "$SAMPLE"
echo "unshare -rn: loop_bench blast udp|tcp 1000000, udp 300000 nobatch, raw-udp 300000; lcm_loop blast 200000;" \
  "rtt 10000 each; placements split and same; $RUNS interleaved rounds (see bench/run.sh)" >>"$raw/commands.txt"

# ---- before and after by instruction count: figures 2 and 3 for both runtimes, figure 1 for the base ----
if [ -n "$base_bin" ] || [ -n "${BENCH_COUNTS_AT:-}" ]; then
  say "figures 1-3 by instruction count (callgrind), this tree${BENCH_BASE:+ and $BENCH_BASE}"
  counts_for "$bin" "$raw/callgrind" 3   # figure 2's count was taken after figure 2 (its profile)
  [ -z "$base_bin" ] || counts_for "$base_bin" "$raw/base_callgrind" 1 2 3
  echo "valgrind --tool=callgrind: codec_bench callgrind; router_hops 1|3 callgrind; loop_bench rtt udp|tcp 2000 same" \
    "(the programs of this tree${BENCH_BASE:+ and of the base})" >>"$raw/commands.txt"
fi
# BENCH_COUNTS_AT: the same three programs over each ref's runtime, counted only (deterministic: no rounds needed).
if [ -n "${BENCH_COUNTS_AT:-}" ]; then
  for ref in $BENCH_COUNTS_AT; do
    short=$(git rev-parse --short "$ref")
    say "figures 1-3 by instruction count over the runtime of $ref ($short)"
    at=$build/at/$short
    "$root/bench/tools/runtime_at.sh" "$ref" "$at"
    mkdir -p "$bin/at-$short"
    ACFLAGS=("${CFLAGS[@]/-Iruntime_c\/include/-I$at/src/runtime_c/include}")
    gcc "${ACFLAGS[@]}" -Wno-address-of-packed-member -I"$peers/mavlink" -I"$peers/lcmgen" -I"$lcm_inc" \
      bench/src/codec_bench.c "$gen/benchcat.c" "$peers"/lcmgen/*.c "$at/lib/libub.a" $SODIUM -L"$lcm_lib" -llcm \
      -Wl,-rpath,"$lcm_lib" -o "$bin/at-$short/codec_bench"
    gcc "${ACFLAGS[@]}" bench/src/router_hops.c "$gen/benchcat.c" "$at/lib/libub.a" $SODIUM -ldl -o "$bin/at-$short/router_hops"
    gcc "${ACFLAGS[@]}" bench/src/loop_bench.c "$gen/benchcat.c" "$at/lib/libub.a" $SODIUM -o "$bin/at-$short/loop_bench"
    counts_for "$bin/at-$short" "$raw/at-$short" 1 2 3
    echo "$short $(git log -1 --format=%s "$ref" | cut -c1-80)" >>"$raw/counts_at.txt"
  done
  echo "BENCH_COUNTS_AT=\"$BENCH_COUNTS_AT\": the same programs over bench/tools/runtime_at.sh REF, counted by callgrind" >>"$raw/commands.txt"
fi

if [ "$ONLY" = core ]; then
  timeout -k 5 300 "$VPY" bench/tables.py --core "$raw" bench/results-core.md
  say "wrote bench/results-core.md (figures 1-3$([ -n "$base_bin" ] && echo " and their before-and-after with $BENCH_BASE"))"
  exit 0
fi

# ---- figure 4: Python ----
say "figure 4: Python"
for p in 1 2 3; do sample "$raw/py.txt" 900 taskset -c 0 .venv/bin/python bench/py_bench.py "$gen/benchcat.catalogue.json" "$peers/lcmpy"; done
# Its profile (results.md's appendix): the same batched publish + receive under cProfile, 32,000 messages a type.
sample "$raw/profile_py.txt" 300 taskset -c 0 "$VPY" bench/py_profile.py "$gen/benchcat.catalogue.json" "$peers/lcmpy"

# ---- figure 5: generator time on synthetic headers ----
say "figure 5: generator"
for n in 100 700 3000 10000; do
  sample "$raw/gen_synth.log" 300 "$VPY" bench/tools/gen_synth.py "$n" "$gen/synth$n.h"
  for r in 1 2 3; do
    t0=$(date +%s%N)
    if timeout -k 5 600 "$root/.venv/bin/uavbus" gen "$gen/synth$n.h" --name synth -o "$gen/synth$n" >/dev/null; then
      t1=$(date +%s%N)
      echo "gen n=$n ns=$((t1 - t0))" >>"$raw/gen.txt"
    else
      echo "status=failed exit=$? deadline_s=600 out=gen.txt cmd=\"uavbus gen synth$n.h\" reason=\"see the log above\"" >>"$raw/failures.txt"
    fi
  done
done
echo "uavbus gen build-bench/bench-gen/synthN.h --name synth -o ... (N = 100, 700, 3000, 10000; 3 runs each)" >>"$raw/commands.txt"

# ---- figure 5b: generator and selftest at scale (issue #13): tests/corpus/big/make_big.py, N/4 types ----
say "figure 5b: gen and selftest at 1,000 and 10,000 instances"
for n in 1000 10000; do
  sample "$raw/make_big.log" 600 "$VPY" tests/corpus/big/make_big.py "$gen/big$n" --instances "$n"
  t0=$(date +%s%N)
  timeout -k 5 1200 "$root/.venv/bin/uavbus" gen "$gen/big$n/big_all.h" -I "$gen/big$n/include" --name big -o "$gen/big$n/out" >/dev/null 2>&1 || true
  t1=$(date +%s%N)
  timeout -k 5 1500 "$root/.venv/bin/uavbus" selftest "$gen/big$n/big_all.h" -I "$gen/big$n/include" --name big --timeout 1200 >/dev/null 2>&1 \
    && ok=1 || ok=0
  t2=$(date +%s%N)
  echo "scale n=$n gen_ns=$((t1 - t0)) selftest_ns=$((t2 - t1)) ok=$ok" >>"$raw/scale.txt"
done
echo "make_big.py N; uavbus gen|selftest big_all.h -I include --name big (N = 1000, 10000; jobs = all CPUs)" >>"$raw/commands.txt"

# ---- figure 6: RAM for the reference configuration, and allocations after init ----
say "figure 6: RAM"
REF=(-DUB_MAX_ENTITIES=16 -DUB_MAX_LINKS_PER_ENTITY=8 -DUB_MAX_NODE_LINKS=8 -DUB_MAX_LOCAL_ENTITIES=4 -DUB_MAX_PUBSUB_ROWS=64)
mkdir -p "$build/ref-obj"
rm -f "$build/ref-obj"/*.o
for f in runtime_c/src/*/*.c; do
  gcc -O2 -std=c11 -D_POSIX_C_SOURCE=200809L -DUB_SECURITY=1 "${REF[@]}" -Iruntime_c/include -Iruntime_c/src -c "$f" \
    -o "$build/ref-obj/$(basename "$f" .c).o"
done
gcc -O2 -std=c11 -D_POSIX_C_SOURCE=200809L "${REF[@]}" -Iruntime_c/include bench/src/ram_bench.c -o "$bin/ram_bench"
sample "$raw/ram.txt" 120 "$bin/ram_bench"
size -t "$build"/ref-obj/*.o | tail -1 | sed 's/^/size /' >>"$raw/ram.txt"
echo "gcc -O2 ${REF[*]} runtime_c/src/*/*.c; size -t; bench/src/ram_bench.c" >>"$raw/commands.txt"

# ---- figure 6b: the core on a microcontroller (examples/mcu, Cortex-M4F, arm-none-eabi-gcc -Os) ----
say "figure 6b: the core cross-compiled for a Cortex-M4F"
# With security, as `make firmware` builds it: libsodium from its sources (examples/mcu/fetch_libsodium.sh)
sh examples/mcu/fetch_libsodium.sh "$root/build-mcu/deps" "$VPY" >/dev/null
cmake -S examples/mcu -B "$build/mcu" -G Ninja -DCMAKE_BUILD_TYPE=MinSizeRel -DUAVBUS_PYTHON="$VPY" \
  -DCMAKE_TOOLCHAIN_FILE="$root/cmake/toolchains/arm-none-eabi-cortex-m4.cmake" \
  -DUAVBUS_MCU_SODIUM_SRC="$root/build-mcu/deps/libsodium-1.0.18/src/libsodium" >/dev/null
cmake --build "$build/mcu" >/dev/null
{ arm-none-eabi-size "$build/mcu/firmware.elf" | tail -1 | sed 's/^/firmware /'
  arm-none-eabi-size -t "$build/mcu/uavbus/runtime_c/libub.a" | tail -1 | sed 's/^/libub /'
  arm-none-eabi-nm -S --size-sort "$build/mcu/firmware.elf" | sed 's/^/sym /'
  # The capacities the sizes hold for, as the ELF records them (firmware.c's fw_capacities).
  "$VPY" -c 'import sys; from uavbus.sim.qemu import firmware_capacities as c
print("caps", *(f"{k}={v}" for k, v in c(sys.argv[1]).items()))' "$build/mcu/firmware.elf"; } >"$raw/mcu.txt"
# Origin authentication's state on the same target and capacities (figure 1c): sizeof(ub_origin_t), 64 pairs.
printf '#include "ub/ub_origin.h"\nub_origin_t bench_origin;\n' >"$build/mcu/origin_size.c"
for peers in 64 8; do   # 64 known peers (the issue's figure); 8: the firmware's provisioned pairs (mcu_ub_config.h)
  arm-none-eabi-gcc -mcpu=cortex-m4 -mthumb -Os -std=c11 -DUB_CONFIG_FILE='"mcu_ub_config.h"' -DUB_ORIGIN_PEERS=$peers \
    -Iexamples/mcu -Iruntime_c/include -c "$build/mcu/origin_size.c" -o "$build/mcu/origin_size.o"
  printf 'ram\tub_origin_t on a Cortex-M4 (arm-none-eabi-gcc -Os, examples/mcu capacities, UB_ORIGIN_PEERS=%d)\t%d\n' \
    "$peers" "$((16#$(arm-none-eabi-nm -S "$build/mcu/origin_size.o" | awk '$4 == "bench_origin" {print $2}')))" \
    >>"$raw/origin.tsv"
done
echo "cmake -S examples/mcu -DCMAKE_BUILD_TYPE=MinSizeRel -DCMAKE_TOOLCHAIN_FILE=cmake/toolchains/arm-none-eabi-cortex-m4.cmake;" \
  "arm-none-eabi-size firmware.elf, libub.a" >>"$raw/commands.txt"

# ---- figure 7: the bridges (MAVLink, Zenoh) beside the same paths without them ----
say "figure 7: bridges"
cmake --build "$build" --target uavbus_mavbridge uavbus_node >/dev/null
sample "$raw/bridges.log" 1800 "$VPY" bench/bridges_bench.py --build "$build" --out "$raw/bridges.json" --runs "${BRIDGE_RUNS:-3}"
# figure 7b: the MAVLink front door (issue 26) beside a direct link and MAVProxy as a router (the test extra has MAVProxy)
sample "$raw/mavdoor.log" 900 "$VPY" bench/mavdoor_bench.py --build "$build" --out "$raw/mavdoor.json" --runs "${BRIDGE_RUNS:-3}"

# ---- figure 8: fleets (issue 12): 10, 30, 100 vehicles + 2 ground stations in process; 30 as processes ----
# A fleet of 102 entities needs room in every node's tables: the runtime is compiled again with larger
# capacities (ub_config.h: every capacity is a -D). The process fleet runs uavbus_node built the same way.
say "figure 8: fleets in process (range model, simulated clock) and 30 vehicles as processes over UDP"
FLEET_CAPS=(-DUB_MAX_ENTITIES=128 -DUB_DEDUP_SOURCES=128 -DUB_MAX_LOCAL_ENTITIES=1)
mkdir -p "$build/fleet-lib"
rm -f "$build"/fleet-lib/*
for f in runtime_c/src/*/*.c; do
  gcc -O2 -std=c11 -D_POSIX_C_SOURCE=200809L -DUB_SECURITY=1 "${FLEET_CAPS[@]}" -Iruntime_c/include -Iruntime_c/src -c "$f" \
    -o "$build/fleet-lib/$(basename "$f" .c).o"
done
ar rcs "$build/fleet-lib/libub.a" "$build"/fleet-lib/*.o
gcc "${CFLAGS[@]}" "${FLEET_CAPS[@]}" bench/src/fleet_bench.c "$gen/benchcat.c" "$build/fleet-lib/libub.a" $SODIUM -lm \
  -o "$bin/fleet_bench"
for n in 10 30 100; do sample "$raw/fleet.txt" 1200 "$bin/fleet_bench" "$n"; done
# 1000 vehicles + 2 ground stations on one core (issue 28 item 5): the same harness with room for 1,002 entities. The
# configuration loader counts in uint8_t and is left out (the in-process fleet has no configuration files);
# FLEET_BENCH_END_S bounds the run (the 15 s warm-up and 1 s of quiet). The real-time factor at that scale was
# ~0.02-0.05 before the routing service's timer heap and incremental route choice; ~1.1 by CPU after (docs/routing.md,
# "Cost at scale"), so on a loaded machine the printed (wall) factor is lower than the nodes' CPU allows.
FLEET1K_CAPS=(-DUB_MAX_ENTITIES=1024 -DUB_DEDUP_SOURCES=1024 -DUB_MAX_LOCAL_ENTITIES=1)
mkdir -p "$build/fleet1k-lib"
rm -f "$build"/fleet1k-lib/*
for f in runtime_c/src/*/*.c; do
  [ "$(basename "$f")" = ub_nodecfg.c ] && continue
  gcc -O2 -std=c11 -D_POSIX_C_SOURCE=200809L -DUB_SECURITY=1 "${FLEET1K_CAPS[@]}" -Iruntime_c/include -Iruntime_c/src -c "$f" \
    -o "$build/fleet1k-lib/$(basename "$f" .c).o"
done
ar rcs "$build/fleet1k-lib/libub.a" "$build"/fleet1k-lib/*.o
gcc "${CFLAGS[@]}" "${FLEET1K_CAPS[@]}" bench/src/fleet_bench.c "$gen/benchcat.c" "$build/fleet1k-lib/libub.a" $SODIUM -lm \
  -o "$bin/fleet_bench_1k"
# Its profile (results.md's appendix) is taken around the sample itself: perf record at 199 Hz, no call graph,
# which costs the run nothing measurable; without a working perf the appendix says there is no profile.
perf_rec=()
if command -v perf >/dev/null && perf record -q -o "$raw/perf-check.data" -- true 2>/dev/null; then
  perf_rec=(perf record -q -F 199 -o "$raw/fleet1k.perf.data" --)
else
  echo "status=failed exit=0 deadline_s=0 out=profile_fleet1k.txt cmd=\"perf record\" reason=\"perf is missing or not" \
    "allowed here (kernel.perf_event_paranoid): no profile of the 1,000-vehicle run\"" >>"$raw/failures.txt"
fi
rm -f "$raw/perf-check.data"
sample "$raw/fleet.txt" 2400 env FLEET_BENCH_END_S=16 "${perf_rec[@]}" taskset -c 0 "$bin/fleet_bench_1k" 1000
if [ ${#perf_rec[@]} -gt 0 ]; then
  sample "$raw/profile_fleet1k.txt" 300 perf report -i "$raw/fleet1k.perf.data" --stdio --no-children --sort dso,symbol -q
  rm -f "$raw/fleet1k.perf.data"
  echo "perf record -F 199 around fleet_bench_1k 1000; perf report --no-children --sort dso,symbol" >>"$raw/commands.txt"
fi
cmake -S . -B "$build/fleet-node" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DUAVBUS_BUILD_TESTS=OFF \
  -DUAVBUS_PYTHON="$VPY" "-DCMAKE_C_FLAGS=-DUB_MAX_ENTITIES=64 -DUB_DEDUP_SOURCES=64" >/dev/null
cmake --build "$build/fleet-node" --target uavbus_node >/dev/null
sample "$raw/fleet.txt" 1200 "$VPY" bench/fleet_procs.py "$build/fleet-node/programs/node/uavbus_node" 30 --out "$build/fleet-procs" \
  2>"$raw/fleet_procs.log"

# ---- figure 9: the wire for real radios (issue 15): bytes per message, messages/s through a 57,600-baud radio ----
say "figure 9: bytes on the wire and a simulated 57,600-baud radio, uavbus compact/full beside MAVLink 2 (pymavlink)"
gcc "${CFLAGS[@]}" bench/src/radio_bench.c "$LIBUB" $SODIUM -o "$bin/radio_bench"
rm -rf "$build/wire-frames"
sample "$raw/wire.txt" 900 "$VPY" bench/wire_bench.py "$gen/benchcat.catalogue.json" "$build/wire-frames"
sample "$raw/radio.txt" 900 "$bin/radio_bench" 5760 255 60 "$build"/wire-frames/*.frames

# ---- figure 10: remote inspection (issue 16): one-shot read over 1 and 2 hops, Table 2 processes ----
say "figure 10: remote read round trip over 1 and 2 hops"
[ -d build ] || cmake -S . -B build -G Ninja -DUAVBUS_PYTHON="$VPY" >/dev/null   # the node Hitl runs (sim.build)
cmake --build build --target uavbus_node >/dev/null
sample "$raw/inspect.txt" 900 "$VPY" bench/inspect_bench.py --n "${INSPECT_N:-300}" 2>"$raw/inspect.log"

# ---- figure 11: priorities on a 57,600-baud radio (issue 28): simulated clock, bench/prio_bench.py ----
say "figure 11: commands beside a telemetry flood on a simulated 57,600-baud radio, with and without priorities"
gcc "${CFLAGS[@]}" bench/src/prio_bench.c "$LIBUB" $SODIUM -o "$bin/prio_bench"
sample "$raw/prio.txt" 900 "$VPY" bench/prio_bench.py "$gen/benchcat.catalogue.json" "$bin/prio_bench" "$build/prio-frames"

# ---- internals kept from the first bench (frame codec, router costs, false-accept rate) ----
"$SAMPLE" "$raw/frame_bench.txt" 600 "$build/runtime_c/ub_frame_bench"
"$SAMPLE" "$raw/router_bench.txt" 600 "$build/runtime_c/ub_router_bench"
"$SAMPLE" "$raw/far.txt" 600 "$build/runtime_c/ub_far" 200000

timeout -k 5 300 "$VPY" bench/tables.py "$raw" bench/results.md
say "wrote bench/results.md"
