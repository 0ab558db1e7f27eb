#!/usr/bin/env python3
"""Independent pure-Python reference for compact frames and fragments; writes tests/vectors/compact_frames.json.

It shares no code with the C runtime: the compact layout, the COBS stuffing, the dictionary hashes
and the fragment layout below are transcribed from docs/wire-format.md ("Compact encoding",
"Fragments"); full frames are built here too (the layout of docs/wire-format.md, its own bitwise
CRC-32C). The C test (runtime_c/tests/test_compact_vectors.c) and the Python test through cffi
(tests/unit/test_vectors_compact.py) rebuild every full frame, its packet and its bytes on the wire
from the same inputs, decode the wire bytes back to the full frame, refuse every reject for its
reason, and split and reassemble the fragmented directory byte for byte.

The tags of the SIGNED and ENCRYPTED frames here are arbitrary bytes: the encoding carries the
trailer unchanged and never looks inside it (the signed vectors are tests/vectors/signed_frames.json).

    python3 tests/vectors/make_compact_vectors.py            # rewrite compact_frames.json
    python3 tests/vectors/make_compact_vectors.py --check    # exit 1 if compact_frames.json is stale
"""

from __future__ import annotations

import argparse
import json
import struct
import sys
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
# The CRC, IDs and payload bytes of the independent frame reference, so both generators agree by construction.
from make_frame_vectors import crc32c, dir_id, entity_id, pattern  # noqa: E402

OUTPUT = Path(__file__).with_name("compact_frames.json")
HEADER_LEN = 64
MAX_PAYLOAD = 1024
FLAG_SIGNED, FLAG_ENCRYPTED = 0x10, 0x20
TRAILER_LEN = {0: 0, FLAG_SIGNED: 11, FLAG_ENCRYPTED: 19}
ADMIN = {"DATA": 0, "PUB_REQUEST": 1, "ACK": 5, "LINK_HELLO": 20, "FRAGMENT": 21}
# ctl0 / ctl1 bits
EXT, ADMIN_BIT = 0x80, 0x40
DIR_FULL, DEST_FULL, SRC_FULL, SEQ32, ENT_WIDE = 0x01, 0x02, 0x04, 0x08, 0x10
FRAG_HEADER_LEN = 8


def fnv1a64(data: bytes, h: int = 0xCBF29CE484222325) -> int:
    for byte in data:
        h = ((h ^ byte) * 0x100000001B3) & 0xFFFFFFFFFFFFFFFF
    return h


# ---- the catalogue both ends share (instances in ID order = index order) -------------------------------

@dataclass(frozen=True)
class Instance:
    name: str
    fingerprint: int
    packed_size: int

    @property
    def id(self) -> bytes:
        return dir_id(self.name)


def catalogue() -> list[Instance]:
    named = [Instance("attitude", 0x41545431, 28), Instance("gpsRawInt", 0x47505331, 52),
             Instance("highresImu", 0x494D5531, 63), Instance("bigTable", 0x54424C31, 3000)]
    # Enough others that some indices need two varint bytes.
    filler = [Instance(f"zz{k:03d}", 0x5A000000 + k, 4 + k % 40) for k in range(140)]
    return sorted(named + filler, key=lambda inst: inst.id)


CAT = catalogue()


def catalogue_hash(cat: list[Instance]) -> int:
    h = 0xCBF29CE484222325
    for inst in cat:
        h = fnv1a64(inst.id + struct.pack("<II", inst.fingerprint, inst.packed_size), h)
    return h


def list_hash(ids: list[bytes]) -> int:
    h = fnv1a64(bytes([len(ids)]))
    for i in ids:
        h = fnv1a64(i, h)
    return h


LISTS = {
    "fleet": sorted(entity_id(n) for n in ("gcs1", "rmax1ob1", "rmax1ob2", "fcs20", "uav7")),
    "wide": sorted(entity_id(f"uav{k:02d}") for k in range(20)),
}


def cat_index(did: bytes) -> int:
    for k, inst in enumerate(CAT):
        if inst.id == did:
            return k
    return -1


# ---- full frames ------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Frame:
    dir_id: bytes
    dest_id: bytes
    src_id: bytes
    admin: int
    hop_limit: int
    seq: int
    fingerprint: int
    payload: bytes
    flags: int = 0
    trailer: bytes = b""


def full_frame(f: Frame) -> bytes:
    assert len(f.trailer) == TRAILER_LEN[f.flags]
    h = bytearray(HEADER_LEN)
    h[0:2] = b"\xA5\x5B"
    h[3] = 1 | f.flags
    struct.pack_into("<HH", h, 4, 0x5053, HEADER_LEN + len(f.payload) + len(f.trailer))
    h[8:24], h[24:36], h[36:48] = f.dir_id, f.dest_id, f.src_id
    struct.pack_into("<BBHII", h, 48, f.admin, f.hop_limit, len(f.payload), f.seq, f.fingerprint)
    header_crc = crc32c(bytes(h[4:60]))
    h[2] = (header_crc ^ header_crc >> 8 ^ header_crc >> 16 ^ header_crc >> 24) & 0xFF
    struct.pack_into("<I", h, 60, crc32c(f.payload + f.trailer, header_crc))
    return bytes(h) + f.payload + f.trailer


# ---- the compact encoding -----------------------------------------------------------------------------------

@dataclass(frozen=True)
class Dictionary:
    content_ok: bool
    entities: str | None  # a key of LISTS, or None: no entity indices


def encode(f: Frame, d: Dictionary, seq32: bool) -> bytes:
    ids = LISTS[d.entities] if d.entities else []
    # content
    if f.fingerprint == 0 and f.dir_id == bytes(16):
        v, inst = 0, None
    else:
        v, inst = -1, None
        k = cat_index(f.dir_id) if d.content_ok else -1
        if k >= 0 and CAT[k].fingerprint == f.fingerprint and (
                f.admin != 0 or CAT[k].packed_size == len(f.payload)):
            v, inst = k + 1, CAT[k]
    di = ids.index(f.dest_id) if f.dest_id in ids else -1
    si = ids.index(f.src_id) if f.src_id in ids else -1
    ctl1 = (DIR_FULL if v < 0 else 0) | (DEST_FULL if di < 0 else 0) | (SRC_FULL if si < 0 else 0)
    ctl1 |= SEQ32 if seq32 else 0
    if di >= 0 and si >= 0 and (di > 15 or si > 15):
        ctl1 |= ENT_WIDE
    prot = {0: 0, FLAG_SIGNED: 1, FLAG_ENCRYPTED: 2}[f.flags]
    ctl0 = (f.hop_limit if f.hop_limit <= 15 else 0) | prot << 4 | (ADMIN_BIT if f.admin else 0) | (EXT if ctl1 else 0)
    out = bytearray([ctl0])
    if ctl1:
        out.append(ctl1)
    if f.hop_limit > 15:
        out.append(f.hop_limit)
    if f.admin:
        out.append(f.admin)
    out += struct.pack("<I", f.seq) if seq32 else struct.pack("<H", f.seq & 0xFFFF)
    if v < 0:
        out += f.dir_id + struct.pack("<I", f.fingerprint)
    elif v > 0x7F:
        out += bytes([0x80 | (v & 0x7F), v >> 7])
    else:
        out.append(v)
    if di >= 0 and si >= 0 and not ctl1 & ENT_WIDE:
        out.append(di | si << 4)
    else:
        out += f.dest_id if di < 0 else bytes([di])
        out += f.src_id if si < 0 else bytes([si])
    payload = f.payload
    if f.admin == 0 and inst is not None:
        payload = payload.rstrip(b"\0")  # the type's packed size restores them
    out += payload + f.trailer
    prefix = struct.pack("<QQ", catalogue_hash(CAT) if v > 0 else 0,
                         list_hash(ids) if (di >= 0 or si >= 0) else 0)
    out += struct.pack("<I", crc32c(bytes(out), crc32c(prefix)))
    return bytes(out)


def cobs(data: bytes) -> bytes:
    """COBS (Cheshire & Baker), then the 0x00 delimiter."""
    out, block = bytearray(), bytearray()
    for byte in data:
        if byte == 0:
            out += bytes([len(block) + 1]) + block
            block = bytearray()
            continue
        block.append(byte)
        if len(block) == 254:
            out += b"\xFF" + block
            block = bytearray()
    out += bytes([len(block) + 1]) + block
    return bytes(out) + b"\0"


# ---- fragments -----------------------------------------------------------------------------------------------

def plan(total: int, max_bytes: int) -> int:
    n = -(-total // max_bytes)
    chunk = -(-total // n)
    return -(-total // chunk)


def fragment_payloads(transfer: int, data: bytes, max_bytes: int) -> list[bytes]:
    count = plan(len(data), max_bytes)
    chunk = -(-len(data) // count)
    out = []
    for i in range(count):
        part = data[i * chunk:(i + 1) * chunk]
        assert part
        out.append(struct.pack("<HHHH", transfer, i, count, len(data)) + part)
    return out


# ---- the vectors -------------------------------------------------------------------------------------------

GCS, OB1, OB2, FCS = (entity_id(n) for n in ("gcs1", "rmax1ob1", "rmax1ob2", "fcs20"))
STRANGER = entity_id("visitor9")
LINK_LOCAL = b"\xFF" * 12
AGREED = Dictionary(True, "fleet")
NOTHING = Dictionary(False, None)


@dataclass(frozen=True)
class Case:
    name: str
    note: str
    frame: Frame
    dictionary: Dictionary
    seq32: bool
    ref_seq: int | None = None  # the receiver's reference for the source (seq16 packets)


def data_frame(name: str, seq: int, payload: bytes | None = None, **kw: object) -> Frame:
    inst = next(i for i in CAT if i.name == name)
    body = payload if payload is not None else pattern(inst.packed_size, seq).replace(b"\0", b"\1")
    assert len(body) == inst.packed_size
    args: dict[str, object] = dict(dir_id=inst.id, dest_id=GCS, src_id=OB1, admin=0, hop_limit=8, seq=seq,
                                   fingerprint=inst.fingerprint, payload=body)
    args.update(kw)
    return Frame(**args)  # type: ignore[arg-type]


def cases() -> list[Case]:
    att = next(i for i in CAT if i.name == "attitude")
    zz = next(i for i in CAT if i.name == "zz139")
    wide = LISTS["wide"]
    sig = bytes([1]) + struct.pack("<H", 0x0102) + pattern(8, 99)
    aead = bytes([2]) + struct.pack("<H", 0x0304) + pattern(16, 98)
    trailing = pattern(20, 5).replace(b"\0", b"\7") + bytes(8)
    return [
        Case("attitude", "DATA, content and both entities indexed, 16-bit sequence: 39 bytes on the wire (MAVLink 2: 40)",
             data_frame("attitude", 0x00012345), AGREED, False, ref_seq=0x00011FF0),
        Case("attitude_seq32", "the same with all 32 sequence bits (first frames of a source)",
             data_frame("attitude", 0x00012345), AGREED, True),
        Case("gps", "GPS_RAW_INT-sized DATA", data_frame("gpsRawInt", 7, dest_id=OB1, src_id=GCS), AGREED, False,
             ref_seq=0xFFFFFFF0),
        Case("highres", "HIGHRES_IMU-sized DATA; the sequence crosses 2^32 from its reference",
             data_frame("highresImu", 0x00000003, dest_id=FCS, src_id=OB2), AGREED, False, ref_seq=0xFFFFFFFE),
        Case("truncated", "DATA whose last 8 payload bytes are zero: cut on the wire, restored from the type's size",
             data_frame("attitude", 11, payload=trailing), AGREED, True),
        Case("all_zero", "DATA of zeros only: no payload byte on the wire",
             data_frame("attitude", 12, payload=bytes(att.packed_size)), AGREED, True),
        Case("signed", "SIGNED DATA: the 11-byte trailer carried unchanged",
             data_frame("gpsRawInt", 0x89ABCDEF, flags=FLAG_SIGNED, trailer=sig), AGREED, False, ref_seq=0x89ABC000),
        Case("encrypted", "ENCRYPTED DATA: 19-byte trailer, ciphertext payload (its trailing zeros cut all the same)",
             data_frame("highresImu", 77, payload=pattern(63, 3)[:60] + bytes(3), flags=FLAG_ENCRYPTED, trailer=aead),
             AGREED, True),
        Case("no_dictionary", "nothing agreed yet: dir_id, fingerprint and both IDs in full",
             data_frame("attitude", 13), NOTHING, True),
        Case("catalogue_only", "catalogue agreed, entity list not yet", data_frame("gpsRawInt", 14),
             Dictionary(True, None), True),
        Case("stranger", "source not in the list: it goes in full, the destination as a 1-byte index",
             data_frame("attitude", 15, src_id=STRANGER), AGREED, True),
        Case("wide", "entity indices above 15: one byte each",
             data_frame("attitude", 16, dest_id=wide[17], src_id=wide[3]), Dictionary(True, "wide"), True),
        Case("varint2", "content index above 127: two varint bytes",
             Frame(zz.id, GCS, OB1, 0, 8, 17, zz.fingerprint, pattern(zz.packed_size, 17).replace(b"\0", b"\2")),
             AGREED, True),
        Case("hop_200", "hop limit above 15: a byte of its own", data_frame("attitude", 18, hop_limit=200), AGREED, True),
        Case("pub_request", "an admin frame about indexed content: admin byte, no payload cut",
             Frame(att.id, OB1, GCS, ADMIN["PUB_REQUEST"], 8, 19, att.fingerprint, pattern(23, 19) + b"\0"), AGREED, True),
        Case("link_hello", "a link-local LINK_HELLO: zero content (1 byte), link-local destination in full",
             Frame(bytes(16), LINK_LOCAL, OB1, ADMIN["LINK_HELLO"], 1, 20, 0, pattern(40, 20)), NOTHING, True),
        Case("stuffing", "a payload with zeros inside and longer than one COBS block (254 bytes)",
             Frame(dir_id("notInCatalog"), GCS, OB1, 0, 8, 21, 0xDEADBEEF,
                   bytes(3) + pattern(300, 21) + b"\0\0\1\0"), AGREED, True),
        Case("max_payload", f"the largest payload ({MAX_PAYLOAD} bytes), nothing agreed",
             Frame(dir_id("bigBlob"), GCS, OB1, 0, 8, 22, 0xFFFFFFFF, pattern(MAX_PAYLOAD, 22)), NOTHING, True),
    ]


def restore(last: int, low: int) -> int:
    """The receiver's 32-bit sequence from the low 16 bits: the value closest to `last`."""
    diff = (low - last) & 0xFFFF
    return (last + (diff - 0x10000 if diff >= 0x8000 else diff)) & 0xFFFFFFFF


def case_json(c: Case) -> dict[str, object]:
    f = c.frame
    assert c.seq32 or (c.ref_seq is not None and restore(c.ref_seq, f.seq & 0xFFFF) == f.seq), c.name
    pkt = encode(f, c.dictionary, c.seq32)
    return {
        "name": c.name, "note": c.note,
        "content_ok": c.dictionary.content_ok, "entities": c.dictionary.entities or "",
        "seq32": c.seq32, "ref_seq": c.ref_seq if c.ref_seq is not None else -1,
        "flags": f.flags, "dir_id": f.dir_id.hex(), "dest_id": f.dest_id.hex(), "src_id": f.src_id.hex(),
        "admin": f.admin, "hop_limit": f.hop_limit, "seq": f.seq, "fingerprint": f.fingerprint,
        "payload": f.payload.hex(), "trailer": f.trailer.hex(),
        "frame": full_frame(f).hex(), "packet": pkt.hex(), "wire": cobs(pkt).hex(),
    }


def rejects() -> list[dict[str, object]]:
    """Wire bytes a decoder holding the AGREED dictionary (and references for every source at seq 0x12340000)
    must refuse, each for its reason."""
    good = encode(data_frame("attitude", 0x12345678), AGREED, False)
    flipped = bytearray(good)
    flipped[len(flipped) // 2] ^= 0x10
    reserved = bytearray(encode(data_frame("attitude", 0x12345678), AGREED, True))
    reserved[1] |= 0x80
    reserved[-4:] = struct.pack("<I", crc32c(bytes(reserved[:-4]), crc32c(struct.pack(
        "<QQ", catalogue_hash(CAT), list_hash(LISTS["fleet"])))))
    wide = LISTS["wide"]
    other_list = encode(data_frame("attitude", 0x12345678, dest_id=wide[1], src_id=wide[2]), Dictionary(True, "wide"),
                        True)  # indices into another list than the receiver holds
    stranger = encode(data_frame("attitude", 0x12345678, src_id=STRANGER), AGREED, False)  # no reference for it
    return [
        {"name": "bad_crc", "expect": "bad_crc", "wire": cobs(bytes(flipped)).hex()},
        {"name": "reserved_bit", "expect": "bad_version", "wire": cobs(bytes(reserved)).hex()},
        {"name": "truncated", "expect": "bad_length", "wire": cobs(good[:6]).hex()},
        {"name": "other_dictionary", "expect": "bad_crc", "wire": cobs(other_list).hex()},
        {"name": "no_reference", "expect": "no_reference", "wire": cobs(stranger).hex()},
        {"name": "broken_stuffing", "expect": "bad_crc", "wire": (bytes([0x05, 1, 2]) + b"\0").hex()},
    ]


def fragments() -> dict[str, object]:
    big = next(i for i in CAT if i.name == "bigTable")
    data = pattern(big.packed_size, 31)
    max_bytes = 230 - FRAG_HEADER_LEN  # e.g. a 255-byte radio packet less a compact header and trailer
    transfer, seq0 = 0xBEEF, 1000
    out = []
    for k, payload in enumerate(fragment_payloads(transfer, data, max_bytes)):
        f = Frame(big.id, GCS, OB1, ADMIN["FRAGMENT"], 8, seq0 + k, big.fingerprint, payload)
        pkt = encode(f, AGREED, True)
        out.append({"frame": full_frame(f).hex(), "wire": cobs(pkt).hex()})
    return {"instance": big.name, "transfer": transfer, "first_seq": seq0, "max_bytes": max_bytes,
            "data": data.hex(), "count": len(out), "fragments": out}


def document() -> dict[str, object]:
    return {
        "description": "uavbus compact frames and fragments (docs/wire-format.md); "
                       "regenerate with tests/vectors/make_compact_vectors.py",
        "catalogue": [{"name": i.name, "id": i.id.hex(), "fingerprint": i.fingerprint, "packed_size": i.packed_size}
                      for i in CAT],
        "catalogue_hash": f"{catalogue_hash(CAT):016x}",
        "lists": {k: {"ids": [i.hex() for i in v], "hash": f"{list_hash(v):016x}"} for k, v in LISTS.items()},
        "cobs": [{"in": x.hex(), "out": cobs(x).hex()} for x in
                 (b"", b"\0", b"\0\0", b"\x11\x22\0\x33", b"\x11\x22\x33\x44", bytes(range(1, 255)),
                  bytes(range(1, 256)) + b"\1")],
        "vectors": [case_json(c) for c in cases()],
        "rejects": rejects(),
        "reject_ref_seq": 0x12340000,
        "fragments": fragments(),
    }


def render() -> str:
    return json.dumps(document(), indent=1) + "\n"


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="compare with the committed file instead of writing")
    args = parser.parse_args(argv)
    text = render()
    if args.check:
        if OUTPUT.read_text(encoding="utf-8") != text:
            print(f"{OUTPUT}:1: stale; regenerate with {Path(__file__).name}", file=sys.stderr)
            return 1
        return 0
    OUTPUT.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
