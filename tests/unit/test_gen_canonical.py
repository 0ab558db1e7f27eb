"""Issue #17 item 5 (canonical codecs) and #13 item 6 (bitfields): for every generated type and every
byte string unpack accepts, pack(unpack(bytes)) == bytes. Unpack refuses what no pack writes (a bool
byte other than 0/1, a bitfield value outside its width), in C (UB_ERR_RANGE, nothing written) and
in Python (ValueError), so C and Python take the same decision on the same bytes. Documented
exceptions, each tested here: a signalling NaN comes back quiet through Python's f32 and through a
C `long double` member (binary64 on the wire).

The generated C self-test runs the same property (templates/c/Selftest.c.j2, st_canonical); here it
runs in Python over both codecs (the generated module and uavbus.Catalogue), seeded."""

from __future__ import annotations

import importlib.util
import random
import struct
import subprocess
from pathlib import Path

import pytest
from gen_testutil import ALL_KINDS, REPO, RUNTIME_INCLUDE, gcc, needs_gcc, run_cli

from uavbus import Catalogue
from uavbus.catalogue import DecodeError

FLIGHTSW = REPO / "examples" / "flightsw"
FSW = REPO / "tests" / "corpus" / "fsw"
ROUNDS = 300


def generate(tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str, args: list[str], cwd: Path) -> tuple:
    out = tmp_path / name
    assert run_cli(["gen", *args, "--name", name, "-o", str(out)], cwd, capsys)[0] == 0
    spec = importlib.util.spec_from_file_location(f"_canon_{name}", out / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)  # type: ignore[arg-type]
    spec.loader.exec_module(mod)  # type: ignore[union-attr]
    return mod, Catalogue.load(out / f"{name}.catalogue.json"), out


CORPORA = {
    "kinds": ([str(ALL_KINDS), "--strings", "bytes"], REPO),
    "flightsw": ([*map(str, sorted(FLIGHTSW.glob("*.h"))), "-I", str(FLIGHTSW)], REPO),
    "fsw": ([".", "--std", "gnu99", *(FSW / "flags.txt").read_text().split()[1:], "--max-payload", "2048",
             "--strings", "bytes", "--exclude", "apps/legacy/*", "--exclude", "msg_hdr.h", "--exclude", "nav_events.h"],
            FSW),
}


def quiet_f32_only(data: bytes, out: bytes) -> bool:
    """`out` differs from `data` only where an f32 signalling NaN came back quiet (bit 22 set)."""
    diff = [i for i in range(len(data)) if data[i] != out[i]]
    for i in diff:
        for start in range(max(0, i - 3), i + 1):
            if start + 4 > len(data):
                continue
            a, b = (struct.unpack_from("<I", x, start)[0] for x in (data, out))
            if (a & 0x7F800000) == 0x7F800000 and a & 0x7FFFFF and b == a | 0x400000:
                break
        else:
            return False
    return bool(diff)


@pytest.mark.parametrize("corpus", sorted(CORPORA))
def test_pack_unpack_is_canonical_in_both_python_codecs(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                        corpus: str) -> None:
    args, cwd = CORPORA[corpus]
    mod, cat, _ = generate(tmp_path, capsys, corpus, args, cwd)
    rng = random.Random(f"canonical-{corpus}")
    accepted = refused = 0
    for cls in mod.TYPES:
        t = cat.type(cls.NAME)
        for k in range(ROUNDS):
            data = bytearray(rng.getrandbits(8) for _ in range(cls.PACKED_SIZE))
            if k % 2:  # half the rounds: make every bool 0/1 so most images are acceptable
                for off in getattr(cls, "_BOOL_AT", ()):
                    data[off] &= 1
            data = bytes(data)
            try:
                obj = cls.unpack(data)
            except ValueError:
                refused += 1
                with pytest.raises(DecodeError):
                    cat.decode(t, data)  # the catalogue-only codec refuses the same bytes
                continue
            accepted += 1
            value = cat.decode(t, data)
            packed = obj.pack()
            assert cat.encode(t, value) == packed, cls.NAME  # the two codecs agree (NaN != NaN as values)
            assert packed == data or quiet_f32_only(data, packed), f"{cls.NAME}: pack(unpack(bytes)) != bytes"
    assert accepted > ROUNDS and (corpus == "flightsw" or refused > 0)


def test_documented_exception_f32_signalling_nan_comes_back_quiet_in_python(tmp_path: Path,
                                                                            capsys: pytest.CaptureFixture[str]) -> None:
    mod, cat, _ = generate(tmp_path, capsys, "kinds", [str(ALL_KINDS)], REPO)
    snan = bytes.fromhex("0100807f")  # f32 signalling NaN, payload 1
    data = snan * 3
    assert mod.vec3.unpack(data).pack() == bytes.fromhex("0100c07f") * 3
    assert cat.encode("struct vec3", cat.decode("struct vec3", data)) == bytes.fromhex("0100c07f") * 3
    qnan = bytes.fromhex("0100c07f") * 3  # a quiet NaN's payload travels unchanged
    assert mod.vec3.unpack(qnan).pack() == qnan


def test_refused_values_name_the_member(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    mod, cat, _ = generate(tmp_path, capsys, "kinds", [str(ALL_KINDS)], REPO)
    good = mod.all_kinds().pack()
    off = mod.all_kinds._BOOL_AT[0]
    bad = good[:off] + b"\x02" + good[off + 1:]
    with pytest.raises(ValueError, match=f"bool byte 2 at offset {off}"):
        mod.all_kinds.unpack(bad)
    with pytest.raises(DecodeError, match="bool byte 2"):
        cat.decode("kinds", bad)
    # bf_u3: 3 bits in a u8 container; 8 does not fit.
    value = cat.decode("kinds", good)
    image = bytearray(good)
    image[96] = 8
    with pytest.raises(DecodeError, match=r"bf_u3: 8 does not fit the bitfield's range \[0, 7\]"):
        cat.decode("kinds", bytes(image))
    with pytest.raises(ValueError, match="bf_u3"):
        mod.all_kinds.unpack(bytes(image))
    with pytest.raises(ValueError, match="bf_s5"):
        mod.all_kinds(bf_s5=16).pack()  # pack refuses too: C could not hold it
    assert value["bf_u3"] == 0


C_EXCEPTIONS = r"""
#include <stdio.h>
#include <string.h>
#include "kinds.h"
/* Byte offsets in the packed all_kinds image (see kinds.catalogue.json): flag 62, ld 75, bf_u3 96. */
int main(void) {
    static struct all_kinds a, before;
    uint8_t in[kinds_all_kinds_PACKED_SIZE], out[kinds_all_kinds_PACKED_SIZE];
    memset(in, 0, sizeof in);
    /* f32 (f at 63) signalling NaN: C keeps every bit. */
    const uint8_t snan32[4] = {0x01, 0x00, 0x80, 0x7f};
    memcpy(in + 63, snan32, 4);
    if (kinds_unpack_all_kinds(&a, in, sizeof in) != (int)sizeof in) return 1;
    if (kinds_pack_all_kinds(&a, out, sizeof out) != (int)sizeof out) return 2;
    if (memcmp(in, out, sizeof in) != 0) return 3;
    /* long double (ld at 75) signalling NaN: comes back quiet on x87 (documented). */
    const uint8_t snan64[8] = {0x01, 0, 0, 0, 0, 0, 0xf0, 0x7f};
    memcpy(in + 75, snan64, 8);
    if (kinds_unpack_all_kinds(&a, in, sizeof in) != (int)sizeof in) return 4;
    if (kinds_pack_all_kinds(&a, out, sizeof out) != (int)sizeof out) return 5;
    int quieted = memcmp(in, out, sizeof in) != 0;
    if (quieted && (out[81] != 0xf8 || memcmp(in, out, 81) != 0)) return 6;
    /* Refusals leave the object alone. */
    memcpy(&before, &a, sizeof a);
    in[62] = 2;
    if (kinds_unpack_all_kinds(&a, in, sizeof in) != UB_ERR_RANGE || memcmp(&a, &before, sizeof a) != 0) return 7;
    in[62] = 1;
    in[96] = 8;
    if (kinds_unpack_all_kinds(&a, in, sizeof in) != UB_ERR_RANGE || memcmp(&a, &before, sizeof a) != 0) return 8;
    printf("ok %s\n", quieted ? "quieted" : "kept");
    return 0;
}
"""


@needs_gcc
def test_c_exceptions_and_refusals(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    _, cat, out = generate(tmp_path, capsys, "kinds", [str(ALL_KINDS)], REPO)
    offsets = {f.name: f.wire_offset for f in cat.type("struct all_kinds").fields if f.packed}
    assert (offsets["flag"], offsets["f"], offsets["ld"], offsets["bf_u3"]) == (62, 63, 75, 96)
    (tmp_path / "main.c").write_text(C_EXCEPTIONS)
    build = gcc(["-std=c11", "-Wall", "-Wextra", "-Werror", "-I", str(RUNTIME_INCLUDE), "-I", str(out),
                 "-I", str(ALL_KINDS.parent), str(out / "kinds.c"), "main.c", "-o", "t"], tmp_path)
    assert build.returncode == 0, build.stderr
    run = subprocess.run([str(tmp_path / "t")], capture_output=True, text=True, timeout=60, check=False)
    assert run.returncode == 0, f"exit {run.returncode}"
    assert run.stdout.strip() in ("ok quieted", "ok kept")
