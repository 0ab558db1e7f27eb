"""The C frame codec through cffi (uavbus._bindings.ub_frame): every vector in tests/vectors/frames.json
is rebuilt and parsed byte for byte by the C runtime, and the C stream decoder, fed the vectors in
random chunks, delivers the same frames and counts them in its own (C) counters."""

from __future__ import annotations

import json
import random
from pathlib import Path
from typing import Any

import pytest

from uavbus._bindings import ub_frame as uf

JSON_PATH = Path(__file__).resolve().parents[1] / "vectors" / "frames.json"
DOCUMENT: dict[str, Any] = json.loads(JSON_PATH.read_text(encoding="utf-8"))
VECTORS: list[dict[str, Any]] = DOCUMENT["vectors"]
GARBAGE = b"\x00\x11noise\x5b\xa5\xff"  # no sync pair (0xA5 0x5B), so it can never start a candidate


def header_of(v: dict[str, Any]) -> uf.FrameHeader:
    return uf.FrameHeader(
        dir_id=bytes.fromhex(v["dir_id"]), dest_id=bytes.fromhex(v["dest_id"]),
        src_id=bytes.fromhex(v["src_id"]), admin=v["admin"], hop_limit=v["hop_limit"],
        payload_size=len(v["payload"]) // 2, seq=v["seq"], fingerprint=v["fingerprint"],
        msg_type=DOCUMENT["msg_type"],
    )


def test_constants_come_from_c_and_match_the_vectors() -> None:
    assert uf.FRAME_HEADER_LEN == DOCUMENT["header_len"]
    assert uf.FRAME_MAX == uf.FRAME_HEADER_LEN + uf.MAX_PAYLOAD + uf.TRAILER_MAX  # room for a signed trailer
    check = DOCUMENT["crc32c_check"]
    assert uf.ub_crc32c(bytes.fromhex(check["input"])) == check["crc32c"]
    assert uf.ub_crc32c_update(uf.ub_crc32c(b"12345"), b"6789") == check["crc32c"]


@pytest.mark.parametrize("v", VECTORS, ids=[v["name"] for v in VECTORS])
def test_finish_reproduces_vector_bytes(v: dict[str, Any]) -> None:
    assert uf.ub_frame_finish(header_of(v), bytes.fromhex(v["payload"])).hex() == v["frame"]


@pytest.mark.parametrize("v", VECTORS, ids=[v["name"] for v in VECTORS])
def test_parse_reads_vector_fields(v: dict[str, Any]) -> None:
    frame = bytes.fromhex(v["frame"])
    assert uf.ub_frame_parse(frame) == header_of(v)
    assert uf.ub_crc32c(frame[4:60] + frame[64:]) == v["msg_crc"] == int.from_bytes(frame[60:64], "little")


@pytest.mark.parametrize("v", VECTORS, ids=[v["name"] for v in VECTORS])
def test_set_hop_limit_equals_a_frame_built_with_that_limit(v: dict[str, Any]) -> None:
    new_hop = 1 if v["hop_limit"] != 1 else 200
    rewritten = uf.ub_frame_set_hop_limit(bytes.fromhex(v["frame"]), new_hop)
    rebuilt = uf.ub_frame_finish(
        uf.FrameHeader(**{**header_of(v).__dict__, "hop_limit": new_hop}), bytes.fromhex(v["payload"]))
    assert rewritten == rebuilt != bytes.fromhex(v["frame"])


def corrupted_frame() -> bytes:
    frame = bytearray.fromhex(VECTORS[0]["frame"])
    assert frame.count(b"\xa5\x5b") == 1, "the corrupted frame must hold only its own sync"
    frame[-1] ^= 0x40  # payload byte: the header check still passes, the message CRC does not
    return bytes(frame)


def stream_and_expected() -> tuple[bytes, list[bytes]]:
    frames = [bytes.fromhex(v["frame"]) for v in VECTORS]
    parts = [GARBAGE]
    for i, frame in enumerate(frames):
        parts.append(frame)
        if i == 2:
            parts.append(corrupted_frame())
        if i % 4 == 0:
            parts.append(GARBAGE)
    return b"".join(parts), frames


def random_chunks(data: bytes, rng: random.Random) -> list[bytes]:
    chunks, pos = [], 0
    while pos < len(data):
        size = rng.choice((1, 2, 3, rng.randint(1, 80), rng.randint(1, 2000)))
        chunks.append(data[pos:pos + size])
        pos += size
    return chunks


def feed_all(chunks: list[bytes]) -> tuple[list[uf.DecodedFrame], uf.DecoderStats, int]:
    decoder = uf.ub_decoder_new()
    delivered = [frame for chunk in chunks for frame in uf.ub_decoder_feed(decoder, chunk)]
    return delivered, uf.ub_decoder_stats(decoder), uf.ub_decoder_pending(decoder)


def test_decoder_one_shot_delivers_every_vector_and_counts_in_c() -> None:
    stream, frames = stream_and_expected()
    delivered, stats, pending = feed_all([stream])
    assert [d.frame for d in delivered] == frames
    assert [d.header for d in delivered] == [header_of(v) for v in VECTORS]
    assert stats.frames_ok == len(frames)
    assert stats.bytes_in == len(stream)
    assert stats.bytes_ok == sum(map(len, frames))
    assert stats.rejected["bad_crc"] == 1
    assert stats.bytes_in == stats.bytes_ok + stats.garbage_bytes + pending
    assert pending == 0


@pytest.mark.parametrize("seed", range(8))
def test_decoder_outcome_does_not_depend_on_chunking(seed: int) -> None:
    stream, frames = stream_and_expected()
    one_shot = feed_all([stream])
    chunked = feed_all(random_chunks(stream, random.Random(seed)))
    assert [d.frame for d in chunked[0]] == frames
    assert chunked == one_shot


def test_decoder_holds_an_unfinished_frame_until_its_last_byte() -> None:
    frame = bytes.fromhex(VECTORS[0]["frame"])
    decoder = uf.ub_decoder_new()
    assert uf.ub_decoder_feed(decoder, frame[:-1]) == []
    assert uf.ub_decoder_pending(decoder) == len(frame) - 1
    assert [d.frame for d in uf.ub_decoder_feed(decoder, frame[-1:])] == [frame]
    uf.ub_decoder_init(decoder)
    assert uf.ub_decoder_stats(decoder).bytes_in == 0 and uf.ub_decoder_pending(decoder) == 0


def test_rx_reason_names_come_from_c() -> None:
    names = [uf.ub_rx_reason_name(r) for r in range(uf.RX_REASON_COUNT)]
    assert names[0] == "bad_hdr_check" and "bad_crc" in names and len(set(names)) == len(names)
    assert uf.ub_rx_reason_name(uf.RX_REASON_COUNT) == "?"
