"""SIGNED / ENCRYPTED conformance vectors: the committed tests/vectors/signed_frames.json is exactly what the
independent Python reference (libsodium's KDF rebuilt with hashlib BLAKE2b, PyNaCl SipHash-2-4 and
XChaCha20-Poly1305) produces, and the C runtime,
through the cffi binding, rebuilds every frame byte for byte, verifies it back to its plaintext and
refuses every reject for the named reason. (runtime_c/tests/test_sec_vectors.c checks C alone.)"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import struct
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest
from nacl.bindings import crypto_aead_xchacha20poly1305_ietf_decrypt, crypto_shorthash_siphash24

from uavbus._bindings import ub_frame as uf
from uavbus._bindings import ub_sec
from uavbus._bindings.ub_error import AuthError, NotFoundError, UbError

VECTORS_DIR = Path(__file__).resolve().parents[1] / "vectors"
JSON_PATH = VECTORS_DIR / "signed_frames.json"
DOC: dict[str, Any] = json.loads(JSON_PATH.read_text(encoding="utf-8"))
VECTORS: list[dict[str, Any]] = DOC["vectors"]
REJECTS: list[dict[str, Any]] = DOC["rejects"]
KEYS = {int(k): bytes.fromhex(v) for k, v in DOC["keys"].items()}
SUBKEYS = {int(k): {n: bytes.fromhex(x) for n, x in v.items()} for k, v in DOC["subkeys"].items()}


def load_reference() -> ModuleType:
    sys.path.insert(0, str(VECTORS_DIR))
    spec = importlib.util.spec_from_file_location("make_signed_vectors", VECTORS_DIR / "make_signed_vectors.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def sec() -> Any:
    return ub_sec.ub_sec_new(KEYS)


def header_of(v: dict[str, Any]) -> uf.FrameHeader:
    flags = uf.FLAG_SIGNED if v["mode"] == "signed" else uf.FLAG_ENCRYPTED
    return uf.FrameHeader(
        dir_id=bytes.fromhex(v["dir_id"]), dest_id=bytes.fromhex(v["dest_id"]), src_id=bytes.fromhex(v["src_id"]),
        admin=v["admin"], hop_limit=v["hop_limit"], payload_size=len(v["payload"]) // 2,
        seq=v["counter"] & 0xFFFFFFFF, fingerprint=v["fingerprint"], flags=flags, key_id=v["key_id"],
        counter_hi=v["counter"] >> 32)


def test_regenerating_reproduces_committed_json_exactly() -> None:
    assert load_reference().render() == JSON_PATH.read_text(encoding="utf-8"), (
        f"{JSON_PATH}:1: stale; run python3 tests/vectors/make_signed_vectors.py")


def test_vectors_cover_the_construction() -> None:
    modes = {v["mode"] for v in VECTORS}
    assert modes == {"signed", "encrypted"}
    assert {0, 24, 48, 59, 1024} <= {len(v["payload"]) // 2 for v in VECTORS}
    assert {7, 8} <= {v["admin"] for v in VECTORS}          # CHALLENGE and CHALLENGE_REPLY
    assert max(v["counter"] for v in VECTORS) == (1 << 48) - 1
    assert len({v["key_id"] for v in VECTORS}) >= 3
    assert {r["expect"] for r in REJECTS} >= {"bad_tag", "unknown_key", "bad_version", "bad_length"}


def test_subkeys_are_libsodiums_kdf_of_each_key() -> None:
    """The documented KDF (docs/security.md): BLAKE2b keyed with the key over nothing, salt = subkey id 1
    (LE, padded to 16 bytes), personalisation = the 8-character context (padded to 16)."""
    assert DOC["kdf"] == {"function": "crypto_kdf_derive_from_key", "subkey_id": 1,
                          "contexts": {"sig": "ubsig001", "aead": "ubaead01"}}
    for kid, key in KEYS.items():
        salt = (1).to_bytes(8, "little") + bytes(8)
        assert SUBKEYS[kid]["sig"] == hashlib.blake2b(b"", digest_size=16, key=key, salt=salt,
                                                      person=b"ubsig001" + bytes(8)).digest()
        assert SUBKEYS[kid]["aead"] == hashlib.blake2b(b"", digest_size=32, key=key, salt=salt,
                                                       person=b"ubaead01" + bytes(8)).digest()


@pytest.mark.parametrize("v", VECTORS, ids=[v["name"] for v in VECTORS])
def test_vector_layout_matches_the_documented_construction(v: dict[str, Any]) -> None:
    frame = bytes.fromhex(v["frame"])
    payload = bytes.fromhex(v["payload"])
    flags = 0x10 if v["mode"] == "signed" else 0x20
    tag_len = 8 if flags == 0x10 else 16
    assert frame[3] == 0x01 | flags
    assert struct.unpack_from("<H", frame, 6)[0] == len(frame) == 64 + len(payload) + 3 + tag_len
    trailer = frame[64 + len(payload):]
    assert trailer[0] == v["key_id"] and struct.unpack_from("<H", trailer, 1)[0] == v["counter"] >> 32
    sh = bytes.fromhex(v["signing_header"])
    assert len(sh) == 68 and sh.startswith(b"uavbus-sig1")
    if flags == 0x10:
        assert frame[64:64 + len(payload)] == payload
        assert trailer[3:] == crypto_shorthash_siphash24(sh + payload, SUBKEYS[v["key_id"]]["sig"])
    else:
        nonce = bytes.fromhex(v["nonce"])
        assert nonce == frame[36:48] + v["counter"].to_bytes(6, "little") + bytes([v["key_id"]]) + bytes(5)
        body = frame[64:64 + len(payload)]
        assert crypto_aead_xchacha20poly1305_ietf_decrypt(body + trailer[3:], sh, nonce,
                                                          SUBKEYS[v["key_id"]]["aead"]) == payload


@pytest.mark.parametrize("v", VECTORS, ids=[v["name"] for v in VECTORS])
def test_c_protect_reproduces_the_vector(sec: Any, v: dict[str, Any]) -> None:
    assert ub_sec.ub_sec_protect(sec, header_of(v), bytes.fromhex(v["payload"])).hex() == v["frame"]


@pytest.mark.parametrize("v", VECTORS, ids=[v["name"] for v in VECTORS])
def test_c_verify_recovers_header_and_plaintext(sec: Any, v: dict[str, Any]) -> None:
    header, plain = ub_sec.ub_sec_verify(sec, bytes.fromhex(v["frame"]))
    assert header == header_of(v)
    assert header.counter == v["counter"]
    assert plain.hex() == v["payload"]


@pytest.mark.parametrize("r", REJECTS, ids=[r["name"] for r in REJECTS])
def test_c_refuses_each_reject_for_its_reason(sec: Any, r: dict[str, Any]) -> None:
    frame = bytes.fromhex(r["frame"])
    expected = {"bad_tag": AuthError, "unknown_key": NotFoundError}.get(r["expect"], UbError)
    with pytest.raises(expected):
        ub_sec.ub_sec_verify(sec, frame)
    if r["expect"] in ("bad_version", "bad_length"):
        with pytest.raises(UbError):
            uf.ub_frame_parse(frame)


def test_a_context_without_the_key_refuses_every_vector() -> None:
    other = ub_sec.ub_sec_new({1: bytes(32)})       # id 1, but another key
    for v in VECTORS:
        with pytest.raises(AuthError if v["key_id"] == 1 else NotFoundError):
            ub_sec.ub_sec_verify(other, bytes.fromhex(v["frame"]))


@pytest.mark.parametrize("v", [v for v in VECTORS if v["payload"]], ids=[v["name"] for v in VECTORS if v["payload"]])
def test_log_and_live_tools_read_the_payload_before_the_trailer(v: dict[str, Any]) -> None:
    from uavbus.logfile import LogRecord
    from uavbus.tools.common import Seen

    frame = bytes.fromhex(v["frame"])
    header = uf.ub_frame_parse(frame)
    on_wire = frame[64:64 + len(v["payload"]) // 2].hex()      # plaintext when SIGNED, ciphertext when ENCRYPTED
    assert Seen(t_ms=0, link="l", dir="rx", header=header, frame=frame).payload.hex() == on_wire
    rec = LogRecord(offset=0, t_ms=0, link_id=0, link="l", dir="rx", frame=frame, header=header)
    assert rec.payload.hex() == on_wire
    if v["mode"] == "signed":
        assert on_wire == v["payload"]
