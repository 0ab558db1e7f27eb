#!/usr/bin/env bash
# Regenerates the checked-in seed corpus fuzz/corpus/<harness>/ (a developer action: `make fuzz-corpus`).
# Seeds come from our own encoders (each harness's --seed mode: frames a node builds, log records as the
# writer lays them out, what the generated pack() writes) plus the project's configuration files, as the
# Zenoh and nanopb OSS-Fuzz builds seed from their encoders. Keep the corpus small: the fuzzers grow their
# working corpus under build-fuzz/, not here.
#   fuzz/make_corpus.sh BUILD_DIR
set -euo pipefail
build=${1:?usage: fuzz/make_corpus.sh BUILD_DIR (a CMake build with the fuzz_replay_* targets)}
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
for h in node_rx nodecfg log_reader codecs mixed_stream ident origin pairs; do
  rm -rf "$here/corpus/$h"
  mkdir -p "$here/corpus/$h"
  "$build/fuzz/fuzz_replay_$h" --seed "$here/corpus/$h"
done
cp "$root"/examples/configs/*.json "$here/corpus/nodecfg/"
# One file per error class of the loader (shared with the Python loader's tests), under 4 kB each.
for f in "$root"/tests/unit/config_cases/*.json; do
  [ "$(stat -c %s "$f")" -le 4096 ] && cp "$f" "$here/corpus/nodecfg/case_$(basename "$f")"
done
du -sh "$here/corpus"/*
