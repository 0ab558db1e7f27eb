"""Wrappers for ub_pubsub.h: publish/subscribe rows of a local entity."""

from __future__ import annotations

from typing import Any

from uavbus._bindings.ub_error import ensure
from uavbus._bindings.ub_node import entity_id, entity_name
from uavbus._ub import ffi, lib

MAX_PUBSUB_ROWS: int = lib.UB_MAX_PUBSUB_ROWS
_KINDS = {lib.UB_PS_PUBLICATION: "publication", lib.UB_PS_SUBSCRIPTION: "subscription"}
_STATES = {lib.UB_SUB_REQUESTING: "requesting", lib.UB_SUB_RECEIVING: "receiving", lib.UB_SUB_STOPPING: "stopping"}


def ub_pubsub_publish(node: Any, entity: int, instance: int, dest: str, period_ms: int, now_ms: int) -> int:
    return ensure(lib.ub_pubsub_publish(node, entity, instance, entity_id(dest), period_ms, now_ms),
                  f"publication of instance {instance} to {dest!r} every {period_ms} ms")


def ub_pubsub_subscribe(node: Any, entity: int, instance: int, source: str, period_ms: int, now_ms: int) -> int:
    return ensure(lib.ub_pubsub_subscribe(node, entity, instance, entity_id(source), period_ms, now_ms),
                  f"subscription to instance {instance} from {source!r} every {period_ms} ms")


def ub_pubsub_stop(node: Any, entity: int, row: int, now_ms: int) -> None:
    ensure(lib.ub_pubsub_stop(node, entity, row, now_ms), f"stopping row {row}")


def ub_pubsub_rows(node: Any, entity: int) -> list[tuple[int, dict[str, Any]]]:
    """(row index, fields) of every used row; `instance` is the catalogue index."""
    out = []
    for k in range(MAX_PUBSUB_ROWS):
        r = lib.ub_pubsub_row(node, entity, k)
        if r == ffi.NULL or r.kind == lib.UB_PS_FREE:
            continue
        kind = _KINDS.get(r.kind, "?")
        owner = bytes(r.owner)
        out.append((k, {
            "kind": kind, "instance": int(r.instance), "peer": entity_name(bytes(r.peer)),
            "owner": entity_name(owner) if any(owner) else None, "period_ms": int(r.period_ms),
            "state": _STATES.get(r.state, "?") if kind == "subscription" else None, "acked": bool(r.acked),
            "frames": int(r.frames), "lease_until_ms": int(r.lease_until_ms), "next_due_ms": int(r.next_due_ms),
            "last_data_ms": int(r.last_data_ms),
        }))
    return out
