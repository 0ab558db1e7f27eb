#!/usr/bin/env bash
# The C runtime of git REF as a static library, for make bench's before-and-after (BENCH_BASE).
#
#   bench/tools/runtime_at.sh REF DIR    -> DIR/src/runtime_c (its sources and headers), DIR/lib/libub.a
#
# Compiled as bench/run.sh compiles this tree's runtime for the bench programs (gcc -O2, UB_SECURITY=1), from
# wherever REF's tree keeps its sources (flat runtime_c/src/ before the layer folders, runtime_c/src/*/ after),
# two compilers at a time. Bench programs then build with -IDIR/src/runtime_c/include and DIR/lib/libub.a;
# a program case that needs an API REF lacks is left out by the program itself (codec_bench: __has_include).
set -euo pipefail
ref=$1 dir=$2
rm -rf "$dir" && mkdir -p "$dir/src" "$dir/lib"
git archive "$ref" runtime_c | tar -x -C "$dir/src"
src=$dir/src/runtime_c
find "$src/src" -name '*.c' -print0 | sort -z |
  xargs -0 -P 2 -I{} sh -c 'gcc -O2 -std=c11 -D_POSIX_C_SOURCE=200809L -DUB_SECURITY=1 -I"$1/include" -I"$1/src" \
    -c "$2" -o "$3/lib/$(basename "$2" .c).o"' _ "$src" {} "$dir"
ar rcs "$dir/lib/libub.a" "$dir"/lib/*.o
