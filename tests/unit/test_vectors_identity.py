"""Identity vectors: tests/vectors/identity.json is exactly what the independent Python reference
(make_identity_vectors.py: PyNaCl Ed25519/X25519 and hashlib BLAKE2b) produces, and the C runtime, through
the cffi binding, rebuilds every certificate, record and file byte for byte from the same seeds and
verifies them. (runtime_c/tests/test_ident_vectors.c checks C alone.)"""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path
from typing import Any

import pytest

from uavbus._bindings import ub_ident

VECTORS_DIR = Path(__file__).resolve().parents[1] / "vectors"
DOC: dict[str, Any] = json.loads((VECTORS_DIR / "identity.json").read_text(encoding="utf-8"))
AUTH_SEED = bytes.fromhex(DOC["authority"]["seed"])


def test_the_json_is_the_reference_output() -> None:
    spec = importlib.util.spec_from_file_location("make_identity_vectors", VECTORS_DIR / "make_identity_vectors.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    assert module.build() == DOC


def test_authority_and_its_files(tmp_path: Path) -> None:
    pk, sk = ub_ident.sign_keypair(AUTH_SEED)
    assert pk.hex() == DOC["authority"]["public_key"]
    assert ub_ident.authority_kid(pk).hex() == DOC["authority"]["key_id"]
    ub_ident.authfile_write_public(tmp_path / "a.pub", pk)
    ub_ident.authfile_write_secret(tmp_path / "a.key", AUTH_SEED)
    assert (tmp_path / "a.pub").read_bytes().hex() == DOC["authority"]["public_file"]
    assert (tmp_path / "a.key").read_bytes().hex() == DOC["authority"]["secret_file"]
    assert ub_ident.authfile_load_secret(tmp_path / "a.key") == sk


@pytest.mark.parametrize("vec", DOC["certificates"], ids=lambda v: v["entity"])
def test_certificate_bytes(vec: dict[str, Any], tmp_path: Path) -> None:
    _, auth_sk = ub_ident.sign_keypair(AUTH_SEED)
    sign_seed, kx_seed = bytes.fromhex(vec["sign_seed"]), bytes.fromhex(vec["kx_seed"])
    sign_pk, _ = ub_ident.sign_keypair(sign_seed)
    kx_pk, kx_sk = ub_ident.kx_keypair(kx_seed)
    cert = ub_ident.Certificate(roles=vec["roles"], serial=int(vec["serial"]), entity=ub_ident.entity_id(vec["entity"]),
                                sign_pk=sign_pk, kx_pk=kx_pk, not_before=int(vec["not_before"]),
                                not_after=int(vec["not_after"]), authority=bytes(8), signature=bytes(64))
    signed, data = ub_ident.cert_sign(cert, auth_sk)
    assert data.hex() == vec["bytes"]
    assert ub_ident.cert_decode(data) == signed
    assert ub_ident.cert_verify(signed, auth_sk[32:]) == "valid"
    path = tmp_path / "e.id"
    ub_ident.identfile_write(path, signed, sign_seed, kx_sk)
    assert path.read_bytes().hex() == vec["identity_file"]
    assert path.stat().st_mode & 0o777 == 0o600


@pytest.mark.parametrize("vec", DOC["revocations"], ids=lambda v: v["entity"])
def test_revocation_bytes(vec: dict[str, Any]) -> None:
    _, auth_sk = ub_ident.sign_keypair(AUTH_SEED)
    data = ub_ident.revocation_sign(ub_ident.entity_id(vec["entity"]), int(vec["serial"]), int(vec["time"]), auth_sk)
    assert data.hex() == vec["bytes"]
    assert ub_ident.revocation_decode(data).serial == int(vec["serial"])


def test_revocations_file(tmp_path: Path) -> None:
    pk, _ = ub_ident.sign_keypair(AUTH_SEED)
    store = ub_ident.Store(pk)
    for vec in DOC["revocations"]:
        assert store.add_revocation(bytes.fromhex(vec["bytes"])) == "added"
    store.save_revocations(tmp_path / "r.ubr")
    assert (tmp_path / "r.ubr").read_bytes().hex() == DOC["revocations_file"]
    again = ub_ident.Store(pk)
    assert again.load_revocations(tmp_path / "r.ubr") == 2
    assert again.status(ub_ident.entity_id("rmax1ob1"), 1_790_000_001) == "revoked"
