#!/usr/bin/env python3
"""Independent pure-Python reference for the legacy datalink envelope; writes tests/vectors/legacy_envelope.json.

It shares no code with the C runtime: the layout is transcribed from docs/wire-format.md ("Legacy datalink
envelope"): sync EB 90, header checksum (8-bit sum of type and size), message checksum (8-bit sum of type,
size and payload), type u16 LE, size u16 LE, payload. The C test (runtime_c/tests/test_legacy_vectors.c) and
the Python test through cffi (tests/unit/test_vectors_legacy.py) rebuild every message byte for byte and
parse the mixed stream to exactly the messages and counters given here.

    python3 tests/vectors/make_legacy_vectors.py            # rewrite legacy_envelope.json
    python3 tests/vectors/make_legacy_vectors.py --check    # exit 1 if legacy_envelope.json is stale
"""

from __future__ import annotations

import argparse
import json
import struct
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from make_frame_vectors import pattern  # noqa: E402  (the deterministic payload bytes of the frame reference)

OUT = Path(__file__).resolve().parent / "legacy_envelope.json"
UAVBUS_TYPE = 200  # the default type uavbus frames travel as (ub_legacy_link.h)
MAX_PAYLOAD = 64 + 1024 + 19  # UB_LEGACY_PAYLOAD_MAX = UB_FRAME_MAX: header, largest payload, largest trailer


def message(msg_type: int, payload: bytes) -> bytes:
    head = struct.pack("<HH", msg_type, len(payload))
    hck = sum(head) & 0xFF
    mck = (hck + sum(payload)) & 0xFF
    return bytes([0xEB, 0x90, hck, mck]) + head + payload


def parse(stream: bytes) -> tuple[list[bytes], dict[str, int]]:
    """The documented search: at each sync pair, judge the header checksum, the size, then the message checksum;
    a good message is taken whole, anything else moves the search one byte on (that byte is noise)."""
    good, counts, i = [], {"bad_header": 0, "bad_checksum": 0, "too_long": 0, "noise_bytes": 0}, 0
    while i < len(stream):
        if stream[i:i + 2] != b"\xeb\x90":
            if stream[i] != 0xEB or i + 1 < len(stream):
                counts["noise_bytes"] += 1
                i += 1
                continue
            break  # a lone EB at the end: held, waiting for more
        if len(stream) - i < 8:
            break
        msg_type, size = struct.unpack_from("<HH", stream, i + 4)
        if sum(stream[i + 4:i + 8]) & 0xFF != stream[i + 2]:
            counts["bad_header"] += 1
        elif size > MAX_PAYLOAD:
            counts["too_long"] += 1
        elif len(stream) - i < 8 + size:
            break
        elif (stream[i + 2] + sum(stream[i + 8:i + 8 + size])) & 0xFF != stream[i + 3]:
            counts["bad_checksum"] += 1
        else:
            good.append(stream[i:i + 8 + size])
            i += 8 + size
            continue
        counts["noise_bytes"] += 1
        i += 1
    return good, counts


def frames_json() -> bytes:
    """A uavbus frame as payload: the first vector of frames.json (any frame will do: the envelope carries it)."""
    frames = json.loads((OUT.parent / "frames.json").read_text(encoding="utf-8"))
    return bytes.fromhex(frames["vectors"][0]["frame"])


def build() -> dict:
    vectors = [
        {"name": "empty legacy message, type 1", "type": 1, "payload": b""},
        {"name": "legacy telemetry, type 2", "type": 2, "payload": pattern(24, 2)},
        {"name": "a type unknown to uavbus, 7, whose payload holds the sync pair", "type": 7,
         "payload": bytes([0xEB, 0x90, 0x00, 0xFF]) + pattern(9, 7)},
        {"name": "sums that wrap (type 0xFFFF, 255-byte payload)", "type": 0xFFFF, "payload": bytes([0xFF]) * 255},
        {"name": "a uavbus frame inside the uavbus type", "type": UAVBUS_TYPE, "payload": frames_json()},
    ]
    for v in vectors:
        v["message"] = message(v["type"], v["payload"])
    # A stream: noise, the messages, a message with a bad header checksum, one with a bad message checksum, a
    # false sync, the last message again. What the parser must report: the good messages in order, and counters.
    bad_header = bytearray(vectors[1]["message"])
    bad_header[2] ^= 0x01
    bad_sum = bytearray(vectors[1]["message"])
    bad_sum[-1] ^= 0x10
    noise = b"\x00\x13noise\xeb\x00\xeb"
    stream = noise + b"".join(v["message"] for v in vectors) + bytes(bad_header) + bytes(bad_sum) + b"\xeb\x90" \
        + vectors[0]["message"]
    good, counts = parse(stream)
    assert good == [v["message"] for v in vectors] + [vectors[0]["message"]], "the stream lost a good message"
    assert len(stream) == sum(map(len, good)) + counts["noise_bytes"]
    return {
        "description": "the legacy datalink envelope (docs/wire-format.md, 'Legacy datalink envelope'); regenerate "
                       "with tests/vectors/make_legacy_vectors.py",
        "vectors": [{"name": v["name"], "type": v["type"], "payload": v["payload"].hex(),
                     "message": v["message"].hex()} for v in vectors],
        "stream": {"bytes": stream.hex(), "messages": [m.hex() for m in good], **counts},
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="exit 1 if the committed file differs")
    args = ap.parse_args()
    text = json.dumps(build(), indent=1) + "\n"
    if args.check:
        return 0 if OUT.read_text(encoding="utf-8") == text else 1
    OUT.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
