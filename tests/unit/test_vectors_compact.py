"""Compact-frame and fragment conformance vectors: the committed tests/vectors/compact_frames.json is exactly
what the independent Python reference produces, and the C runtime, through the cffi binding, rebuilds every
packet and its bytes on the wire byte for byte, decodes them back to the full frame, refuses every reject for
its reason, and splits and reassembles the fragmented directory. (runtime_c/tests/test_compact_vectors.c
checks C alone; docs/wire-format.md describes the bytes.)"""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

from uavbus._ub import ffi, lib

VECTORS_DIR = Path(__file__).resolve().parents[1] / "vectors"
JSON_PATH = VECTORS_DIR / "compact_frames.json"
DOC: dict[str, Any] = json.loads(JSON_PATH.read_text(encoding="utf-8"))
RX_REASONS = [ffi.string(lib.ub_rx_reason_name(r)).decode() for r in range(lib.UB_RX_REASON_COUNT)]


def load_reference() -> ModuleType:
    spec = importlib.util.spec_from_file_location("make_compact_vectors", VECTORS_DIR / "make_compact_vectors.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


class CCatalogue:
    """The vectors' catalogue as C descriptors (wire-image types), kept alive with their memory."""

    def __init__(self, entries: list[dict[str, Any]]) -> None:
        n = len(entries)
        self.types = ffi.new("ub_type_desc_t[]", n)
        self.insts = ffi.new("ub_instance_desc_t[]", n)
        self.name = ffi.new("char[]", b"vectors")
        for k, e in enumerate(entries):
            self.types[k].name = self.name
            self.types[k].fingerprint = e["fingerprint"]
            self.types[k].packed_size = self.types[k].c_size = e["packed_size"]
            ffi.memmove(self.insts[k].id, bytes.fromhex(e["id"]), 16)
            self.insts[k].name = self.name
            self.insts[k].type = ffi.addressof(self.types[k])
        self.cat = ffi.new("ub_catalogue_t *")
        self.cat.name, self.cat.abi_version = self.name, lib.UB_CATALOGUE_ABI_VERSION
        self.cat.types, self.cat.n_types, self.cat.instances, self.cat.n_instances = self.types, n, self.insts, n


@pytest.fixture(scope="module")
def cat() -> CCatalogue:
    return CCatalogue(DOC["catalogue"])


def ids_of(name: str) -> list[bytes]:
    return [bytes.fromhex(i) for i in DOC["lists"][name]["ids"]] if name else []


def codec(cat: CCatalogue, entities: str, content_ok: bool) -> tuple[Any, Any]:
    c = ffi.new("ub_compact_codec_t *")
    c.cat, c.cat_hash, c.content_ok = cat.cat, lib.ub_compact_catalogue_hash(cat.cat), content_ok
    ids = ids_of(entities)
    arr = ffi.new("uint8_t[][12]", max(1, len(ids)))
    for k, i in enumerate(ids):
        ffi.memmove(arr[k], i, 12)
    if ids:
        c.entities_ok, c.n_ids, c.ids, c.list_hash = 1, len(ids), arr, int(DOC["lists"][entities]["hash"], 16)
    return c, arr


def decode(c: Any, pkt: bytes, src: bytes | None, ref_seq: int) -> tuple[int, bytes, str]:
    refs = ffi.new("ub_compact_refs_t *")
    if src is not None and ref_seq >= 0:
        refs.ref[0].in_use, refs.ref[0].seq = 1, ref_seq
        ffi.memmove(refs.ref[0].src, src, 12)
    out = ffi.new("uint8_t[]", lib.UB_FRAME_MAX)
    h = ffi.new("ub_frame_header_t *")
    why = ffi.new("ub_rx_reason_t *", lib.UB_RX_REASON_COUNT)
    n = lib.ub_compact_decode(c, pkt, len(pkt), refs, out, lib.UB_FRAME_MAX, h, why)
    return n, bytes(ffi.buffer(out, max(n, 0))), RX_REASONS[why[0]] if why[0] < len(RX_REASONS) else "?"


def test_regenerating_reproduces_committed_json_exactly() -> None:
    assert load_reference().render() == JSON_PATH.read_text(encoding="utf-8"), (
        f"{JSON_PATH}:1: stale; run python3 tests/vectors/make_compact_vectors.py")


def test_hashes_and_cobs(cat: CCatalogue) -> None:
    assert f"{lib.ub_compact_catalogue_hash(cat.cat):016x}" == DOC["catalogue_hash"]
    for name, entry in DOC["lists"].items():
        ids = ids_of(name)
        arr = ffi.new("uint8_t[][12]", len(ids))
        for k, i in enumerate(ids):
            ffi.memmove(arr[k], i, 12)
        assert f"{lib.ub_compact_list_hash(arr, len(ids)):016x}" == entry["hash"]
    for case in DOC["cobs"]:
        data = bytes.fromhex(case["in"])
        out = ffi.new("uint8_t[]", len(data) + len(data) // 254 + 2)
        n = lib.ub_cobs_encode(data, len(data), out, len(out))
        assert bytes(ffi.buffer(out, n)).hex() == case["out"]
        back = ffi.new("uint8_t[]", max(1, len(data)))
        assert lib.ub_cobs_decode(out, n - 1, back, len(back)) == len(data)
        assert bytes(ffi.buffer(back, len(data))) == data


@pytest.mark.parametrize("v", DOC["vectors"], ids=lambda v: v["name"])
def test_vector_encodes_and_decodes_byte_for_byte(cat: CCatalogue, v: dict[str, Any]) -> None:
    frame = bytes.fromhex(v["frame"])
    c, _keep = codec(cat, v["entities"], v["content_ok"])
    pkt = ffi.new("uint8_t[]", lib.UB_COMPACT_PACKET_MAX)
    n = lib.ub_compact_encode(c, frame, len(frame), v["seq32"], pkt, lib.UB_COMPACT_PACKET_MAX)
    assert bytes(ffi.buffer(pkt, n)).hex() == v["packet"]
    wire = ffi.new("uint8_t[]", lib.UB_COMPACT_WIRE_MAX)
    w = lib.ub_cobs_encode(pkt, n, wire, lib.UB_COMPACT_WIRE_MAX)
    assert bytes(ffi.buffer(wire, w)).hex() == v["wire"]
    got, back, why = decode(c, bytes(ffi.buffer(pkt, n)), bytes.fromhex(v["src_id"]), v["ref_seq"])
    assert got == len(frame), why
    assert back == frame
    # What the encoding saves, as the vector's note says: a DATA frame indexed in both ways is 11 bytes + payload.
    if v["name"] in ("attitude", "gps", "highres"):
        assert w == len(v["payload"]) // 2 + 11


@pytest.mark.parametrize("r", DOC["rejects"], ids=lambda r: r["name"])
def test_reject_is_refused_for_its_reason(cat: CCatalogue, r: dict[str, Any]) -> None:
    c, _keep = codec(cat, "fleet", True)
    wire = bytes.fromhex(r["wire"])
    pkt = ffi.new("uint8_t[]", lib.UB_COMPACT_PACKET_MAX)
    n = lib.ub_cobs_decode(wire, len(wire) - 1, pkt, lib.UB_COMPACT_PACKET_MAX)
    if n < 0:
        assert r["expect"] == "bad_crc"  # broken stuffing is line noise
        return
    ob1 = b"rmax1ob1".ljust(12, b"\0")
    got, _, why = decode(c, bytes(ffi.buffer(pkt, n)), ob1, DOC["reject_ref_seq"])
    assert got < 0 and why == r["expect"]


def test_fragments_split_and_reassemble(cat: CCatalogue) -> None:
    fr = DOC["fragments"]
    data = bytes.fromhex(fr["data"])
    count = ffi.new("uint16_t *")
    assert lib.ub_frag_plan(len(data), fr["max_bytes"], count) == 0
    assert count[0] == fr["count"] == len(fr["fragments"])
    payloads = []
    for k, f in enumerate(fr["fragments"]):
        frame = bytes.fromhex(f["frame"])
        out = ffi.new("uint8_t[]", lib.UB_MAX_PAYLOAD)
        n = lib.ub_frag_write(out, lib.UB_MAX_PAYLOAD, fr["transfer"], k, count[0], data, len(data))
        assert bytes(ffi.buffer(out, n)) == frame[64:]
        payloads.append((frame[8:24], frame[36:48], int.from_bytes(frame[56:60], "little"), frame[64:]))
    state = ffi.new("ub_frag_t *")
    lib.ub_frag_init(state, ffi.NULL, 0)
    whole = ffi.new("uint8_t **")
    total = ffi.new("size_t *")
    results = []
    for dir_id, src, fp, payload in reversed(payloads):  # any order
        results.append(lib.ub_frag_take(state, 0, src, dir_id, fp, payload, len(payload), 5, whole, total))
    assert results[:-1] == [0] * (len(payloads) - 1) and results[-1] == 1  # pending ... complete
    assert bytes(ffi.buffer(whole[0], total[0])) == data
