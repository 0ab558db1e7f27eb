#!/usr/bin/env python3
"""Independent Python reference for identity certificates and revocation records; writes
tests/vectors/identity.json.

It shares no code with the C runtime: the byte layouts are transcribed from docs/wire-format.md
("Identity certificates") and ub_ident.h. Ed25519 and X25519 come from PyNaCl (libsodium's own
seeded key pairs and detached signatures, which are deterministic), the authority key id from
Python's hashlib.blake2b. The C runtime rebuilds every certificate, record and identity file from
the same seeds, in C (runtime_c/tests/test_ident_vectors.c) and through the cffi binding
(tests/unit/test_vectors_identity.py), and must match byte for byte.

The seeds below are public test-vector seeds, not keys of any deployment.

    python3 tests/vectors/make_identity_vectors.py            # rewrite identity.json
    python3 tests/vectors/make_identity_vectors.py --check    # exit 1 if identity.json is stale
"""

from __future__ import annotations

import hashlib
import json
import struct
import sys
from pathlib import Path

from nacl.bindings import crypto_kx_seed_keypair, crypto_sign, crypto_sign_seed_keypair


def crypto_sign_detached(message: bytes, sk: bytes) -> bytes:
    """Ed25519's signed message is signature || message: the detached signature is its first 64 bytes."""
    return crypto_sign(message, sk)[:64]

OUTPUT = Path(__file__).with_name("identity.json")

VERSION, KIND_CERT, KIND_REVOCATION = 1, 1, 2
ROLES = {"admin": 0x01, "vehicle": 0x02, "relay": 0x04, "bridge": 0x08, "observer": 0x10}


def seed(label: str) -> bytes:
    return hashlib.sha256(b"uavbus identity test vector: " + label.encode()).digest()


def entity_id(name: str) -> bytes:
    raw = name.encode("ascii")
    assert 1 <= len(raw) <= 12
    return raw + bytes(12 - len(raw))


def key_id(authority_pk: bytes) -> bytes:
    return hashlib.blake2b(authority_pk, digest_size=32).digest()[:8]


def certificate(authority_sk: bytes, authority_pk: bytes, *, roles: int, serial: int, entity: str, sign_pk: bytes,
                kx_pk: bytes, not_before: int, not_after: int) -> bytes:
    body = struct.pack("<BBHQ", VERSION, KIND_CERT, roles, serial) + entity_id(entity) + sign_pk + kx_pk
    body += struct.pack("<QQ", not_before, not_after) + key_id(authority_pk)
    assert len(body) == 112
    return body + crypto_sign_detached(body, authority_sk)


def revocation(authority_sk: bytes, authority_pk: bytes, *, entity: str, serial: int, time_s: int) -> bytes:
    body = struct.pack("<BBHQ", VERSION, KIND_REVOCATION, 0, serial) + entity_id(entity)
    body += struct.pack("<Q", time_s) + key_id(authority_pk)
    assert len(body) == 40
    return body + crypto_sign_detached(body, authority_sk)


def header(magic: bytes) -> bytes:
    return magic + bytes([1, 0, 0, 0])


CERTS = [
    # label, entity, roles, serial, not_before, not_after
    ("gcs1", "gcs1", ROLES["admin"], 1, 1_790_000_000, 1_821_536_000),
    ("rmax1ob1", "rmax1ob1", ROLES["vehicle"] | ROLES["relay"], 2, 1_790_000_000, 1_821_536_000),
    ("fcs20", "fcs20", ROLES["vehicle"], 3, 1_790_000_000, 1_790_086_400),
    ("mavbridge", "mavbridge1", ROLES["bridge"] | ROLES["observer"], 2**64 - 1, 0, 2**64 - 1),
    ("longname", "abcdefghijkl", 0x1F, 0x0102030405060708, 1, 1),
]
REVOCATIONS = [
    # entity, serial, time
    ("rmax1ob1", 2, 1_795_000_000),
    ("fcs20", 2**64 - 1, 0),
]


def build() -> dict:
    auth_seed = seed("authority")
    auth_pk, auth_sk = crypto_sign_seed_keypair(auth_seed)
    certs = []
    for label, entity, roles, serial, nb, na in CERTS:
        sign_seed, kx_seed = seed(label + " sign"), seed(label + " kx")
        sign_pk, _ = crypto_sign_seed_keypair(sign_seed)
        kx_pk, kx_sk = crypto_kx_seed_keypair(kx_seed)
        cert = certificate(auth_sk, auth_pk, roles=roles, serial=serial, entity=entity, sign_pk=sign_pk, kx_pk=kx_pk,
                           not_before=nb, not_after=na)
        certs.append({"entity": entity, "roles": roles, "serial": str(serial), "not_before": str(nb),
                      "not_after": str(na), "sign_seed": sign_seed.hex(), "kx_seed": kx_seed.hex(),
                      "sign_pk": sign_pk.hex(), "kx_pk": kx_pk.hex(), "kx_sk": kx_sk.hex(), "bytes": cert.hex(),
                      "identity_file": (header(b"UBID") + cert + sign_seed + kx_sk).hex()})
    revs = []
    for entity, serial, time_s in REVOCATIONS:
        rec = revocation(auth_sk, auth_pk, entity=entity, serial=serial, time_s=time_s)
        revs.append({"entity": entity, "serial": str(serial), "time": str(time_s), "bytes": rec.hex()})
    return {
        "description": "Identity certificates and revocation records (docs/wire-format.md#identity-certificates), "
                       "made by tests/vectors/make_identity_vectors.py (PyNaCl + hashlib), reproduced by C and "
                       "Python byte for byte. 64-bit numbers are decimal strings. Public test seeds only.",
        "authority": {"seed": auth_seed.hex(), "public_key": auth_pk.hex(), "key_id": key_id(auth_pk).hex(),
                      "public_file": (header(b"UBAP") + auth_pk).hex(),
                      "secret_file": (header(b"UBAK") + auth_seed).hex()},
        "certificates": certs,
        "revocations": revs,
        "revocations_file": (header(b"UBRV") + b"".join(bytes.fromhex(r["bytes"]) for r in revs)).hex(),
    }


def main(argv: list[str]) -> int:
    text = json.dumps(build(), indent=1) + "\n"
    if "--check" in argv:
        if OUTPUT.read_text(encoding="utf-8") != text:
            print(f"{OUTPUT}: stale; run {Path(__file__).name}", file=sys.stderr)
            return 1
        return 0
    OUTPUT.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
