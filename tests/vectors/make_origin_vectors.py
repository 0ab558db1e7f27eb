#!/usr/bin/env python3
"""Independent pure-Python reference for ORIGIN frames; writes tests/vectors/origin_frames.json.

It shares no code with the C runtime: the construction is transcribed from docs/security.md ("Origin
authentication") and docs/wire-format.md ("Origin block"). X25519 is PyNaCl's crypto_scalarmult; the pairwise
master is BLAKE2b-256 from Python's hashlib; libsodium's KDF is rebuilt with hashlib.blake2b (as in
make_signed_vectors.py); SipHash-2-4 and XChaCha20-Poly1305 are PyNaCl's; the frame layout and CRC-32C come
from the frame reference (make_frame_vectors.py). The C runtime rebuilds every pair key and frame from the
same inputs, in C (runtime_c/tests/test_origin_vectors.c) and through the cffi binding
(tests/unit/test_vectors_origin.py), byte for byte.

The secret keys below are public test-vector keys, not keys of any deployment.

    python3 tests/vectors/make_origin_vectors.py            # rewrite origin_frames.json
    python3 tests/vectors/make_origin_vectors.py --check    # exit 1 if origin_frames.json is stale
"""

from __future__ import annotations

import hashlib
import json
import struct
import sys
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import make_frame_vectors as frame_ref  # noqa: E402  (the independent frame reference)

from nacl.bindings import (  # noqa: E402
    crypto_aead_xchacha20poly1305_ietf_encrypt,
    crypto_scalarmult,
    crypto_scalarmult_base,
    crypto_shorthash_siphash24,
)

OUTPUT = Path(__file__).with_name("origin_frames.json")

FLAG_SIGNED, FLAG_ENCRYPTED, FLAG_ORIGIN = 0x10, 0x20, 0x80
SIG_DOMAIN, ORIGIN_DOMAIN, AGREE_DOMAIN = b"uavbus-sig1", b"uavbus-org1", b"uavbus-origin-v1"
ORIGIN_CONTEXT = b"uborigin"
SIG_TAG_LEN, AEAD_TAG_LEN, ORIGIN_TAG_LEN = 8, 16, 8
ADMIN = {**frame_ref.ADMIN, "CHALLENGE": 7, "CHALLENGE_REPLY": 8}

# The group key of the hop tag: signed_frames.json's key 1.
GROUP_KEY_ID = 1
GROUP_KEY = bytes(range(32))

NAMES = ["gcs1", "rmax1ob1", "fcs20"]
SECRET = {n: hashlib.sha256(b"uavbus origin test-vector x25519 " + n.encode()).digest() for n in NAMES}


def kdf(key: bytes, length: int, subkey_id: int, context: bytes) -> bytes:
    """libsodium's crypto_kdf_derive_from_key (see make_signed_vectors.py)."""
    return hashlib.blake2b(b"", digest_size=length, key=key, salt=subkey_id.to_bytes(8, "little") + bytes(8),
                           person=context + bytes(8)).digest()


def public(name: str) -> bytes:
    return crypto_scalarmult_base(SECRET[name])


def pair(x: str, y: str) -> dict[str, bytes]:
    """Static-static agreement of entities x and y: A is the smaller 12-byte ID (bytewise)."""
    ix, iy = frame_ref.entity_id(x), frame_ref.entity_id(y)
    a, b = (x, y) if ix < iy else (y, x)
    q = crypto_scalarmult(SECRET[a], public(b))
    assert q == crypto_scalarmult(SECRET[b], public(a))
    master = hashlib.blake2b(AGREE_DOMAIN + q + frame_ref.entity_id(a) + public(a) + frame_ref.entity_id(b)
                             + public(b), digest_size=32).digest()
    return {"a": frame_ref.entity_id(a), "b": frame_ref.entity_id(b), "shared": q, "master": master,
            "key_ab": kdf(master, 16, 1, ORIGIN_CONTEXT), "key_ba": kdf(master, 16, 2, ORIGIN_CONTEXT)}


def direction_key(src: str, dest: str) -> bytes:
    p = pair(src, dest)
    return p["key_ab"] if frame_ref.entity_id(src) == p["a"] else p["key_ba"]


@dataclass(frozen=True)
class OriginInput:
    name: str
    note: str
    mode: str        # "signed" | "encrypted"
    counter: int
    dir_id: bytes
    src: str
    dest: str
    admin: int
    hop0: int        # the hop limit the origin sent (under the origin tag)
    hop_limit: int   # as on the wire now (under the hop tag)
    fingerprint: int
    payload: bytes


def signing_header(flags: int, v: OriginInput, key_id: int, domain: bytes) -> bytes:
    seq, counter_hi = v.counter & 0xFFFFFFFF, v.counter >> 32
    return (domain + bytes([frame_ref.WIRE_VERSION | flags]) + struct.pack("<H", frame_ref.MSG_TYPE_PUBSUB)
            + v.dir_id + frame_ref.entity_id(v.dest) + frame_ref.entity_id(v.src)
            + struct.pack("<BHIIBH", v.admin, len(v.payload), seq, v.fingerprint, key_id, counter_hi))


def origin_tag(v: OriginInput, key: bytes) -> bytes:
    """SipHash-2-4 under the source->destination key over the signing header with domain uavbus-org1, flags =
    ORIGIN alone and key id 0, then hop0, then the plaintext payload."""
    return crypto_shorthash_siphash24(signing_header(FLAG_ORIGIN, v, 0, ORIGIN_DOMAIN) + bytes([v.hop0]) + v.payload,
                                      key)


def build(v: OriginInput, otag: bytes, hop_limit: int | None = None, hop0: int | None = None) -> dict[str, object]:
    hop_limit = v.hop_limit if hop_limit is None else hop_limit
    hop0 = v.hop0 if hop0 is None else hop0
    prot = FLAG_SIGNED if v.mode == "signed" else FLAG_ENCRYPTED
    flags = prot | FLAG_ORIGIN
    block = bytes([hop0]) + otag
    hop_header = signing_header(flags, v, GROUP_KEY_ID, SIG_DOMAIN) + bytes([hop_limit]) + block
    if prot == FLAG_SIGNED:
        body = v.payload
        tag = crypto_shorthash_siphash24(hop_header + v.payload, kdf(GROUP_KEY, 16, 1, b"ubsig001"))
        extra: dict[str, object] = {}
    else:
        nonce = (frame_ref.entity_id(v.src) + v.counter.to_bytes(6, "little") + bytes([GROUP_KEY_ID, hop_limit])
                 + bytes(4))
        sealed = crypto_aead_xchacha20poly1305_ietf_encrypt(v.payload, hop_header, nonce,
                                                            kdf(GROUP_KEY, 32, 1, b"ubaead01"))
        body, tag = sealed[:-AEAD_TAG_LEN], sealed[-AEAD_TAG_LEN:]
        extra = {"nonce": nonce.hex()}
    trailer = bytes([GROUP_KEY_ID]) + struct.pack("<H", v.counter >> 32) + tag + block
    header = bytearray(frame_ref.HEADER_LEN)
    header[0:2] = frame_ref.SYNC
    header[3] = frame_ref.WIRE_VERSION | flags
    struct.pack_into("<HH", header, 4, frame_ref.MSG_TYPE_PUBSUB, frame_ref.HEADER_LEN + len(body) + len(trailer))
    header[8:24], header[24:36], header[36:48] = v.dir_id, frame_ref.entity_id(v.dest), frame_ref.entity_id(v.src)
    struct.pack_into("<BBHII", header, 48, v.admin, hop_limit, len(body), v.counter & 0xFFFFFFFF, v.fingerprint)
    header_crc = frame_ref.crc32c(bytes(header[frame_ref.CHECKED]))
    header[2] = frame_ref.fold8(header_crc)
    struct.pack_into("<I", header, 60, frame_ref.crc32c(body + trailer, header_crc))
    return {"hop_header": hop_header.hex(), "hop_tag": tag.hex(), **extra, "frame": (bytes(header) + body + trailer).hex()}


def inputs() -> list[OriginInput]:
    d, p = frame_ref.dir_id, frame_ref.pattern
    c0 = 0x00003A5B_C0DE0001
    return [
        OriginInput("origin_signed_data", "SIGNED|ORIGIN DATA gcs1 -> rmax1ob1, 24-byte payload, as sent", "signed",
                    c0, d("onboardSet"), "gcs1", "rmax1ob1", ADMIN["DATA"], 8, 8, 0x1A2B3C4D, p(24, 1)),
        OriginInput("origin_signed_after_3_hops", "the same frame after 3 forwarders: same origin tag, hop tag made "
                    "again over hop limit 5", "signed", c0, d("onboardSet"), "gcs1", "rmax1ob1", ADMIN["DATA"], 8, 5,
                    0x1A2B3C4D, p(24, 1)),
        OriginInput("origin_signed_imu", "SIGNED|ORIGIN DATA fcs20 -> gcs1, 59-byte payload", "signed", c0 + 2,
                    d("imuOutputs"), "fcs20", "gcs1", ADMIN["DATA"], 8, 7, 0x80000001, p(59, 3)),
        OriginInput("origin_encrypted_data", "ENCRYPTED|ORIGIN DATA rmax1ob1 -> fcs20 (hop limit in the nonce)",
                    "encrypted", c0 + 1, d("gpsOut"), "rmax1ob1", "fcs20", ADMIN["DATA"], 8, 6, 0x00C0FFEE,
                    p(48, 2)),
        OriginInput("origin_challenge", "CHALLENGE rmax1ob1 -> gcs1, origin-tagged: only rmax1ob1 asks",
                    "signed", c0 + 5, bytes(16), "rmax1ob1", "gcs1", ADMIN["CHALLENGE"], 8, 8, 0, p(16, 8)),
        OriginInput("origin_challenge_reply", "CHALLENGE_REPLY gcs1 -> rmax1ob1: only gcs1 can answer",
                    "signed", c0 + 77, bytes(16), "gcs1", "rmax1ob1", ADMIN["CHALLENGE_REPLY"], 8, 8, 0, p(16, 8)),
        OriginInput("origin_ack_empty", "SIGNED|ORIGIN ACK, empty payload, hop limit 255", "signed", (1 << 48) - 1,
                    d("gpsOut"), "fcs20", "rmax1ob1", ADMIN["ACK"], 255, 255, 0, b""),
        OriginInput("origin_max_payload", f"SIGNED|ORIGIN, largest payload ({frame_ref.MAX_PAYLOAD} bytes)",
                    "signed", c0 + 4, d("bigBlob"), "gcs1", "fcs20", ADMIN["DATA"], 8, 8, 0xFFFFFFFF,
                    p(frame_ref.MAX_PAYLOAD, 7)),
    ]


def vector_json(v: OriginInput) -> dict[str, object]:
    otag = origin_tag(v, direction_key(v.src, v.dest))
    return {"name": v.name, "note": v.note, "mode": v.mode, "key_id": GROUP_KEY_ID, "counter": v.counter,
            "dir_id": v.dir_id.hex(), "src": v.src, "dest": v.dest, "src_id": frame_ref.entity_id(v.src).hex(),
            "dest_id": frame_ref.entity_id(v.dest).hex(), "admin": v.admin, "hop0": v.hop0,
            "hop_limit": v.hop_limit, "fingerprint": v.fingerprint, "payload": v.payload.hex(),
            "origin_header": (signing_header(FLAG_ORIGIN, v, 0, ORIGIN_DOMAIN) + bytes([v.hop0])).hex(),
            "origin_tag": otag.hex(), **build(v, otag)}


def rejects() -> list[dict[str, object]]:
    """Frames the destination (the vector's `dest`) must refuse. All CRC-valid; the insider ones also carry a
    right hop tag (made with the group key), so only the origin check can catch them."""
    base = inputs()[0]
    good = build(base, origin_tag(base, direction_key(base.src, base.dest)))
    out: list[dict[str, object]] = []
    # an insider (fcs20) forges in gcs1's name: its best origin tag is under its own key with rmax1ob1
    forged = origin_tag(base, direction_key("fcs20", base.dest))
    out.append({"name": "insider_own_key", "expect": "bad_origin", "dest": base.dest,
                "note": "fcs20 forges gcs1 -> rmax1ob1 with its own pairwise key; right hop tag",
                "frame": build(base, forged)["frame"]})
    otag = origin_tag(base, direction_key(base.src, base.dest))
    flipped = bytes([otag[0] ^ 0x01]) + otag[1:]
    out.append({"name": "origin_tag_bit", "expect": "bad_origin", "dest": base.dest,
                "note": "one origin tag bit flipped; hop tag made again over it", "frame": build(base, flipped)["frame"]})
    out.append({"name": "hop_above_hop0", "expect": "bad_origin", "dest": base.dest,
                "note": "an insider raised the hop limit to 60 and made the hop tag again (hop0 stays 8)",
                "frame": build(base, otag, hop_limit=60)["frame"]})
    out.append({"name": "hop0_raised", "expect": "bad_origin", "dest": base.dest,
                "note": "hop limit and hop0 raised to 60, hop tag made again: the origin tag covers hop0",
                "frame": build(base, otag, hop_limit=60, hop0=60)["frame"]})
    f = bytearray(bytes.fromhex(str(good["frame"])))
    f[49] = 3   # the hop limit lowered by an outsider, checks made again: the hop tag covers it
    header_crc = frame_ref.crc32c(bytes(f[frame_ref.CHECKED]))
    f[2] = frame_ref.fold8(header_crc)
    struct.pack_into("<I", f, 60, frame_ref.crc32c(bytes(f[64:]), header_crc))
    out.append({"name": "hop_lowered_by_outsider", "expect": "bad_tag", "dest": base.dest,
                "note": "hop limit changed without the group key, CRC fixed", "frame": bytes(f).hex()})
    f = bytearray(bytes.fromhex(str(good["frame"])))
    f[3] = frame_ref.WIRE_VERSION | FLAG_ORIGIN   # ORIGIN without SIGNED or ENCRYPTED
    header_crc = frame_ref.crc32c(bytes(f[frame_ref.CHECKED]))
    f[2] = frame_ref.fold8(header_crc)
    struct.pack_into("<I", f, 60, frame_ref.crc32c(bytes(f[64:]), header_crc))
    out.append({"name": "origin_alone", "expect": "bad_version", "dest": base.dest,
                "note": "flag 0x80 without a hop protection", "frame": bytes(f).hex()})
    return out


def document() -> dict[str, object]:
    return {
        "description": "uavbus ORIGIN frame conformance vectors (docs/security.md, 'Origin authentication'); "
                       "regenerate with tests/vectors/make_origin_vectors.py. Public test keys only.",
        "group_key": {"id": GROUP_KEY_ID, "key": GROUP_KEY.hex()},
        "flags": {"signed": FLAG_SIGNED, "encrypted": FLAG_ENCRYPTED, "origin": FLAG_ORIGIN},
        "domains": {"origin": ORIGIN_DOMAIN.decode(), "agreement": AGREE_DOMAIN.decode(),
                    "kdf_context": ORIGIN_CONTEXT.decode()},
        "identities": [{"name": n, "id": frame_ref.entity_id(n).hex(), "x25519_sk": SECRET[n].hex(),
                        "x25519_pk": public(n).hex()} for n in NAMES],
        "pairs": [{"x": x, "y": y, **{k: v.hex() for k, v in pair(x, y).items()}}
                  for x, y in (("gcs1", "rmax1ob1"), ("rmax1ob1", "fcs20"), ("fcs20", "gcs1"))],
        "vectors": [vector_json(v) for v in inputs()],
        "rejects": rejects(),
    }


def render() -> str:
    return json.dumps(document(), indent=2) + "\n"


def main(argv: list[str]) -> int:
    return frame_ref.write_or_check(argv, render(), OUTPUT, __doc__.splitlines()[0], Path(__file__).name)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
