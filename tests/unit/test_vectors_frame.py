"""The frame conformance vectors: the committed tests/vectors/frames.json is exactly what the
independent Python reference produces, and each vector is self-consistent with the layout in
docs/wire-format.md. (The C runtime's test_frame_vectors checks the C side against the same file.)"""

from __future__ import annotations

import importlib.util
import json
import struct
import sys
from pathlib import Path
from types import ModuleType

import pytest

VECTORS_DIR = Path(__file__).resolve().parents[1] / "vectors"
JSON_PATH = VECTORS_DIR / "frames.json"
VECTORS: list[dict[str, object]] = json.loads(JSON_PATH.read_text(encoding="utf-8"))["vectors"]


def load_reference() -> ModuleType:
    spec = importlib.util.spec_from_file_location("make_frame_vectors", VECTORS_DIR / "make_frame_vectors.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up while the class is built
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def ref() -> ModuleType:
    return load_reference()


@pytest.fixture(scope="module")
def committed() -> dict[str, object]:
    return json.loads(JSON_PATH.read_text(encoding="utf-8"))


def test_regenerating_reproduces_committed_json_exactly(ref: ModuleType) -> None:
    assert ref.render() == JSON_PATH.read_text(encoding="utf-8"), (
        f"{JSON_PATH}:1: stale; run python3 tests/vectors/make_frame_vectors.py"
    )


def test_reference_crc_check_values(ref: ModuleType) -> None:
    assert ref.crc32c(b"123456789") == 0xE3069283
    assert ref.crc32c(bytes(32)) == 0x8A9136AA  # RFC 3720 B.4
    assert ref.crc32c(b"6789", ref.crc32c(b"12345")) == 0xE3069283  # continuation


def test_vectors_cover_the_brief(committed: dict[str, object]) -> None:
    vectors = committed["vectors"]
    assert isinstance(vectors, list) and len(vectors) >= 10
    assert {v["admin"] for v in vectors} == set(range(7))  # every admin code
    payload_sizes = {len(v["payload"]) // 2 for v in vectors}
    assert 0 in payload_sizes and 1024 in payload_sizes and {24, 48, 59} <= payload_sizes
    assert {1, 255} <= {v["hop_limit"] for v in vectors}


@pytest.mark.parametrize("v", VECTORS, ids=[str(v["name"]) for v in VECTORS])
def test_vector_fields_sit_at_documented_offsets(ref: ModuleType, v: dict[str, object]) -> None:
    frame = bytes.fromhex(str(v["frame"]))
    payload = bytes.fromhex(str(v["payload"]))
    assert frame[0:2] == b"\xa5\x5b" and frame[3] == 1
    msg_type, msg_size = struct.unpack_from("<HH", frame, 4)
    assert (msg_type, msg_size) == (0x5053, len(frame)) and msg_size == 64 + len(payload)
    assert frame[8:24].hex() == v["dir_id"]
    assert frame[24:36].hex() == v["dest_id"]
    assert frame[36:48].hex() == v["src_id"]
    admin, hop, payload_size, seq, fingerprint, msg_crc = struct.unpack_from("<BBHIII", frame, 48)
    assert (admin, hop, payload_size, seq, fingerprint) == (
        v["admin"], v["hop_limit"], len(payload), v["seq"], v["fingerprint"])
    assert frame[64:] == payload
    header_crc = ref.crc32c(frame[4:60])
    assert frame[2] == v["hdr_check"] == ref.fold8(header_crc)
    assert msg_crc == v["msg_crc"] == ref.crc32c(frame[4:60] + payload)
