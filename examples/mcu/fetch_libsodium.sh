#!/bin/sh
# Unpacks libsodium's sources for the Cortex-M4 build into DIR (DIR/libsodium-1.0.18/src/libsodium) from a
# packaged release on PyPI: PyNaCl 1.5.0's sdist bundles libsodium 1.0.18. Downloaded with pip (the registry's
# ordinary client) once, checked against its published SHA-256, never built on the host. Idempotent.
set -eu
dir=${1:?usage: fetch_libsodium.sh DIR [PYTHON]}
py=${2:-python3}
want=8ac7448f09ab85811607bdd21ec2464495ac8b7c66d146bf545b0f08fb9220ba
out="$dir/libsodium-1.0.18/src/libsodium"
[ -f "$out/sodium/core.c" ] && exit 0
mkdir -p "$dir"
sdist="$dir/PyNaCl-1.5.0.tar.gz"
if [ ! -f "$sdist" ]; then
  "$py" -m pip download -q --no-binary :all: --no-deps --no-build-isolation pynacl==1.5.0 -d "$dir"
fi
got=$(sha256sum "$sdist" | cut -d' ' -f1)
if [ "$got" != "$want" ]; then
  echo "fetch_libsodium.sh: $sdist: SHA-256 $got, expected $want (delete it and run again)" >&2
  exit 1
fi
rm -rf "$dir/unpack" && mkdir -p "$dir/unpack"
tar -xzf "$sdist" -C "$dir/unpack" PyNaCl-1.5.0/src/libsodium
rm -rf "$dir/libsodium-1.0.18"
mv "$dir/unpack/PyNaCl-1.5.0/src/libsodium" "$dir/libsodium-1.0.18"
rm -rf "$dir/unpack"
echo "fetch_libsodium.sh: libsodium 1.0.18 sources in $out"
