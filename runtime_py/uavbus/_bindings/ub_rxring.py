"""Wrappers for ub_rxring.h: the delivery ring (records drained in one call) and ub_send_many().

The ring replaces the per-delivery `extern "Python"` callback (uavbus._bindings.ub_node.ub_py_delivery) on
the hot path: C appends one record per delivery to memory allocated here (owned by the returned Ring),
and drain() copies every record into one buffer with one call. Deliveries that find the ring full go to
the Python sink through the old callback (`spill`), counted, so nothing is lost and the order is the
ring's records, then the spilled ones.
"""

from __future__ import annotations

import struct
from typing import Any

from uavbus._bindings.ub_error import InvalidArgumentError, ensure
from uavbus._ub import ffi, lib

HEADER: int = lib.UB_RXREC_HEADER
# t_ms, instance, seq, entity, len, hop_limit, reserved, src_id, dest_id (ub_rxring.h, host order)
RECORD_HEADER = struct.Struct("=QIIiHBx12s12s")
assert RECORD_HEADER.size == HEADER
_COUNTERS = ("recorded", "drained", "spilled", "dropped", "high_water")


class Ring:
    """A ub_rxring_t with its record memory and a drain buffer of the same size (both owned here)."""

    __slots__ = ("c", "mem", "out", "stride", "capacity", "out_buf", "_attached")

    def __init__(self, capacity: int, image_cap: int) -> None:
        if capacity < 1 or image_cap < 0:
            raise InvalidArgumentError(f"ring of {capacity} records of {image_cap} bytes: both must be positive")
        self.stride = HEADER + (image_cap + 7) // 8 * 8
        self.c = ffi.new("ub_rxring_t *")
        self.mem = ffi.new("uint8_t[]", capacity * self.stride)
        self.out = ffi.new("uint8_t[]", capacity * self.stride)
        self.out_buf = ffi.buffer(self.out)
        ensure(lib.ub_rxring_init(self.c, self.mem, capacity * self.stride, self.stride), "ub_rxring_init")
        self.capacity = int(self.c.capacity)
        self._attached = False


def ub_rxring_attach(ring: Ring, node: Any, spill_handle: Any) -> None:
    """Installs the ring as the node's delivery hook; a full ring spills to ub_py_deliver(spill_handle)."""
    spill = lib.ub_py_deliver if spill_handle is not None else ffi.NULL
    ensure(lib.ub_rxring_attach(ring.c, node, spill, spill_handle if spill_handle is not None else ffi.NULL),
           "ub_rxring_attach")
    ring._attached = True


def ub_rxring_detach(ring: Ring) -> None:
    if ring._attached:
        lib.ub_rxring_detach(ring.c)
        ring._attached = False


def ub_rxring_pending(ring: Ring) -> int:
    return int(lib.ub_rxring_pending(ring.c))


def ub_rxring_drain(ring: Ring) -> int:
    """Moves every record into ring.out (ring.out_buf), oldest first, `ring.stride` apart; returns how many."""
    return int(lib.ub_rxring_drain(ring.c, ring.out, ring.capacity))


def ub_rxring_counters(ring: Ring) -> dict[str, int]:
    c = lib.ub_rxring_get_counters(ring.c)
    return {k: int(getattr(c, k)) for k in _COUNTERS}


def ub_send_many(node: Any, entity: int, instance: int, dest_id: Any, now_ms: int, offset: int, size: int,
                 values: bytes | bytearray | memoryview, n: int, what: str = "") -> int:
    """ub_send_many(): `n` frames, `values` holding n runs of `size` bytes written at `offset` of the bound
    storage before each. Returns the sum of links that accepted each frame."""
    if len(values) < n * size:
        raise InvalidArgumentError(f"send_many {what}: {len(values)} bytes of values for {n} x {size}")
    buf = ffi.from_buffer("uint8_t[]", values) if n * size else ffi.NULL
    rc = lib.ub_send_many(node, entity, instance, dest_id, now_ms, offset, size, buf, n)
    if rc < 0:
        ensure(int(rc), f"send_many {what}")
    return int(rc)
