#!/usr/bin/env bash
# Every byte order and word size (issue 29, item 4): builds the runtime, the generated example codecs and
# the socket-free C tests for
#   s390x-linux-gnu       64-bit big-endian
#   arm-linux-gnueabihf   32-bit little-endian (4-byte pointers and size_t, 8-byte alignment of u64, unsigned char)
# with Debian's cross compilers, runs them under qemu-user, and checks that every shared vector file
# (tests/vectors/*.json) is reproduced byte for byte there by a test that ran and passed. (clang: make test's
# sanitizer tree, build-asan, is its clang build: the whole tree with -Werror, every ctest; docs/testing.md.)
#
#   tests/cross/run.sh [OUT_DIR] [PYTHON]      (make test-cross; OUT_DIR default build-cross)
#
# The targets' cmocka and libsodium are Debian's own packages, fetched with apt-get download through a
# private apt state under OUT_DIR and unpacked there (nothing is installed: the machine's dpkg keeps its one
# architecture, so no other build sees a second libsodium-dev). The cross compilers and qemu-user are
# ordinary packages (the Makefile's APT_PKGS).
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
OUT=$(mkdir -p "${1:-$ROOT/build-cross}" && cd "${1:-$ROOT/build-cross}" && pwd)
PY=${2:-$ROOT/.venv/bin/python}
JOBS=${UB_CROSS_JOBS:-2}

# Each shared vector file and the tests that must reproduce it. A vector file with no entry here fails the
# run: a new one must be checked on every target too.
declare -A VECTOR_TESTS=(
  [frames.json]="test_frame_vectors"
  [signed_frames.json]="test_sec_vectors"
  [compact_frames.json]="test_compact_vectors"
  [inspect.json]="test_inspect_vectors"
  [identity.json]="test_ident_vectors"
  [origin_frames.json]="test_origin_vectors"
  [legacy_envelope.json]="test_legacy_vectors"
  [structs.json]="test_struct_vectors_flightsw test_struct_vectors_kinds"
)
# On a 32-bit target (ILP32) one part of structs.json cannot be: the `kinds` catalogue
# (tests/gen_cases/all_kinds.h) has `long` and `unsigned long` members, whose wire size is the ABI's (8 bytes
# on LP64, 4 on ILP32: a header with `long` makes a different catalogue, and fingerprint, per data model), and
# its vectors hold 64-bit values. Its flightsw part (fixed-width types, as flight software's interfaces are) is
# checked there like every other file.
ILP32_NOT_APPLICABLE="test_struct_vectors_kinds"
# The socket-free tests run under qemu besides the vector tests: frames and CRCs, the catalogue and the
# generated codecs' layouts, the router and node (signed too), tables, routing, membership, compact links,
# fragments and inspection over memlinks, the config parser, and logs (their writer and reader). Tests that
# need sockets or ptys (udp, tcp, serial, ports, accounting, contracts) are left to the native builds, and so
# are the long randomised ones (test_log_damage, test_frame_fuzz, test_loops), which exercise no other
# byte-order path than test_log and test_frame_codec do.
CORE_TESTS="test_frame_codec test_frame_crc test_catalogue test_layout test_router test_node test_node_sec test_sec
  test_sec_failclosed test_pubsub test_route test_member test_memlink test_nodecfg test_policy test_inspect
  test_wire_paths test_log test_table1 test_ident test_revoke test_origin test_frag_fair test_compact_limit"

fail() { echo "test-cross: $*" >&2; exit 1; }

vector_tests=""
for f in "$ROOT"/tests/vectors/*.json; do
  name=$(basename "$f")
  [[ -n "${VECTOR_TESTS[$name]:-}" ]] || fail "tests/vectors/$name is reproduced by no test on the cross targets: add it to VECTOR_TESTS in tests/cross/run.sh"
  vector_tests="$vector_tests ${VECTOR_TESTS[$name]}"
done
ALL_TESTS="$vector_tests $CORE_TESTS"

# --- the targets' cmocka and libsodium, unpacked from Debian's packages --------------------------------
# Both targets' packages come through one private apt state, with one `apt-get update` and one
# `apt-get download` for every target whose sysroot is missing. The update fetches only the targets' Packages
# indexes (the first target is apt's native architecture there, so the host's amd64 index, its translations
# and AppStream data are not fetched), and each apt-get call parses every index it has (several seconds):
# one update and one download per target did that twice over (both sysroots from nothing, load ~6: 38.9 and
# 55.6 s wall, 10 s CPU, that way; 21.5 and 23.3 s wall, 5 s CPU, this way; the same sysroots byte for byte).
fetch_sysroots() { # triple:debian-arch ...
  local apt=$OUT/apt p arch sysroot missing=() pkgs=()
  for p in "$@"; do [[ -f $OUT/sysroot-${p%%:*}/.complete ]] || missing+=("$p"); done
  ((${#missing[@]})) || return 0
  rm -rf "$apt/debs" && mkdir -p "$apt/lists/partial" "$apt/cache/archives/partial" "$apt/debs"
  local opts=(-o "Dir::State::Lists=$apt/lists" -o "Dir::Cache=$apt/cache" -o "APT::Sandbox::User=root"
              -o "Debug::NoLocking=1" -qq -o "APT::Architecture=${missing[0]##*:}" -o "Acquire::Languages=none")
  for p in DEP-11 DEP-11-icons DEP-11-icons-small; do opts+=(-o "Acquire::IndexTargets::deb::$p::DefaultEnabled=false"); done
  for p in "${missing[@]}"; do
    arch=${p##*:}
    opts+=(-o "APT::Architectures::=$arch")
    pkgs+=(libcmocka0:"$arch" libcmocka-dev:"$arch" libsodium23:"$arch" libsodium-dev:"$arch")
  done
  # An index that fails to download (a mirror mid-sync) does not stop the packages below from being found;
  # if they are not, apt-get download says so.
  apt-get "${opts[@]}" update >/dev/null 2>&1 || true
  (cd "$apt/debs" && apt-get "${opts[@]}" download "${pkgs[@]}") \
    || fail "could not fetch cmocka and libsodium for ${missing[*]}"
  for p in "${missing[@]}"; do
    arch=${p##*:} sysroot=$OUT/sysroot-${p%%:*}
    rm -rf "$sysroot" && mkdir -p "$sysroot"
    for deb in "$apt/debs"/*_"$arch".deb; do dpkg-deb -x "$deb" "$sysroot"; done
    touch "$sysroot/.complete"
  done
}

# --- one target: configure, build what the tests need, run them under qemu ------------------------------
run_target() { # triple debian-arch description data-model (lp64|ilp32)
  local triple=$1 arch=$2 build=$OUT/$1 TESTS=$ALL_TESTS t
  if [[ $4 == ilp32 ]]; then
    TESTS=""
    for t in $ALL_TESTS; do [[ " $ILP32_NOT_APPLICABLE " == *" $t "* ]] || TESTS="$TESTS $t"; done
  fi
  command -v "$triple-gcc" >/dev/null || fail "$triple-gcc missing: make setup installs gcc-${triple%%-*}... (APT_PKGS)"
  # A toolchain file's flags are read at the first configure only: start over when it changed.
  [[ "$ROOT/tests/cross/linux-cross.cmake" -nt "$build/CMakeCache.txt" ]] && rm -f "$build/CMakeCache.txt"
  cmake -S "$ROOT" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release "-DUAVBUS_PYTHON=$PY" \
    "-DCMAKE_TOOLCHAIN_FILE=$ROOT/tests/cross/linux-cross.cmake" "-DUB_CROSS_TRIPLE=$triple" \
    "-DUB_CROSS_SYSROOT=$OUT/sysroot-$triple" >/dev/null
  # shellcheck disable=SC2086
  cmake --build "$build" -j "$JOBS" --target $TESTS flightsw_roundtrip
  local regex
  regex="^($(echo $TESTS examples_flightsw_roundtrip | tr ' ' '|'))\$"
  # Every test of the list is in this build (one missing would otherwise pass by its absence); ctest fails
  # when any of them fails.
  local listed
  listed=$(ctest --test-dir "$build" -N -R "$regex" | sed -n 's/^ *Test *#[0-9]*: //p')
  for t in $TESTS; do
    grep -qx "$t" <<<"$listed" || fail "$triple: $t is not a test of this build"
  done
  ctest --test-dir "$build" --output-on-failure -j "$JOBS" -R "$regex"
  local note="every file of tests/vectors reproduced"
  [[ $4 == ilp32 ]] && note="$note (structs.json: its flightsw vectors; the kinds ones are LP64's, see ILP32_NOT_APPLICABLE)"
  echo "test-cross: $triple ($3): $(( $(wc -w <<<"$TESTS") + 1 )) tests passed under qemu, $note"
}

# Both sysroots in one apt-get update and one download (~22 s wall for 5 s of CPU from nothing, nothing once
# they are there). A clang Release tree used to build beside it; make test's clang ASan/UBSan tree (test-c)
# checks what it checked, so the download is on the path again on a clean clone only.
# (Not `fetch_sysroots ... || fail`: set -e does not act inside a function called as a condition.)
fetch_sysroots s390x-linux-gnu:s390x arm-linux-gnueabihf:armhf

run_target s390x-linux-gnu s390x "64-bit big-endian" lp64
run_target arm-linux-gnueabihf armhf "32-bit little-endian" ilp32
