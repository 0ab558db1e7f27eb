"""Wrappers for ub_member.h: membership requests over the bus, and applying one locally."""

from __future__ import annotations

from typing import Any

from uavbus._bindings.ub_admin import nack_reason_name
from uavbus._bindings.ub_error import InvalidArgumentError, ensure
from uavbus._bindings.ub_node import entity_id, entity_name
from uavbus._ub import ffi, lib

OPS = {"add_entity": lib.UB_MEMBER_ADD_ENTITY, "remove_entity": lib.UB_MEMBER_REMOVE_ENTITY,
       "set_mask": lib.UB_MEMBER_SET_MASK, "add_link": lib.UB_MEMBER_ADD_LINK,
       "remove_link": lib.UB_MEMBER_REMOVE_LINK}
_OP_NAMES = {v: k for k, v in OPS.items()}
_STATUS = {lib.UB_MEMBER_PENDING: "pending", lib.UB_MEMBER_DONE: "done", lib.UB_MEMBER_FAILED: "failed"}


def spec(op: str, target: str = "", subject: str = "", mask: int = 0, link_index: int = 0, link_name: str = "",
         port_spec: str = "") -> Any:
    if op not in OPS:
        raise InvalidArgumentError(f"membership op {op!r}: one of {', '.join(OPS)}")
    s = ffi.new("ub_member_spec_t *")
    s.op = OPS[op]
    if target:
        s.target = entity_id(target)
    if subject:
        s.subject = entity_id(subject)
    s.mask, s.link_index = mask, link_index
    for field, text, cap in (("link_name", link_name, len(s.link_name)), ("port_spec", port_spec, len(s.port_spec))):
        raw = text.encode("utf-8")
        if len(raw) >= cap:
            raise InvalidArgumentError(f"{field} {text!r} is longer than {cap - 1} bytes")
        setattr(s, field, raw)
    return s


def ub_member_new(node: Any, entity: int, retry_ms: int = 0, max_retries: int = 0) -> Any:
    m = ffi.new("ub_member_t *")
    opt = ffi.new("ub_member_options_t *")
    opt.retry_ms, opt.max_retries = retry_ms, max_retries
    ensure(lib.ub_member_init(m, node, entity, opt), f"membership requester on entity {entity}")
    return m


def ub_member_request(m: Any, s: Any, now_ms: int) -> int:
    return ensure(lib.ub_member_request(m, s, now_ms), "membership request (check the names; or too many pending)")


def ub_member_status(m: Any, row: int) -> dict[str, Any]:
    info = ffi.new("ub_member_info_t *")
    ensure(lib.ub_member_status(m, row, info), f"membership request {row}")
    out: dict[str, Any] = {
        "row": row, "op": _OP_NAMES.get(info.spec.op, "?"), "target": entity_name(bytes(info.spec.target)),
        "status": _STATUS.get(info.status, "?"), "attempts": int(info.attempts),
        "request_id": int(info.request_id), "done_ms": int(info.done_ms),
    }
    if info.spec.op in (lib.UB_MEMBER_ADD_LINK, lib.UB_MEMBER_REMOVE_LINK):
        out["link"] = ffi.string(info.spec.link_name).decode("utf-8")
    else:
        out["subject"] = entity_name(bytes(info.spec.subject))
    if info.status == lib.UB_MEMBER_DONE:
        out["changed"] = bool(info.changed)
    if info.status == lib.UB_MEMBER_FAILED:
        out["reason"] = nack_reason_name(info.nack_reason) if info.nack_reason else "no_answer"
    return out


def ub_member_forget(m: Any, row: int) -> None:
    ensure(lib.ub_member_forget(m, row), f"membership request {row}")


def ub_member_detach(m: Any) -> None:
    lib.ub_member_detach(m)


def ub_member_apply(node: Any, entity: int, s: Any, now_ms: int) -> tuple[str | None, bool]:
    """Applies `s` here; (NACK reason name or None, changed)."""
    changed = ffi.new("bool *")
    reason = int(lib.ub_member_apply(node, entity, s, now_ms, changed))
    return nack_reason_name(reason), bool(changed[0])
