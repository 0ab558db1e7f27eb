#!/usr/bin/env python3
"""Independent pure-Python reference for the remote-inspection payloads; writes tests/vectors/inspect.json.

It shares no code with the runtime: the layouts are transcribed from docs/inspect.md (INSPECT = admin code
12, INSPECT_VALUE = 13, LIST records). The C encoders (ub_inspect_put_*, runtime_c/tests/test_inspect_vectors.c)
must produce every `bytes` from the same fields; Python's record decoder (uavbus._bindings.ub_inspect,
tests/unit/test_vectors_inspect.py) must read the fields back.

    python3 tests/vectors/make_inspect_vectors.py            # rewrite inspect.json
    python3 tests/vectors/make_inspect_vectors.py --check    # exit 1 if inspect.json is stale
"""

from __future__ import annotations

import argparse
import json
import struct
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from make_frame_vectors import dir_id, entity_id  # noqa: E402  (the IDs of the independent frame reference)

OUTPUT = Path(__file__).with_name("inspect.json")
OPS = {"read": 1, "write": 2, "list": 3, "set_period": 4, "set_mask": 5, "admin_row": 6}
TABLES = {"entities": 1, "links": 2, "pubsub": 3, "admin": 4}

# The integer fields and byte fields of each kind, in the order the C table takes them (n[], blob[]).
KINDS: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    "request": (("id", "op", "arg", "offset", "value"), ("extra",)),
    "value": (("id", "op", "arg", "offset", "total", "next"), ("data",)),
    "entity": (("local", "mask", "pinned"), ("entity_id",)),
    "link": (("index", "attached", "frames_in", "frames_out", "bytes_in", "bytes_out", "drops", "accepted"),
             ("name",)),
    "pubsub": (("row", "kind", "state", "period_ms", "frames"), ("dir_id", "peer", "owner")),
    "admin": (("row", "type", "status", "period_ms", "active", "nack_reason"), ("dir_id", "source", "destination")),
}


def encode(kind: str, f: dict[str, Any]) -> bytes:
    """The payload bytes of one vector, from docs/inspect.md's tables."""
    if kind == "request":   # id u32, op u8, arg u8, offset u16, value u32, then WRITE data / SET_MASK subject
        return struct.pack("<IBBHI", f["id"], f["op"], f["arg"], f["offset"], f["value"]) + f["extra"]
    if kind == "value":     # id u32, op, arg, offset u16, total u16, next u16, then data
        return struct.pack("<IBBHHH", f["id"], f["op"], f["arg"], f["offset"], f["total"], f["next"]) + f["data"]
    if kind == "entity":    # id[12], local, mask, pinned, 0
        return f["entity_id"] + bytes([f["local"], f["mask"], f["pinned"], 0])
    if kind == "link":      # name[32], index, attached, 0, 0, six u32
        return f["name"].ljust(32, b"\0") + bytes([f["index"], f["attached"], 0, 0]) + struct.pack(
            "<6I", f["frames_in"], f["frames_out"], f["bytes_in"], f["bytes_out"], f["drops"], f["accepted"])
    if kind == "pubsub":    # row u16, kind, state, dir[16], peer[12], owner[12], period u32, frames u32
        return struct.pack("<HBB", f["row"], f["kind"], f["state"]) + f["dir_id"] + f["peer"] + f["owner"] + \
            struct.pack("<II", f["period_ms"], f["frames"])
    if kind == "admin":     # row u16, type, status, dir[16], source[12], destination[12], period u32, active, nack, 0, 0
        return struct.pack("<HBB", f["row"], f["type"], f["status"]) + f["dir_id"] + f["source"] + \
            f["destination"] + struct.pack("<IBBBB", f["period_ms"], f["active"], f["nack_reason"], 0, 0)
    raise ValueError(kind)


def vectors() -> list[tuple[str, str, str, dict[str, Any]]]:
    """(name, kind, note, fields); every field of the kind is given."""
    gcs, ob1, ob2, fcs = (entity_id(n) for n in ("gcs1", "rmax1ob1", "rmax1ob2", "fcs20"))
    req = {"arg": 0, "offset": 0, "value": 0, "extra": b""}
    return [
        ("req_read", "request", "READ airData from byte 0", {**req, "id": 0x1A2B3C4D, "op": OPS["read"]}),
        ("req_read_chunk", "request", "READ, the next chunk from byte 1012",
         {**req, "id": 0xFFFFFFFE, "op": OPS["read"], "offset": 1012}),
        ("req_write_field", "request", "WRITE one 4-byte field at byte 8 (fcsSet.mode = 3)",
         {**req, "id": 0x00000001, "op": OPS["write"], "offset": 8, "extra": struct.pack("<i", 3)}),
        ("req_list_pubsub", "request", "LIST pubsub from row 2",
         {**req, "id": 0x80000000, "op": OPS["list"], "arg": TABLES["pubsub"], "offset": 2}),
        ("req_set_period", "request", "SET_PERIOD of pubsub row 5 to 20 ms",
         {**req, "id": 0x0BADF00D, "op": OPS["set_period"], "offset": 5, "value": 20}),
        ("req_set_mask", "request", "SET_MASK toward rmax1ob2 to 0x00000011",
         {**req, "id": 0x12345678, "op": OPS["set_mask"], "value": 0x11, "extra": ob2}),
        ("req_admin_row", "request", "ADMIN_ROW 3: active = 0",
         {**req, "id": 0xCAFEBABE, "op": OPS["admin_row"], "arg": 2, "offset": 3, "value": 0}),
        ("val_read", "value", "a READ answer: 12 bytes of a 12-byte image, last chunk",
         {"id": 0x1A2B3C4D, "op": OPS["read"], "arg": 0, "offset": 0, "total": 12, "next": 0xFFFF,
          "data": bytes(range(0xA0, 0xAC))}),
        ("val_list_more", "value", "a LIST answer of 1 entity record of 4, more from row 1",
         {"id": 0x80000000, "op": OPS["list"], "arg": TABLES["entities"], "offset": 0, "total": 4, "next": 1,
          "data": fcs + bytes([1, 0x03, 0, 0])}),
        ("rec_entity", "entity", "fcs20 seen from rmax1ob1: mask 0x00000100, pinned",
         {"entity_id": fcs, "local": 0, "mask": 0x04, "pinned": 1}),
        ("rec_link", "link", "a link with saturated bytes_in",
         {"name": b"onboardPortDatalink1", "index": 1, "attached": 1, "frames_in": 1234, "frames_out": 567,
          "bytes_in": 0xFFFFFFFF, "bytes_out": 89012, "drops": 3, "accepted": 1200}),
        ("rec_pubsub", "pubsub", "publication of imuOut to gcs1, created by gcs1's admin row",
         {"row": 7, "kind": 1, "state": 1, "dir_id": dir_id("imuOut"), "peer": gcs, "owner": gcs,
          "period_ms": 20, "frames": 4321}),
        ("rec_pubsub_local", "pubsub", "subscription to gpsOutBackup from fcs20, local API (owner 0)",
         {"row": 0, "kind": 2, "state": 3, "dir_id": dir_id("gpsOutBackup"), "peer": fcs, "owner": bytes(12),
          "period_ms": 100, "frames": 0}),
        ("rec_admin", "admin", "subscription row gpsOut rmax1ob1 -> gcs1, NACKed not_authorized",
         {"row": 2, "type": 1, "status": 4, "dir_id": dir_id("gpsOut"), "source": ob1, "destination": gcs,
          "period_ms": 100, "active": 1, "nack_reason": 6}),
    ]


def render() -> str:
    out = []
    for name, kind, note, fields in vectors():
        ints, blobs = KINDS[kind]
        assert set(fields) == set(ints) | set(blobs) and "layout" not in fields, name
        row: dict[str, Any] = {"name": name, "layout": kind, "note": note}
        row.update({k: fields[k] for k in ints})
        row.update({k: fields[k].hex() for k in blobs})
        row["bytes"] = encode(kind, fields).hex()
        out.append(row)
    doc = {"description": "uavbus remote-inspection payloads (docs/inspect.md); regenerate with "
                          "tests/vectors/make_inspect_vectors.py",
           "admin_codes": {"INSPECT": 12, "INSPECT_VALUE": 13},
           "layouts": {k: {"ints": list(v[0]), "bytes": list(v[1])} for k, v in KINDS.items()},
           "vectors": out}
    return json.dumps(doc, indent=2) + "\n"


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--check", action="store_true", help="exit 1 if inspect.json differs from what this writes")
    args = p.parse_args()
    text = render()
    if args.check:
        if OUTPUT.read_text(encoding="utf-8") != text:
            print(f"{OUTPUT}:1: stale; run python3 {Path(__file__).name}", file=sys.stderr)
            return 1
        return 0
    OUTPUT.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
