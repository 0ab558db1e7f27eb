"""Wrappers for ub_inspect.h: remote inspection requests and their results, table records decoded."""

from __future__ import annotations

import struct
from typing import Any

from uavbus._bindings.ub_admin import nack_reason_name
from uavbus._bindings.ub_error import InvalidArgumentError, ensure
from uavbus._bindings.ub_node import entity_id, entity_name
from uavbus._ub import ffi, lib

OPS = {"read": lib.UB_INSPECT_READ, "write": lib.UB_INSPECT_WRITE, "list": lib.UB_INSPECT_LIST,
       "set_period": lib.UB_INSPECT_SET_PERIOD, "set_mask": lib.UB_INSPECT_SET_MASK,
       "admin_row": lib.UB_INSPECT_ADMIN_ROW}
TABLES = {"entities": lib.UB_INSPECT_ENTITIES, "links": lib.UB_INSPECT_LINKS, "pubsub": lib.UB_INSPECT_PUBSUB,
          "admin": lib.UB_INSPECT_ADMIN}
ADMIN_FIELDS = {"period": lib.UB_INSPECT_ADMIN_PERIOD, "active": lib.UB_INSPECT_ADMIN_ACTIVE}
STATUS = {lib.UB_INSPECT_PENDING: "pending", lib.UB_INSPECT_DONE: "done", lib.UB_INSPECT_FAILED: "failed"}
CHUNK = int(lib.UB_INSPECT_CHUNK)
END = int(lib.UB_INSPECT_END)
RECORD_SIZE = {"entities": lib.UB_INSPECT_ENTITY_REC, "links": lib.UB_INSPECT_LINK_REC,
               "pubsub": lib.UB_INSPECT_PUBSUB_REC, "admin": lib.UB_INSPECT_ADMIN_REC}
_PS_KIND = {1: "publication", 2: "subscription"}
_ADMIN_TYPE = {0: "publication", 1: "subscription"}


def ub_inspect_new(node: Any, entity: int, retry_ms: int = 0, max_retries: int = 0) -> Any:
    c = ffi.new("ub_inspect_t *")
    opt = ffi.new("ub_inspect_options_t *")
    opt.retry_ms, opt.max_retries = retry_ms, max_retries
    ensure(lib.ub_inspect_init(c, node, entity, opt), f"inspection requester on entity {entity}")
    return c


def spec(op: str, target: str, *, arg: int = 0, offset: int = 0, value: int = 0, instance: int = 0,
         subject: str = "", data: bytes = b"") -> Any:
    if op not in OPS:
        raise InvalidArgumentError(f"inspection op {op!r}: one of {', '.join(OPS)}")
    s = ffi.new("ub_inspect_spec_t *")
    s.op, s.arg, s.offset, s.value, s.instance = OPS[op], arg, offset, value, instance
    s.target = entity_id(target)
    if subject:
        s.subject = entity_id(subject)
    if len(data) > CHUNK:
        raise InvalidArgumentError(f"{len(data)} bytes to write: at most {CHUNK} per request")
    s.len = len(data)
    ffi.memmove(s.data, data, len(data))
    return s


def ub_inspect_request(c: Any, s: Any, now_ms: int) -> int:
    return ensure(lib.ub_inspect_request(c, s, now_ms), "inspection request (bad arguments, or too many pending)")


def ub_inspect_result(c: Any, row: int) -> dict[str, Any]:
    r = ffi.new("ub_inspect_result_t *")
    ensure(lib.ub_inspect_result(c, row, r), f"inspection request {row}")
    return {"status": STATUS.get(r.status, "?"), "reason": nack_reason_name(r.nack_reason),
            "changed": bool(r.changed), "attempts": int(r.attempts), "sent_ms": int(r.sent_ms),
            "done_ms": int(r.done_ms), "total": int(r.total), "next": int(r.next),
            "data": bytes(ffi.buffer(r.data, r.len))}


def ub_inspect_forget(c: Any, row: int) -> None:
    ensure(lib.ub_inspect_forget(c, row), f"inspection request {row}")


def ub_inspect_detach(c: Any) -> None:
    lib.ub_inspect_detach(c)


COUNTER_FIELDS = ("sent", "done", "failed", "unmatched_replies")


def ub_inspect_counters(c: Any) -> dict[str, int]:
    k = lib.ub_inspect_counters(c)
    return {f: int(getattr(k, f)) for f in COUNTER_FIELDS}


def _mask_text(mask: int) -> str:
    out = ffi.new("char[]", 11)
    lib.ub_link_mask_format(mask, out)
    return ffi.string(out).decode("ascii")


def decode_records(table: str, data: bytes, dir_name: Any) -> list[dict[str, Any]]:
    """Table records (docs/inspect.md) as dicts; `dir_name(dir_id)` names a content ID."""
    size = RECORD_SIZE[table]
    out: list[dict[str, Any]] = []
    for k in range(0, len(data) - size + 1, size):
        p = data[k:k + size]
        if table == "entities":
            out.append({"entity": entity_name(p[0:12]), "local": bool(p[12]), "mask": _mask_text(p[13]),
                        "pinned": bool(p[14])})
        elif table == "links":
            fin, fout, bin_, bout, drops, acc = struct.unpack_from("<6I", p, 36)
            out.append({"link": p[0:32].rstrip(b"\0").decode("utf-8", "replace"), "index": p[32],
                        "attached": bool(p[33]), "frames_in": fin, "frames_out": fout, "bytes_in": bin_,
                        "bytes_out": bout, "drops": drops, "accepted": acc})
        elif table == "pubsub":
            row, kind, state = struct.unpack_from("<HBB", p, 0)
            period, frames = struct.unpack_from("<II", p, 44)
            out.append({"row": row, "kind": _PS_KIND.get(kind, "?"), "state": state,
                        "content": dir_name(p[4:20]), "peer": entity_name(p[20:32]),
                        "owner": entity_name(p[32:44]) or None, "period_ms": period, "frames": frames})
        else:
            row, typ, status = struct.unpack_from("<HBB", p, 0)
            (period,) = struct.unpack_from("<I", p, 44)
            out.append({"row": row, "type": _ADMIN_TYPE.get(typ, "?"),
                        "status": ffi.string(lib.ub_admin_status_name(status)).decode("ascii"),
                        "content": dir_name(p[4:20]), "source": entity_name(p[20:32]),
                        "destination": entity_name(p[32:44]), "period_ms": period, "active": bool(p[48]),
                        "reason": nack_reason_name(p[49])})
    return out
