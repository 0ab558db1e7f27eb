"""Wrappers for ub_admin.h: the global administration table attached to one local entity."""

from __future__ import annotations

from typing import Any

from uavbus._bindings.ub_error import ensure
from uavbus._bindings.ub_node import entity_id, entity_name
from uavbus._ub import ffi, lib

ROW_TYPES = {"publication": lib.UB_ADMIN_ROW_PUBLICATION, "subscription": lib.UB_ADMIN_ROW_SUBSCRIPTION}
_ROW_TYPE_NAMES = {v: k for k, v in ROW_TYPES.items()}
MAX_ADMIN_ROWS: int = lib.UB_MAX_ADMIN_ROWS


def nack_reason_name(reason: int) -> str | None:
    """The C name of a NACK reason ("table_full", "not_authorized", "limit", ...); None for no NACK."""
    if reason == lib.UB_NACK_NONE:
        return None
    return ffi.string(lib.ub_nack_reason_name(reason)).decode("ascii")


def ub_admin_new(node: Any, entity: int, options: dict[str, int] | None = None) -> Any:
    """A table attached to local entity `entity`; the caller keeps the cdata (and the node) alive."""
    adm = ffi.new("ub_admin_t *")
    opt = ffi.new("ub_admin_options_t *")
    for key, value in (options or {}).items():
        setattr(opt, key, value)
    ensure(lib.ub_admin_init(adm, node, entity, opt), f"administration table on entity {entity}")
    return adm


def ub_admin_add_row(adm: Any, instance: int, source: str, destination: str, period_ms: int, kind: str) -> int:
    spec = ffi.new("ub_admin_row_spec_t *")
    spec.instance, spec.period_ms = instance, period_ms
    ffi.memmove(spec.source, entity_id(source), len(spec.source))
    ffi.memmove(spec.destination, entity_id(destination), len(spec.destination))
    spec.type = ROW_TYPES[kind]
    return ensure(lib.ub_admin_add_row(adm, spec), f"admin row {source}->{destination} every {period_ms} ms")


def ub_admin_set_active(adm: Any, row: int, active: bool, now_ms: int) -> None:
    ensure(lib.ub_admin_set_active(adm, row, active, now_ms), f"admin row {row}")


def ub_admin_remove_row(adm: Any, row: int) -> None:
    ensure(lib.ub_admin_remove_row(adm, row), f"admin row {row}")


def ub_admin_row_status(adm: Any, row: int) -> dict[str, Any]:
    info = ffi.new("ub_admin_row_info_t *")
    ensure(lib.ub_admin_row_status(adm, row, info), f"admin row {row}")
    s = info.spec
    return {
        "row": row, "instance": int(s.instance), "source": entity_name(bytes(s.source)),
        "destination": entity_name(bytes(s.destination)), "period_ms": int(s.period_ms),
        "kind": _ROW_TYPE_NAMES.get(s.type, "?"),
        "status": ffi.string(lib.ub_admin_status_name(info.status)).decode("ascii"),
        "active": bool(info.active_flag), "nack_reason": nack_reason_name(info.nack_reason),
        "nack_relayed": bool(info.nack_relayed),
        "request_id": int(info.request_id), "attempts": int(info.attempts), "acked_at_ms": int(info.acked_at_ms),
        "active_at_ms": int(info.active_at_ms), "last_ack_ms": int(info.last_ack_ms),
        "last_data_ms": int(info.last_data_ms),
    }


def ub_admin_detach(adm: Any) -> None:
    lib.ub_admin_detach(adm)
