#!/usr/bin/env python3
"""Independent pure-Python reference for the uavbus frame; writes tests/vectors/frames.json.

It shares no code with the C runtime: the layout below is transcribed from
docs/wire-format.md and the CRC-32C is computed bit by bit. The C test builds
every frame from the same inputs and must match byte for byte.

    python3 tests/vectors/make_frame_vectors.py            # rewrite frames.json
    python3 tests/vectors/make_frame_vectors.py --check    # exit 1 if frames.json is stale
"""

from __future__ import annotations

import argparse
import json
import struct
import sys
from dataclasses import dataclass
from pathlib import Path

SYNC = b"\xA5\x5B"
WIRE_VERSION = 1
MSG_TYPE_PUBSUB = 0x5053
HEADER_LEN = 64
CHECKED = slice(4, 60)  # header bytes under both checks
MAX_PAYLOAD = 1024  # UB_MAX_PAYLOAD default (runtime_c/include/ub/ub_config.h)

ADMIN = {"DATA": 0, "PUB_REQUEST": 1, "SUB_REQUEST": 2, "PUB_STOP": 3, "SUB_STOP": 4, "ACK": 5, "NACK": 6}

OUTPUT = Path(__file__).with_name("frames.json")


def crc32c(data: bytes, crc: int = 0) -> int:
    """CRC-32C, reflected polynomial 0x82F63B78, continued from a previous result `crc`."""
    reg = crc ^ 0xFFFFFFFF
    for byte in data:
        reg ^= byte
        for _ in range(8):
            reg = (reg >> 1) ^ (0x82F63B78 if reg & 1 else 0)
    return reg ^ 0xFFFFFFFF


def fold8(crc: int) -> int:
    """Folds a 32-bit CRC to the 8-bit header check: XOR of its four bytes."""
    return (crc ^ (crc >> 8) ^ (crc >> 16) ^ (crc >> 24)) & 0xFF


def entity_id(name: str) -> bytes:
    """A 12-byte entity ID: the name, NUL-padded."""
    raw = name.encode("ascii")
    assert 0 < len(raw) <= 12, name
    return raw.ljust(12, b"\0")


def dir_id(name: str) -> bytes:
    """The paper's 16-byte content ID: first 8 and last 8 characters, NUL-padded when short."""
    raw = name.encode("ascii")
    if len(raw) <= 8:
        half = raw.ljust(8, b"\0")
        return half + half
    return raw[:8] + raw[-8:].rjust(8, b"\0")


def pattern(n: int, seed: int) -> bytes:
    """Deterministic payload bytes (a 32-bit LCG's top byte)."""
    out = bytearray()
    state = seed & 0xFFFFFFFF
    for _ in range(n):
        state = (state * 1664525 + 1013904223) & 0xFFFFFFFF
        out.append(state >> 24)
    return bytes(out)


@dataclass(frozen=True)
class FrameInput:
    name: str
    note: str
    dir_id: bytes
    dest_id: bytes
    src_id: bytes
    admin: int
    hop_limit: int
    seq: int
    fingerprint: int
    payload: bytes


def build_frame(v: FrameInput) -> tuple[bytes, int, int]:
    """Returns (frame, hdr_check, msg_crc) for one input."""
    assert len(v.dir_id) == 16 and len(v.dest_id) == 12 and len(v.src_id) == 12
    assert 1 <= v.hop_limit <= 255 and len(v.payload) <= MAX_PAYLOAD
    header = bytearray(HEADER_LEN)
    header[0:2] = SYNC
    header[3] = WIRE_VERSION
    struct.pack_into("<HH", header, 4, MSG_TYPE_PUBSUB, HEADER_LEN + len(v.payload))
    header[8:24] = v.dir_id
    header[24:36] = v.dest_id
    header[36:48] = v.src_id
    struct.pack_into("<BBHII", header, 48, v.admin, v.hop_limit, len(v.payload), v.seq, v.fingerprint)
    header_crc = crc32c(bytes(header[CHECKED]))
    hdr_check = fold8(header_crc)
    msg_crc = crc32c(v.payload, header_crc)
    header[2] = hdr_check
    struct.pack_into("<I", header, 60, msg_crc)
    return bytes(header) + v.payload, hdr_check, msg_crc


def inputs() -> list[FrameInput]:
    gcs, ob1, ob2, fcs = (entity_id(n) for n in ("gcs1", "rmax1ob1", "rmax1ob2", "fcs20"))
    sync_in_payload = SYNC + pattern(20, 7) + SYNC + SYNC
    return [
        FrameInput("data_88", "DATA, 24-byte payload (ATTITUDE-sized frame, 88 bytes)",
                   dir_id("onboardSet"), gcs, ob1, ADMIN["DATA"], 8, 1, 0x1A2B3C4D, pattern(24, 1)),
        FrameInput("data_112", "DATA, 48-byte payload (GPS_RAW_INT-sized frame, 112 bytes)",
                   dir_id("gpsOut"), gcs, ob1, ADMIN["DATA"], 8, 2, 0x00C0FFEE, pattern(48, 2)),
        FrameInput("data_123", "DATA, 59-byte payload (HIGHRES_IMU-sized frame, 123 bytes)",
                   dir_id("imuOutputs"), ob2, fcs, ADMIN["DATA"], 8, 3, 0x80000001, pattern(59, 3)),
        FrameInput("ack_empty", "ACK with empty payload",
                   dir_id("gpsOut"), ob1, gcs, ADMIN["ACK"], 8, 4, 0, b""),
        FrameInput("pub_request", "PUB_REQUEST, small request payload",
                   dir_id("navigationFilterState"), ob1, gcs, ADMIN["PUB_REQUEST"], 8, 5, 0, pattern(16, 5)),
        FrameInput("sub_request", "SUB_REQUEST",
                   dir_id("imuOutputs"), ob2, gcs, ADMIN["SUB_REQUEST"], 8, 6, 0, pattern(20, 6)),
        FrameInput("pub_stop", "PUB_STOP", dir_id("gpsOut"), ob1, gcs, ADMIN["PUB_STOP"], 8, 7, 0, pattern(8, 7)),
        FrameInput("sub_stop", "SUB_STOP", dir_id("imuOutputs"), ob2, gcs, ADMIN["SUB_STOP"], 8, 8, 0, pattern(8, 8)),
        FrameInput("nack", "NACK with a reason byte", dir_id("gpsOut"), gcs, ob1, ADMIN["NACK"], 8, 9, 0, b"\x05"),
        FrameInput("hop_limit_1", "hop limit 1: the last hop", dir_id("onboardSet"), fcs, gcs,
                   ADMIN["DATA"], 1, 10, 0x1A2B3C4D, pattern(24, 10)),
        FrameInput("hop_limit_255", "hop limit 255, sequence and fingerprint with every byte distinct",
                   dir_id("onboardSet"), fcs, gcs, ADMIN["DATA"], 255, 0xFEDCBA98, 0x01234567, pattern(24, 11)),
        FrameInput("sync_in_payload", "payload full of sync bytes: the decoder must not resync inside a good frame",
                   dir_id("onboardSet"), gcs, ob1, ADMIN["DATA"], 8, 0xA55BA55B, 0x5BA55BA5, sync_in_payload),
        FrameInput("max_payload", f"largest payload ({MAX_PAYLOAD} bytes)",
                   dir_id("bigBlob"), gcs, ob1, ADMIN["DATA"], 8, 0xFFFFFFFF, 0xFFFFFFFF, pattern(MAX_PAYLOAD, 13)),
    ]


def vector_json(v: FrameInput) -> dict[str, object]:
    frame, hdr_check, msg_crc = build_frame(v)
    return {
        "name": v.name,
        "note": v.note,
        "dir_id": v.dir_id.hex(),
        "dest_id": v.dest_id.hex(),
        "src_id": v.src_id.hex(),
        "admin": v.admin,
        "hop_limit": v.hop_limit,
        "seq": v.seq,
        "fingerprint": v.fingerprint,
        "payload": v.payload.hex(),
        "hdr_check": hdr_check,
        "msg_crc": msg_crc,
        "frame": frame.hex(),
    }


def document() -> dict[str, object]:
    return {
        "description": "uavbus frame conformance vectors (docs/wire-format.md); "
                       "regenerate with tests/vectors/make_frame_vectors.py",
        "wire_version": WIRE_VERSION,
        "msg_type": MSG_TYPE_PUBSUB,
        "header_len": HEADER_LEN,
        "crc32c_check": {"input": b"123456789".hex(), "crc32c": crc32c(b"123456789")},
        "vectors": [vector_json(v) for v in inputs()],
    }


def render() -> str:
    return json.dumps(document(), indent=2) + "\n"


def write_or_check(argv: list[str], text: str, output: Path, description: str, script: str) -> int:
    """The command line of the vector scripts: write `text` to `output`, or with --check compare."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--check", action="store_true", help="compare with the committed file instead of writing")
    args = parser.parse_args(argv)
    if args.check:
        if output.read_text(encoding="utf-8") != text:
            print(f"{output}:1: stale; regenerate with {script}", file=sys.stderr)
            return 1
        return 0
    output.write_text(text, encoding="utf-8")
    return 0


def main(argv: list[str]) -> int:
    return write_or_check(argv, render(), OUTPUT, __doc__.splitlines()[0], Path(__file__).name)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
