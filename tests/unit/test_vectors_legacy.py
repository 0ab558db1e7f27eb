"""Legacy datalink envelope conformance vectors (docs/wire-format.md, "Legacy datalink envelope"): the committed
tests/vectors/legacy_envelope.json is exactly what the independent Python reference produces, and the C runtime,
through the cffi binding, rebuilds every message byte for byte and parses the mixed stream to its messages and
counters. (runtime_c/tests/test_legacy_vectors.c checks C alone.)"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from uavbus._ub import ffi, lib

VECTORS_DIR = Path(__file__).resolve().parents[1] / "vectors"
DOC = json.loads((VECTORS_DIR / "legacy_envelope.json").read_text(encoding="utf-8"))


def test_the_committed_vectors_are_the_reference_s_output() -> None:
    run = subprocess.run([sys.executable, str(VECTORS_DIR / "make_legacy_vectors.py"), "--check"])
    assert run.returncode == 0, "tests/vectors/legacy_envelope.json is stale: run make_legacy_vectors.py"


def test_c_rebuilds_every_message() -> None:
    assert len(DOC["vectors"]) >= 5
    for v in DOC["vectors"]:
        payload = bytes.fromhex(v["payload"])
        out = ffi.new("uint8_t[]", len(payload) + 8)
        n = lib.ub_legacy_build(v["type"], payload, len(payload), out, len(out))
        assert n == len(payload) + 8, v["name"]
        assert bytes(ffi.buffer(out, n)).hex() == v["message"], v["name"]


def test_c_parses_the_stream_to_its_messages_and_counters() -> None:
    got: list[bytes] = []

    @ffi.callback("ub_legacy_cb")
    def on_message(user, msg_type, msg, msg_len, payload, payload_len):  # type: ignore[no-untyped-def]
        got.append(bytes(ffi.buffer(msg, msg_len)))

    st = DOC["stream"]
    data = bytes.fromhex(st["bytes"])
    p = ffi.new("ub_legacy_t *")
    lib.ub_legacy_init(p)
    assert lib.ub_legacy_feed(p, data, len(data), on_message, ffi.NULL) == len(st["messages"])
    assert [m.hex() for m in got] == st["messages"]
    for key in ("bad_header", "bad_checksum", "too_long", "noise_bytes"):
        assert getattr(p.stats, key) == st[key], key
    assert p.stats.bytes_in == p.stats.message_bytes + p.stats.noise_bytes + lib.ub_legacy_pending(p)
