"""Wrappers for ub_log.h: the C binary-log writer, installed as the node's C tap (no Python per frame)."""

from __future__ import annotations

from typing import Any

from uavbus._bindings.ub_catalogue import _c_name
from uavbus._bindings.ub_error import ensure
from uavbus._ub import ffi, lib


def ub_log_open(fd: int, node: Any, node_name: str, record_tx: bool, start_unix_ms: int, start_t_ms: int) -> Any:
    log = ffi.new("ub_log_t *")
    ensure(lib.ub_log_open(log, fd, node, _c_name(node_name), record_tx, start_unix_ms, start_t_ms),
           f"log for node {node_name!r}")
    return log


def ub_log_install(node: Any, log: Any) -> None:
    """Makes `log` the node's frame tap (`log` must stay alive until removed)."""
    lib.ub_node_set_tap(node, lib.ub_log_tap, log)


def ub_log_stats(log: Any) -> dict[str, int]:
    s = lib.ub_log_stats(log)
    return {"records": int(s.records), "bytes": int(s.bytes), "write_errors": int(s.write_errors),
            "skipped_tx": int(s.skipped_tx), "last_errno": int(s.last_errno)}


def ub_log_close(log: Any) -> None:
    lib.ub_log_close(log)
