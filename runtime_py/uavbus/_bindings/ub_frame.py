"""Wrappers for ub_frame.h: build and verify frames, CRC-32C, and the streaming decoder.

The decoder is the C state machine itself: Python only hands it bytes and collects what its
callback delivers, so Python never parses or verifies a frame on its own.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from uavbus._bindings.ub_error import InvalidArgumentError, RangeError, ensure
from uavbus._ub import ffi, lib

FRAME_HEADER_LEN: int = lib.UB_FRAME_HEADER_LEN
FRAME_MAX: int = lib.UB_FRAME_MAX
MAX_PAYLOAD: int = lib.UB_MAX_PAYLOAD
DEFAULT_HOP_LIMIT: int = lib.UB_DEFAULT_HOP_LIMIT
RX_REASON_COUNT: int = lib.UB_RX_REASON_COUNT
FLAG_SIGNED: int = lib.UB_FRAME_FLAG_SIGNED
FLAG_ENCRYPTED: int = lib.UB_FRAME_FLAG_ENCRYPTED
FLAG_ORIGIN: int = lib.UB_FRAME_FLAG_ORIGIN
TRAILER_MAX: int = lib.UB_FRAME_TRAILER_MAX
ADMIN_DATA: int = lib.UB_ADMIN_DATA  # the admin code of a DATA frame (ub_wire.h)
_U16_MAX = 0xFFFF


@dataclass(frozen=True)
class FrameHeader:
    """Host form of ub_frame_header_t. `msg_type` is filled by parsing; finishing ignores it."""

    dir_id: bytes
    dest_id: bytes
    src_id: bytes
    admin: int = lib.UB_ADMIN_DATA
    hop_limit: int = DEFAULT_HOP_LIMIT
    payload_size: int = 0
    seq: int = 0
    fingerprint: int = 0
    msg_type: int = lib.UB_MSG_TYPE_PUBSUB
    flags: int = 0          # 0, FLAG_SIGNED or FLAG_ENCRYPTED, maybe | FLAG_ORIGIN (the version byte's high nibble)
    key_id: int = 0         # from the trailer of a flagged frame
    counter_hi: int = 0     # high 16 bits of the 48-bit counter (seq is the low 32)
    origin_hop0: int = 0    # origin block (FLAG_ORIGIN): the hop limit the origin sent
    origin_tag: bytes = bytes(8)  # ... and the origin tag

    @property
    def counter(self) -> int:
        """The 48-bit freshness counter: counter_hi << 32 | seq."""
        return self.counter_hi << 32 | self.seq


@dataclass(frozen=True)
class DecodedFrame:
    """One frame the C decoder verified and delivered: its parsed header and its bytes."""

    header: FrameHeader
    frame: bytes


@dataclass(frozen=True)
class DecoderStats:
    """Copy of ub_decoder_stats_t; `rejected` is keyed by ub_rx_reason_name()."""

    frames_ok: int
    bytes_in: int
    bytes_ok: int
    garbage_bytes: int
    rejected: dict[str, int]


def _copy_id(field: Any, value: bytes, what: str) -> None:
    if len(value) != len(field):
        raise InvalidArgumentError(f"{what} must be {len(field)} bytes, got {len(value)}")
    ffi.memmove(field, value, len(value))


def _header_to_c(h: FrameHeader) -> Any:
    c = ffi.new("ub_frame_header_t *")
    _copy_id(c.dir_id, h.dir_id, "dir_id")
    _copy_id(c.dest_id, h.dest_id, "dest_id")
    _copy_id(c.src_id, h.src_id, "src_id")
    _copy_id(c.origin_tag, h.origin_tag, "origin_tag")
    try:
        c.msg_type, c.admin, c.hop_limit = h.msg_type, h.admin, h.hop_limit
        c.payload_size, c.seq, c.fingerprint = h.payload_size, h.seq, h.fingerprint
        c.flags, c.key_id, c.counter_hi = h.flags, h.key_id, h.counter_hi
        c.origin_hop0 = h.origin_hop0
    except OverflowError as exc:
        raise RangeError(f"header field out of range: {exc}") from exc
    return c


def _header_from_c(c: Any) -> FrameHeader:
    return FrameHeader(
        dir_id=bytes(c.dir_id), dest_id=bytes(c.dest_id), src_id=bytes(c.src_id),
        admin=c.admin, hop_limit=c.hop_limit, payload_size=c.payload_size, seq=c.seq,
        fingerprint=c.fingerprint, msg_type=c.msg_type, flags=c.flags, key_id=c.key_id, counter_hi=c.counter_hi,
        origin_hop0=c.origin_hop0, origin_tag=bytes(c.origin_tag),
    )


def ub_frame_finish(h: FrameHeader, payload: bytes) -> bytes:
    """The complete frame for header `h` and `payload` (`h.payload_size` is taken from the payload).

    Raises RangeError for a payload above UB_MAX_PAYLOAD or a hop limit of 0 (the C checks)."""
    if len(payload) > _U16_MAX:
        raise RangeError(f"payload of {len(payload)} bytes does not fit the 16-bit payload_size")
    c = _header_to_c(h)
    c.payload_size = len(payload)
    frame = ffi.new("uint8_t[]", FRAME_HEADER_LEN + len(payload))
    ffi.memmove(frame + FRAME_HEADER_LEN, payload, len(payload))
    n = ensure(lib.ub_frame_finish(frame, len(frame), c), "ub_frame_finish")
    return bytes(ffi.buffer(frame, n))


def ub_frame_parse(frame: bytes) -> FrameHeader:
    """Verifies one complete frame and returns its header; raises TruncatedError, ChecksumError or
    InvalidArgumentError as ub_frame_parse() reports."""
    c = ffi.new("ub_frame_header_t *")
    ensure(lib.ub_frame_parse(frame, len(frame), c), "ub_frame_parse")
    return _header_from_c(c)


def ub_frame_set_hop_limit(frame: bytes, hop_limit: int) -> bytes:
    """A copy of a verified `frame` with its hop limit rewritten and both checks recomputed."""
    if not 0 <= hop_limit <= 0xFF:
        raise RangeError(f"hop limit {hop_limit} does not fit one byte")
    rewritten = bytearray(frame)
    ensure(lib.ub_frame_set_hop_limit(ffi.from_buffer("uint8_t[]", rewritten), len(rewritten), hop_limit),
           "ub_frame_set_hop_limit")
    return bytes(rewritten)


def ub_rx_reason_name(reason: int) -> str:
    """The decoder's name for a rejection reason ("bad_hdr_check", ...), "?" when out of range."""
    return ffi.string(lib.ub_rx_reason_name(reason)).decode("ascii")


def ub_crc32c(data: bytes) -> int:
    return int(lib.ub_crc32c(data, len(data)))


def ub_crc32c_update(crc: int, data: bytes) -> int:
    return int(lib.ub_crc32c_update(crc, data, len(data)))


def ub_decoder_new() -> Any:
    """A fresh ub_decoder_t, owned by the returned cdata (freed with it; the C side holds nothing)."""
    decoder = ffi.new("ub_decoder_t *")
    lib.ub_decoder_init(decoder)
    return decoder


def ub_decoder_init(decoder: Any) -> None:
    """Empties `decoder` and zeroes its counters."""
    lib.ub_decoder_init(decoder)


@ffi.def_extern()
def ub_py_frame_sink(user: Any, h: Any, frame: Any, frame_len: int) -> None:
    # `frame` points into C memory valid only during the call, so copy it out now.
    sink: list[DecodedFrame] = ffi.from_handle(user)
    sink.append(DecodedFrame(_header_from_c(h), bytes(ffi.buffer(frame, frame_len))))


def ub_decoder_feed(decoder: Any, data: bytes) -> list[DecodedFrame]:
    """Feeds `data` to the C decoder; returns the frames it delivered during this call, in order."""
    delivered: list[DecodedFrame] = []
    handle = ffi.new_handle(delivered)  # kept alive by this frame until the C call returns
    count = lib.ub_decoder_feed(decoder, data, len(data), lib.ub_py_frame_sink, handle)
    if count != len(delivered):
        raise RuntimeError(f"decoder reported {count} frames but delivered {len(delivered)}")
    return delivered


def ub_decoder_pending(decoder: Any) -> int:
    return int(lib.ub_decoder_pending(decoder))


def ub_decoder_stats(decoder: Any) -> DecoderStats:
    """A snapshot of the C decoder's counters."""
    s = decoder.stats
    return DecoderStats(
        frames_ok=s.frames_ok, bytes_in=s.bytes_in, bytes_ok=s.bytes_ok, garbage_bytes=s.garbage_bytes,
        rejected={ub_rx_reason_name(r): s.rejected[r] for r in range(len(s.rejected))},
    )
