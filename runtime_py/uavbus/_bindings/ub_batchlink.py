"""Wrappers for ub_batchlink.h: frames in batches, packed and unpacked in C (the Zenoh bridge's samples)."""

from __future__ import annotations

from typing import Any

from uavbus._bindings.ub_error import ensure
from uavbus._ub import ffi, lib

OK: int = lib.UB_BATCH_OK
# ub_batch_status_t -> the bridge counter that counts a refused payload.
REASONS: dict[int, str] = {lib.UB_BATCH_FOREIGN: "batch_foreign", lib.UB_BATCH_OTHER_VERSION: "batch_version",
                           lib.UB_BATCH_MALFORMED: "batch_malformed"}


class BatchLink:
    """A ub_batchlink_t and the memory it packs into (owned here, alive as long as this object)."""

    def __init__(self, cap: int, ends_cap: int, batch_limit: int) -> None:
        self.c = ffi.new("ub_batchlink_t *")
        self.buf = ffi.new("uint8_t[]", cap)
        self.ends = ffi.new("uint32_t[]", ends_cap)
        ensure(lib.ub_batchlink_init(self.c, self.buf, cap, self.ends, ends_cap, batch_limit),
               f"ub_batchlink_init (cap {cap}, ends {ends_cap}, batch limit {batch_limit})")


def ub_batchlink_attach(bl: BatchLink, node: Any, link_id: int) -> None:
    ensure(lib.ub_batchlink_attach(bl.c, node, link_id), f"attaching a batch link to link {link_id}")


def ub_batchlink_take(bl: BatchLink) -> tuple[Any, list[int]]:
    """The pending batches, without a copy: a view of the link's memory (`view[a:b]` copies out bytes) and
    each batch's end offset; the link is emptied. The view is valid until the node runs again (its next
    send writes over it)."""
    c = bl.c
    n = c.n
    if not n:
        return b"", []
    view = ffi.buffer(bl.buf, c.len)
    ends = ffi.unpack(bl.ends, n)
    lib.ub_batchlink_clear(c)
    return view, ends


def pending_bytes_ptr(bl: BatchLink) -> Any:
    """A `size_t *` to the link's pending bytes (for ub_ports_drain()'s `pending`), valid while `bl` lives."""
    return ffi.addressof(bl.c, "len")


def ub_batch_check(payload: bytes) -> tuple[int, int]:
    """(status, frames) of a received payload, checked whole (ub_batch_status_t)."""
    count = ffi.new("size_t *")
    st = lib.ub_batch_check(payload, len(payload), count)
    return int(st), int(count[0])


def ub_batch_rx(node: Any, link_id: int, payload: bytes, now_ms: int, out: Any = None) -> tuple[int, int, int]:
    """(status, frames handed to the node, frames it refused) for one received payload. `out`: a
    `size_t[2]` to reuse (one per caller), else allocated."""
    out = out if out is not None else ffi.new("size_t[2]")
    st = lib.ub_batch_rx(node, link_id, payload, len(payload), now_ms, out, out + 1)
    return st, out[0], out[1]


def new_counts() -> Any:
    return ffi.new("size_t[2]")
