#!/usr/bin/env python3
"""Independent pure-Python reference for SIGNED and ENCRYPTED frames; writes tests/vectors/signed_frames.json.

It shares no code with the C runtime: the construction is transcribed from docs/security.md and
docs/wire-format.md ("Flags and trailer"). The two subkeys come from libsodium's KDF
(crypto_kdf_derive_from_key) rebuilt with Python's hashlib.blake2b (key = the key file's key, salt =
the subkey id, person = the context); the tag is SipHash-2-4 from PyNaCl, the AEAD XChaCha20-Poly1305
(IETF) from PyNaCl; the frame layout and CRC-32C come from the frame reference (make_frame_vectors.py,
itself independent of C). The C runtime rebuilds every frame from the same
inputs, in C (runtime_c/tests/test_sec_vectors.c) and through the cffi binding (tests/unit), and
must match byte for byte.

The keys below are public test-vector keys, not keys of any deployment.

    python3 tests/vectors/make_signed_vectors.py            # rewrite signed_frames.json
    python3 tests/vectors/make_signed_vectors.py --check    # exit 1 if signed_frames.json is stale
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

from nacl.bindings import crypto_aead_xchacha20poly1305_ietf_encrypt, crypto_shorthash_siphash24  # noqa: E402

OUTPUT = Path(__file__).with_name("signed_frames.json")

FLAG_SIGNED = 0x10
FLAG_ENCRYPTED = 0x20
DOMAIN = b"uavbus-sig1"
SIG_TAG_LEN = 8
AEAD_TAG_LEN = 16
TRAILER_LEN = {FLAG_SIGNED: 3 + SIG_TAG_LEN, FLAG_ENCRYPTED: 3 + AEAD_TAG_LEN}
ADMIN = {**frame_ref.ADMIN, "CHALLENGE": 7, "CHALLENGE_REPLY": 8}
SIG_CONTEXT, AEAD_CONTEXT, SUBKEY_ID = b"ubsig001", b"ubaead01", 1
SIG_KEY_LEN, AEAD_KEY_LEN = 16, 32

KEYS = {
    1: bytes(range(32)),                                    # 00 01 02 ... 1f
    7: hashlib.sha256(b"uavbus test-vector key 7").digest(),
    200: bytes([0xFF] * 32),
}


def kdf(key: bytes, length: int, subkey_id: int, context: bytes) -> bytes:
    """libsodium's crypto_kdf_derive_from_key: BLAKE2b keyed with the master key over an empty message,
    salt = the subkey id (64-bit LE) padded to 16 bytes, personalisation = the 8-byte context padded to 16."""
    assert len(key) == 32 and len(context) == 8 and 16 <= length <= 64
    return hashlib.blake2b(b"", digest_size=length, key=key, salt=subkey_id.to_bytes(8, "little") + bytes(8),
                           person=context + bytes(8)).digest()


def sig_key(key: bytes) -> bytes:
    return kdf(key, SIG_KEY_LEN, SUBKEY_ID, SIG_CONTEXT)


def aead_key(key: bytes) -> bytes:
    return kdf(key, AEAD_KEY_LEN, SUBKEY_ID, AEAD_CONTEXT)


@dataclass(frozen=True)
class SignedInput:
    name: str
    note: str
    mode: str            # "signed" | "encrypted"
    key_id: int
    counter: int         # 48-bit freshness counter: counter_hi << 32 | seq
    dir_id: bytes
    dest_id: bytes
    src_id: bytes
    admin: int
    hop_limit: int
    fingerprint: int
    payload: bytes       # plaintext


def signing_header(flags: int, v: SignedInput) -> bytes:
    """The canonical 68-byte prefix of the tag input (and the AEAD's additional data)."""
    seq, counter_hi = v.counter & 0xFFFFFFFF, v.counter >> 32
    return (DOMAIN + bytes([frame_ref.WIRE_VERSION | flags]) + struct.pack("<H", frame_ref.MSG_TYPE_PUBSUB)
            + v.dir_id + v.dest_id + v.src_id
            + struct.pack("<BHIIBH", v.admin, len(v.payload), seq, v.fingerprint, v.key_id, counter_hi))


def aead_nonce(v: SignedInput) -> bytes:
    """src_id[12] | counter 48-bit LE | key_id | 5 zero bytes."""
    return v.src_id + v.counter.to_bytes(6, "little") + bytes([v.key_id]) + bytes(5)


def frame_bytes(flags: int, v: SignedInput, body: bytes, tag: bytes) -> tuple[bytes, int, int]:
    """The whole frame (header with checks, body, trailer); returns (frame, hdr_check, msg_crc)."""
    trailer = bytes([v.key_id]) + struct.pack("<H", v.counter >> 32) + tag
    assert len(trailer) == TRAILER_LEN[flags]
    header = bytearray(frame_ref.HEADER_LEN)
    header[0:2] = frame_ref.SYNC
    header[3] = frame_ref.WIRE_VERSION | flags
    struct.pack_into("<HH", header, 4, frame_ref.MSG_TYPE_PUBSUB, frame_ref.HEADER_LEN + len(body) + len(trailer))
    header[8:24], header[24:36], header[36:48] = v.dir_id, v.dest_id, v.src_id
    struct.pack_into("<BBHII", header, 48, v.admin, v.hop_limit, len(body), v.counter & 0xFFFFFFFF, v.fingerprint)
    header_crc = frame_ref.crc32c(bytes(header[frame_ref.CHECKED]))
    msg_crc = frame_ref.crc32c(body + trailer, header_crc)
    header[2] = frame_ref.fold8(header_crc)
    struct.pack_into("<I", header, 60, msg_crc)
    return bytes(header) + body + trailer, header[2], msg_crc


def protect(v: SignedInput) -> dict[str, object]:
    key = KEYS[v.key_id]
    if v.mode == "signed":
        sh = signing_header(FLAG_SIGNED, v)
        tag = crypto_shorthash_siphash24(sh + v.payload, sig_key(key))
        assert len(tag) == SIG_TAG_LEN
        frame, hdr_check, msg_crc = frame_bytes(FLAG_SIGNED, v, v.payload, tag)
        extra: dict[str, object] = {}
    else:
        sh = signing_header(FLAG_ENCRYPTED, v)
        nonce = aead_nonce(v)
        sealed = crypto_aead_xchacha20poly1305_ietf_encrypt(v.payload, sh, nonce, aead_key(key))
        body, tag = sealed[:-AEAD_TAG_LEN], sealed[-AEAD_TAG_LEN:]
        frame, hdr_check, msg_crc = frame_bytes(FLAG_ENCRYPTED, v, body, tag)
        extra = {"nonce": nonce.hex(), "ciphertext": body.hex()}
    return {"signing_header": sh.hex(), "tag": tag.hex(), **extra, "hdr_check": hdr_check, "msg_crc": msg_crc,
            "frame": frame.hex()}


def inputs() -> list[SignedInput]:
    e = frame_ref.entity_id
    d = frame_ref.dir_id
    p = frame_ref.pattern
    gcs, ob1, ob2, fcs = e("gcs1"), e("rmax1ob1"), e("rmax1ob2"), e("fcs20")
    c0 = 0x00003A5B_C0DE0001   # a wall-clock-like counter with a non-zero high half
    return [
        SignedInput("signed_data_88", "SIGNED DATA, 24-byte payload (ATTITUDE-sized, 99 bytes)", "signed", 1, c0,
                    d("onboardSet"), gcs, ob1, ADMIN["DATA"], 8, 0x1A2B3C4D, p(24, 1)),
        SignedInput("signed_data_112", "SIGNED DATA, 48-byte payload (GPS_RAW_INT-sized)", "signed", 1, c0 + 1,
                    d("gpsOut"), gcs, ob1, ADMIN["DATA"], 8, 0x00C0FFEE, p(48, 2)),
        SignedInput("signed_data_123", "SIGNED DATA, 59-byte payload (HIGHRES_IMU-sized)", "signed", 7, c0 + 2,
                    d("imuOutputs"), ob2, fcs, ADMIN["DATA"], 8, 0x80000001, p(59, 3)),
        SignedInput("signed_hop_1", "the frame of signed_data_88 after 7 forwarders: same tag, hop limit 1",
                    "signed", 1, c0, d("onboardSet"), gcs, ob1, ADMIN["DATA"], 1, 0x1A2B3C4D, p(24, 1)),
        SignedInput("signed_ack_empty", "SIGNED ACK, empty payload", "signed", 1, c0 + 3,
                    d("gpsOut"), ob1, gcs, ADMIN["ACK"], 8, 0, b""),
        SignedInput("signed_seq_wrap_before", "SIGNED, counter 0x0001FFFFFFFF: seq at its 32-bit maximum", "signed",
                    7, 0x0001_FFFFFFFF, d("gpsOut"), gcs, ob1, ADMIN["DATA"], 8, 0x00C0FFEE, p(48, 4)),
        SignedInput("signed_seq_wrap_after", "SIGNED, counter 0x000200000000: seq wrapped to 0, counter_hi rose",
                    "signed", 7, 0x0002_00000000, d("gpsOut"), gcs, ob1, ADMIN["DATA"], 8, 0x00C0FFEE, p(48, 5)),
        SignedInput("signed_counter_max", "SIGNED, the largest 48-bit counter, key id 200, hop limit 255", "signed",
                    200, (1 << 48) - 1, d("onboardSet"), fcs, gcs, ADMIN["DATA"], 255, 0x01234567, p(24, 6)),
        SignedInput("signed_max_payload", f"SIGNED, largest payload ({frame_ref.MAX_PAYLOAD} bytes)", "signed", 1,
                    c0 + 4, d("bigBlob"), gcs, ob1, ADMIN["DATA"], 8, 0xFFFFFFFF, p(frame_ref.MAX_PAYLOAD, 7)),
        SignedInput("challenge", "CHALLENGE: a 16-byte nonce from gcs1 to rmax1ob1", "signed", 1, c0 + 5,
                    bytes(16), ob1, gcs, ADMIN["CHALLENGE"], 8, 0, p(16, 8)),
        SignedInput("challenge_reply", "CHALLENGE_REPLY: the nonce echoed, with the source's current counter",
                    "signed", 1, c0 + 77, bytes(16), gcs, ob1, ADMIN["CHALLENGE_REPLY"], 8, 0, p(16, 8)),
        SignedInput("encrypted_data_88", "ENCRYPTED DATA, 24-byte payload (107 bytes)", "encrypted", 1, c0,
                    d("onboardSet"), gcs, ob1, ADMIN["DATA"], 8, 0x1A2B3C4D, p(24, 1)),
        SignedInput("encrypted_data_112", "ENCRYPTED DATA, 48-byte payload", "encrypted", 7, c0 + 1,
                    d("gpsOut"), gcs, ob1, ADMIN["DATA"], 8, 0x00C0FFEE, p(48, 2)),
        SignedInput("encrypted_data_123", "ENCRYPTED DATA, 59-byte payload", "encrypted", 7, c0 + 2,
                    d("imuOutputs"), ob2, fcs, ADMIN["DATA"], 3, 0x80000001, p(59, 3)),
        SignedInput("encrypted_empty", "ENCRYPTED, empty payload: the tag authenticates the header alone",
                    "encrypted", 200, 1, d("gpsOut"), ob1, gcs, ADMIN["ACK"], 8, 0, b""),
        SignedInput("encrypted_max_payload", f"ENCRYPTED, largest payload ({frame_ref.MAX_PAYLOAD} bytes)",
                    "encrypted", 1, (1 << 48) - 2, d("bigBlob"), gcs, ob1, ADMIN["DATA"], 8, 0xFFFFFFFF,
                    p(frame_ref.MAX_PAYLOAD, 9)),
    ]


def vector_json(v: SignedInput) -> dict[str, object]:
    return {
        "name": v.name, "note": v.note, "mode": v.mode, "key_id": v.key_id, "counter": v.counter,
        "dir_id": v.dir_id.hex(), "dest_id": v.dest_id.hex(), "src_id": v.src_id.hex(), "admin": v.admin,
        "hop_limit": v.hop_limit, "fingerprint": v.fingerprint, "payload": v.payload.hex(), **protect(v),
    }


def rejects() -> list[dict[str, object]]:
    """Frames a receiver must refuse, each CRC-valid (so only the named check can catch it)."""
    base = inputs()[0]
    good = bytes.fromhex(str(protect(base)["frame"]))
    out = []

    def recrc(frame: bytearray) -> bytes:
        header_crc = frame_ref.crc32c(bytes(frame[frame_ref.CHECKED]))
        frame[2] = frame_ref.fold8(header_crc)
        struct.pack_into("<I", frame, 60, frame_ref.crc32c(bytes(frame[64:]), header_crc))
        return bytes(frame)

    f = bytearray(good)
    f[-1] ^= 0x01
    out.append({"name": "bad_tag_last_bit", "expect": "bad_tag", "note": "last tag bit flipped", "frame": recrc(f).hex()})
    f = bytearray(good)
    f[64] ^= 0x80
    out.append({"name": "bad_tag_payload", "expect": "bad_tag", "note": "a payload bit flipped, CRC recomputed",
                "frame": recrc(f).hex()})
    f = bytearray(good)
    f[64 + 24] = 9   # key id of the trailer: no key 9 in KEYS
    out.append({"name": "unknown_key", "expect": "unknown_key", "note": "key id 9 (not in the keyring)",
                "frame": recrc(f).hex()})
    f = bytearray(good)
    f[3] = frame_ref.WIRE_VERSION | 0x40
    out.append({"name": "reserved_flag", "expect": "bad_version", "note": "reserved flag 0x40 set",
                "frame": recrc(f).hex()})
    f = bytearray(good)
    f[3] = frame_ref.WIRE_VERSION   # the flag removed: the trailer is now excess length
    out.append({"name": "flag_stripped", "expect": "bad_length", "note": "SIGNED flag cleared, trailer left",
                "frame": recrc(f).hex()})
    return out


def document() -> dict[str, object]:
    return {
        "description": "uavbus SIGNED / ENCRYPTED frame conformance vectors (docs/security.md); regenerate with "
                       "tests/vectors/make_signed_vectors.py. Public test keys only.",
        "keys": {str(k): v.hex() for k, v in KEYS.items()},
        "kdf": {"function": "crypto_kdf_derive_from_key", "subkey_id": SUBKEY_ID,
                "contexts": {"sig": SIG_CONTEXT.decode(), "aead": AEAD_CONTEXT.decode()}},
        "subkeys": {str(k): {"sig": sig_key(v).hex(), "aead": aead_key(v).hex()} for k, v in KEYS.items()},
        "flags": {"signed": FLAG_SIGNED, "encrypted": FLAG_ENCRYPTED},
        "domain": DOMAIN.decode("ascii"),
        "vectors": [vector_json(v) for v in inputs()],
        "rejects": rejects(),
    }


def render() -> str:
    return json.dumps(document(), indent=2) + "\n"


def main(argv: list[str]) -> int:
    return frame_ref.write_or_check(argv, render(), OUTPUT, __doc__.splitlines()[0], Path(__file__).name)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
