"""Wrappers for ub_node.h: the router's set-up, I/O entry points, hooks and counters.

The delivery hook and the frame tap call back into Python through `extern "Python"` functions; the
`user` pointer is an `ffi.new_handle()` of a Python sink object (kept alive by its owner), whose
`on_deliver(entity, instance, src_id, dest_id, seq, now_ms, hop_limit)` / `on_tap(link_id, dir, frame, now_ms)` run inside
the C call. Sinks must not raise (cffi would only print the error): they queue and return.
"""

from __future__ import annotations

from typing import Any

from uavbus._bindings.ub_catalogue import ENTITY_ID_LEN, _c_name
from uavbus._bindings.ub_error import InvalidArgumentError, NotFoundError, ensure
from uavbus._ub import ffi, lib

MAX_ENTITIES: int = lib.UB_MAX_ENTITIES
MAX_LOCAL_ENTITIES: int = lib.UB_MAX_LOCAL_ENTITIES
MAX_NODE_LINKS: int = lib.UB_MAX_NODE_LINKS
MAX_LINKS_PER_ENTITY: int = lib.UB_MAX_LINKS_PER_ENTITY
DROP_REASONS: tuple[str, ...] = tuple(
    ffi.string(lib.ub_drop_reason_name(r)).decode("ascii") for r in range(lib.UB_DROP_REASON_COUNT))
RX_REASONS: tuple[str, ...] = tuple(
    ffi.string(lib.ub_rx_reason_name(r)).decode("ascii") for r in range(lib.UB_RX_REASON_COUNT))
_COUNTER_FIELDS = ("originated", "forwarded", "delivered", "admin_handled", "local_direct", "dedup_resets",
                   "dedup_evictions", "leases_expired", "replies_unmatched", "requests_limited", "leases_clamped",
                   "rows_evicted", "random_failures", "entities_added", "entities_removed", "links_added",
                   "links_removed", "rows_stopped", "admin_rows_stopped", "dedup_cleared", "membership_applied",
                   "membership_refused", "handovers", "nacks_relayed", "other_admin",
                   "inspect_served", "inspect_refused")


def entity_id(name: str) -> bytes:
    """The 12-byte entity ID of `name` (RangeError when longer than 12 characters)."""
    out = ffi.new("uint8_t[]", ENTITY_ID_LEN)
    ensure(lib.ub_entity_id(_c_name(name), out), f"entity name {name!r}")
    return bytes(ffi.buffer(out))


def entity_name(raw: bytes) -> str:
    """An entity ID as text: the name without its NUL padding."""
    return bytes(raw).rstrip(b"\0").decode("utf-8", "replace")


def ub_node_seq_seed(unix_us: int) -> int:
    """The first sequence number of a node started at wall-clock time `unix_us` (ub_node_seq_seed(): the
    microsecond clock mod 2^32, never 0), so a restarted process starts ahead of its predecessor's numbers."""
    return int(lib.ub_node_seq_seed(unix_us & 0xFFFFFFFFFFFFFFFF))


def ub_node_new(c_catalogue: Any, hop_limit: int = 0, first_seq: int = 0,
                timing: dict[str, int] | None = None, random_seed: int | None = None) -> Any:
    """A fresh node over `c_catalogue` (which must outlive it), freed with the returned cdata. Request ids
    come from the operating system (ub_random_os); `random_seed` makes them the node's seeded, guessable
    sequence instead (deterministic tests)."""
    node = ffi.new("ub_node_t *")
    opt = ffi.new("ub_node_options_t *")
    opt.hop_limit, opt.first_seq = hop_limit, first_seq
    if random_seed is None:
        opt.random = ffi.addressof(lib, "ub_random_os")
    else:
        opt.random_seed = random_seed
    for key, value in (timing or {}).items():
        if not hasattr(opt.timing, key):
            raise InvalidArgumentError(f"unknown pubsub timing field {key!r} (retry_ms, renew_ms, lease_ms, "
                                       "timeout_min_ms, stop_retries)")
        setattr(opt.timing, key, value)
    rc = lib.ub_node_init(node, c_catalogue, opt)
    if rc != 0 and c_catalogue != ffi.NULL:
        big = lib.ub_catalogue_oversize(c_catalogue, lib.ub_catalogue_payload_limit())
        if big != ffi.NULL:
            raise InvalidArgumentError(
                f"catalogue {ffi.string(c_catalogue.name).decode('utf-8', 'replace')!r}: type "
                f"{ffi.string(big.name).decode('utf-8', 'replace')!r} packs to {big.packed_size} bytes, more than this "
                f"runtime's payload limit of {lib.ub_catalogue_payload_limit()} bytes (UB_MAX_DIRECTORY); rebuild the "
                "runtime with a larger -DUB_MAX_DIRECTORY, or split the type (uavbus gen --max-payload names them all)")
    ensure(rc, "ub_node_init")
    return node


def ub_node_add_entity_name(node: Any, name: str, local: bool) -> int:
    return ensure(lib.ub_node_add_entity_name(node, _c_name(name), local), f"entity {name!r}")


def ub_node_remove_entity(node: Any, entity: int, now_ms: int) -> None:
    ensure(lib.ub_node_remove_entity(node, entity, now_ms), f"entity {entity} is local (local entities stay)")


def ub_node_remove_link(node: Any, link_id: int) -> None:
    ensure(lib.ub_node_remove_link(node, link_id), f"link {link_id} still has a transport: close its port first")


def ub_node_mask_pinned(node: Any, entity: int, dest: int) -> bool:
    return bool(lib.ub_node_mask_pinned(node, entity, dest))


def ub_node_get_mask(node: Any, entity: int, dest: int) -> int:
    out = ffi.new("uint8_t *")
    ensure(lib.ub_node_get_mask(node, entity, dest, out), f"mask of entity {entity} toward {dest}")
    return int(out[0])


def ub_node_find_entity(node: Any, name: str) -> int:
    return ensure(lib.ub_node_find_entity(node, entity_id(name)), f"entity {name!r} is not in the node's table")


def ub_node_add_link(node: Any, entity: int, index: int, name: str) -> int:
    return ensure(lib.ub_node_add_link(node, entity, index, _c_name(name)), f"link {name!r}")


def ub_node_find_link(node: Any, name: str) -> int:
    return ensure(lib.ub_node_find_link(node, _c_name(name)), f"link {name!r} is not a link of this node")


def ub_node_set_mask(node: Any, entity: int, dest: int, mask: int) -> None:
    ensure(lib.ub_node_set_mask(node, entity, dest, mask), f"mask of entity {entity} toward {dest}")


def ub_node_bind(node: Any, instance: int, storage: Any) -> None:
    ensure(lib.ub_node_bind(node, instance, storage), f"binding instance {instance}")


def ub_node_rx(node: Any, link_id: int, data: bytes, now_ms: int) -> int:
    return ensure(lib.ub_node_rx(node, link_id, data, len(data), now_ms), "ub_node_rx")


def ub_node_rx_frame(node: Any, link_id: int, frame: bytes, now_ms: int) -> None:
    ensure(lib.ub_node_rx_frame(node, link_id, frame, len(frame), now_ms), "ub_node_rx_frame")


def ub_node_rx_spans(node: Any, link_id: int, buf: bytes, spans: list[tuple[int, int]], now_ms: int) -> int:
    """ub_node_rx_frame() for each (offset, length) frame inside `buf`, in order, without copying a frame
    out of it (a batch of frames in one buffer: the Zenoh bridge's samples). Returns how many the router
    refused as invalid (each counted on the link by its reason, as ub_node_rx_frame's errors)."""
    base = ffi.from_buffer("uint8_t[]", buf)
    rx = lib.ub_node_rx_frame
    return sum(1 for at, size in spans if rx(node, link_id, base + at, size, now_ms) < 0)


def ub_node_send_data(node: Any, entity: int, instance: int, dest: str, now_ms: int) -> int:
    return ensure(lib.ub_node_send_data(node, entity, instance, entity_id(dest), now_ms), f"send to {dest!r}")


def entity_id_c(name: str) -> Any:
    """`name`'s entity ID as C memory, resolved once for ub_node_send_data_id() (the sender keeps it alive)."""
    return ffi.new("uint8_t[]", entity_id(name))


def ub_node_send_data_id(node: Any, entity: int, instance: int, dest_id: Any, now_ms: int, what: str = "") -> int:
    """ub_node_send_data() to an ID from entity_id_c(): the pre-resolved path of high-rate senders (no name
    lookup, no message built unless it fails)."""
    n = lib.ub_node_send_data(node, entity, instance, dest_id, now_ms)
    if n < 0:
        ensure(n, f"send {what}")
    return n


def storage_new(size: int) -> Any:
    """Zeroed C memory of `size` bytes (at least 1) for ub_node_bind(): a directory's wire image."""
    return ffi.new("uint8_t[]", max(size, 1))


def storage_buffer(storage: Any) -> Any:
    """A writable buffer over C memory from storage_new()."""
    return ffi.buffer(storage)


def new_handle(obj: Any) -> Any:
    """A handle on `obj` for set_deliver_sink()/set_tap_sink() (keep both alive as long as C may call)."""
    return ffi.new_handle(obj)


def ub_node_link_set_compact(node: Any, link_id: int, compact: bool, what: str) -> Any:
    """Sets link `link_id` to the compact encoding (a fresh ub_compact_t, returned: the link points at it,
    keep it alive) or back to full frames (returns None)."""
    state = ffi.new("ub_compact_t *") if compact else ffi.NULL
    ensure(lib.ub_node_link_set_compact(node, link_id, state, ffi.NULL), what)
    return state if compact else None


PRIO_CLASSES: tuple[str, ...] = tuple(
    ffi.string(lib.ub_prio_class_name(c)).decode("ascii") for c in range(lib.UB_PRIO_CLASSES))


def ub_node_set_content_classes(node: Any, classes: list[int] | None, what: str) -> Any:
    """Gives every catalogue instance its priority class (indices into PRIO_CLASSES), or none (None). Returns the
    table the C node points to (keep it alive), or None."""
    if classes is None:
        ensure(lib.ub_node_set_content_classes(node, ffi.NULL, 0), what)
        return None
    table = ffi.new("uint8_t[]", classes) if classes else ffi.new("uint8_t[]", 1)
    ensure(lib.ub_node_set_content_classes(node, table, len(classes)), what)
    return table


def ub_node_link_set_mtu(node: Any, link_id: int, mtu: int, what: str) -> None:
    ensure(lib.ub_node_link_set_mtu(node, link_id, mtu), what)


def ub_node_tick(node: Any, now_ms: int) -> None:
    lib.ub_node_tick(node, now_ms)


def ub_node_counters(node: Any) -> dict[str, Any]:
    """The node-wide counters; `drops` keyed by ub_drop_reason_name()."""
    c = lib.ub_node_counters(node)
    out: dict[str, Any] = {k: int(getattr(c, k)) for k in _COUNTER_FIELDS}
    out["drops"] = {DROP_REASONS[r]: int(c.drops[r]) for r in range(len(DROP_REASONS))}
    return out


def ub_node_links(node: Any) -> list[int]:
    """The ids of every link slot in use."""
    return [link_id for link_id in range(MAX_NODE_LINKS) if lib.ub_node_link_name(node, link_id) != ffi.NULL]


def link_name(node: Any, link_id: int) -> str:
    """The name of link slot `link_id` ("link<id>" if there is no such slot)."""
    name = lib.ub_node_link_name(node, link_id)
    return f"link{link_id}" if name == ffi.NULL else ffi.string(name).decode("utf-8")


def link_counters(node: Any, link_id: int) -> dict[str, Any]:
    """One slot's counters: frames/bytes in and out, drops by reason, bad frames by decoder reason
    (stream decoder and datagram rejections together, as ub_node_link_bad_frames() adds them)."""
    c = lib.ub_node_link_counters(node, link_id)
    if c == ffi.NULL:
        raise NotFoundError(f"link {link_id} is not a link slot in use")
    kind = lib.ub_node_link_kind(node, link_id)
    return {
        "name": link_name(node, link_id),
        "transport": ffi.string(kind).decode("ascii") if kind != ffi.NULL else None,
        "frames_in": int(c.frames_in), "bytes_in": int(c.bytes_in),
        "frames_out": int(c.frames_out), "bytes_out": int(c.bytes_out),
        "frames_accepted": int(c.frames_accepted),
        "require_signed": bool(lib.ub_node_link_requires_signed(node, link_id)),
        "encrypt": bool(lib.ub_node_link_encrypts(node, link_id)),
        "mtu": int(lib.ub_node_link_mtu(node, link_id)), **compact_info(node, link_id),
        "drops": {DROP_REASONS[r]: int(c.drops[r]) for r in range(len(DROP_REASONS))},
        "bad_frames": {RX_REASONS[r]: int(lib.ub_node_link_bad_frames(node, link_id, r))
                       for r in range(len(RX_REASONS))},
    }


COMPACT_STATS = ("tx_frames", "tx_bytes", "tx_full_bytes", "tx_full_ids", "tx_seq32", "rx_frames", "rx_bytes",
                 "garbage_bytes", "hello_tx", "hello_rx", "hello_bad", "peer_restarts", "peer_lists", "dict_changes",
                 "dict_limited")


def compact_info(node: Any, link_id: int) -> dict[str, Any]:
    """A link's encoding, and for a compact one its counters and whether the dictionaries are agreed."""
    s = lib.ub_node_link_compact_stats(node, link_id)
    if s == ffi.NULL:
        return {"encoding": "full"}
    stats: dict[str, Any] = {k: int(getattr(s, k)) for k in COMPACT_STATS}
    stats["rejected"] = {RX_REASONS[r]: int(s.rejected[r]) for r in range(len(RX_REASONS))}
    agreed = bool(lib.ub_compact_agreed(lib.ub_node_link_compact(node, link_id)))
    return {"encoding": "compact", "agreed": agreed, "compact": stats}


def ub_node_entity_id(node: Any, entity: int) -> bytes:
    """The 12-byte ID of entity-table row `entity` (NotFoundError if the row is not in use)."""
    if not lib.ub_node_entity_in_use(node, entity):
        raise NotFoundError(f"entity {entity} is not in the node's table")
    return bytes(ffi.buffer(lib.ub_node_entity_id(node, entity), ENTITY_ID_LEN))


def ub_node_entity_is_local(node: Any, entity: int) -> bool:
    return bool(lib.ub_node_entity_is_local(node, entity))


def ub_node_entities(node: Any) -> list[dict[str, Any]]:
    """The entity table: index, name, local, and for local entities their links (link[i] names)."""
    out = []
    for index in range(MAX_ENTITIES):
        if not lib.ub_node_entity_in_use(node, index):
            continue
        local = bool(lib.ub_node_entity_is_local(node, index))
        entry: dict[str, Any] = {"index": index, "name": entity_name(ub_node_entity_id(node, index)), "local": local}
        if local:
            links: list[str | None] = []
            for i in range(MAX_LINKS_PER_ENTITY):
                link_id = lib.ub_node_entity_link(node, index, i)
                links.append(link_name(node, link_id) if link_id >= 0 else None)
            while links and links[-1] is None:
                links.pop()
            entry["links"] = links
        out.append(entry)
    return out


def set_deliver_sink(node: Any, handle: Any) -> None:
    """Routes the delivery hook to `ffi.from_handle(handle).on_deliver`; None removes it."""
    if handle is None:
        lib.ub_node_set_deliver_hook(node, ffi.NULL, ffi.NULL)
    else:
        lib.ub_node_set_deliver_hook(node, lib.ub_py_deliver, handle)


def set_tap_sink(node: Any, handle: Any) -> None:
    """Routes the frame tap to `ffi.from_handle(handle).on_tap`; None removes it."""
    if handle is None:
        lib.ub_node_set_tap(node, ffi.NULL, ffi.NULL)
    else:
        lib.ub_node_set_tap(node, lib.ub_py_tap, handle)


@ffi.def_extern()
def ub_py_deliver(user: Any, entity: int, instance: int, h: Any, now_ms: int) -> None:
    # Only what a delivery reports (source, destination, sequence), copied: `h` lives for this call.
    ffi.from_handle(user).on_deliver(entity, instance, ffi.buffer(h.src_id)[:], ffi.buffer(h.dest_id)[:], h.seq,
                                     now_ms, h.hop_limit)


@ffi.def_extern()
def ub_py_tap(user: Any, link_id: int, direction: int, frame: Any, length: int, now_ms: int) -> None:
    # `frame` is valid only during the call: copy it.
    ffi.from_handle(user).on_tap(link_id, direction, bytes(ffi.buffer(frame, length)), now_ms)
