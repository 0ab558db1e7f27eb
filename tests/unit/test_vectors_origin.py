"""ORIGIN conformance vectors: the committed tests/vectors/origin_frames.json is exactly what the independent
Python reference (PyNaCl X25519 / SipHash-2-4 / XChaCha20-Poly1305, hashlib BLAKE2b) produces, and the C
runtime, through the cffi binding, rebuilds every public key, pair key, origin tag and whole frame byte for
byte, verifies the hop tag of every frame and refuses the rejects. (runtime_c/tests/test_origin_vectors.c
checks C alone, and feeds every vector and reject to a node hosting its destination.)"""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

from uavbus._bindings import ub_frame as uf
from uavbus._bindings import ub_origin, ub_sec
from uavbus._bindings.ub_error import AuthError, UbError

VECTORS_DIR = Path(__file__).resolve().parents[1] / "vectors"
JSON_PATH = VECTORS_DIR / "origin_frames.json"
DOC: dict[str, Any] = json.loads(JSON_PATH.read_text(encoding="utf-8"))
VECTORS: list[dict[str, Any]] = DOC["vectors"]
REJECTS: list[dict[str, Any]] = DOC["rejects"]
IDS = {i["name"]: i for i in DOC["identities"]}


def load_reference() -> ModuleType:
    sys.path.insert(0, str(VECTORS_DIR))
    spec = importlib.util.spec_from_file_location("make_origin_vectors", VECTORS_DIR / "make_origin_vectors.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def sec() -> Any:
    return ub_sec.ub_sec_new({DOC["group_key"]["id"]: bytes.fromhex(DOC["group_key"]["key"])})


def key(src: str, dest: str) -> bytes:
    s, d = IDS[src], IDS[dest]
    tx, _ = ub_origin.ub_origin_pair_keys(bytes.fromhex(s["id"]), bytes.fromhex(s["x25519_sk"]),
                                          bytes.fromhex(d["id"]), bytes.fromhex(d["x25519_pk"]))
    return tx


def header_of(v: dict[str, Any], origin_tag: bytes = bytes(8)) -> uf.FrameHeader:
    flags = (uf.FLAG_SIGNED if v["mode"] == "signed" else uf.FLAG_ENCRYPTED) | uf.FLAG_ORIGIN
    return uf.FrameHeader(
        dir_id=bytes.fromhex(v["dir_id"]), dest_id=bytes.fromhex(v["dest_id"]), src_id=bytes.fromhex(v["src_id"]),
        admin=v["admin"], hop_limit=v["hop_limit"], payload_size=len(v["payload"]) // 2,
        seq=v["counter"] & 0xFFFFFFFF, fingerprint=v["fingerprint"], flags=flags, key_id=v["key_id"],
        counter_hi=v["counter"] >> 32, origin_hop0=v["hop0"], origin_tag=origin_tag)


def test_regenerating_reproduces_committed_json_exactly() -> None:
    assert load_reference().render() == JSON_PATH.read_text(encoding="utf-8"), (
        f"{JSON_PATH}:1: stale; run python3 tests/vectors/make_origin_vectors.py")


def test_public_and_pair_keys() -> None:
    for ident in DOC["identities"]:
        assert ub_origin.ub_origin_public_key(bytes.fromhex(ident["x25519_sk"])).hex() == ident["x25519_pk"]
    for p in DOC["pairs"]:
        x_is_a = IDS[p["x"]]["id"] == p["a"]
        assert key(p["x"], p["y"]).hex() == (p["key_ab"] if x_is_a else p["key_ba"])
        assert key(p["y"], p["x"]).hex() == (p["key_ba"] if x_is_a else p["key_ab"])
        assert p["key_ab"] != p["key_ba"]


@pytest.mark.parametrize("v", VECTORS, ids=[v["name"] for v in VECTORS])
def test_c_reproduces_origin_tag_and_frame(sec: Any, v: dict[str, Any]) -> None:
    payload = bytes.fromhex(v["payload"])
    tag = ub_origin.ub_origin_tag(key(v["src"], v["dest"]), header_of(v), payload)
    assert tag.hex() == v["origin_tag"]
    assert ub_sec.ub_sec_protect(sec, header_of(v, tag), payload).hex() == v["frame"]
    header, plain = ub_sec.ub_sec_verify(sec, bytes.fromhex(v["frame"]))
    assert header == header_of(v, tag)
    assert plain == payload
    # another pair's key (a third entity's) never makes this tag
    third = next(n for n in IDS if n not in (v["src"], v["dest"]))
    assert ub_origin.ub_origin_tag(key(third, v["dest"]), header_of(v), payload) != tag


@pytest.mark.parametrize("r", REJECTS, ids=[r["name"] for r in REJECTS])
def test_c_refuses_each_reject(sec: Any, r: dict[str, Any]) -> None:
    frame = bytes.fromhex(r["frame"])
    if r["expect"] == "bad_version":
        with pytest.raises(UbError):
            uf.ub_frame_parse(frame)
        return
    if r["expect"] == "bad_tag":
        with pytest.raises(AuthError):
            ub_sec.ub_sec_verify(sec, frame)
        return
    # an insider's frame: the hop tag verifies; the origin check fails (tag, or hop limit above hop0)
    header, plain = ub_sec.ub_sec_verify(sec, frame)
    good = ub_origin.ub_origin_tag(key(uf_name(header.src_id), r["dest"]), header, plain)
    assert good != header.origin_tag or header.hop_limit > header.origin_hop0


def uf_name(raw: bytes) -> str:
    return raw.rstrip(b"\0").decode()
