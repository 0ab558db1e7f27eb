"""Wrappers for ub_nodecfg.h: the C config loader, so C programs and Python apply the same table."""

from __future__ import annotations

from typing import Any

from uavbus._bindings.ub_catalogue import _c_name
from uavbus._bindings.ub_error import ensure
from uavbus._ub import ffi, lib

ERR_LEN: int = lib.UB_NODECFG_ERR_LEN
FILE_MAX = 1 << 20  # largest config file read; the C loader reports UB_ERR_NOSPACE beyond it


def _err() -> Any:
    return ffi.new("char[]", ERR_LEN)


def _text(err: Any) -> str:
    return ffi.string(err).decode("utf-8", "replace")


def ub_nodecfg_load_file(path: str) -> Any:
    cfg = ffi.new("ub_nodecfg_t *")
    buf = ffi.new("char[]", FILE_MAX)
    err = _err()
    rc = lib.ub_nodecfg_load_file(cfg, _c_name(str(path)), buf, FILE_MAX, err, ERR_LEN)
    ensure(rc, _text(err) or str(path))
    return cfg


def ub_nodecfg_parse(text: str, source_name: str = "<config>") -> Any:
    cfg = ffi.new("ub_nodecfg_t *")
    raw = text.encode("utf-8")
    err = _err()
    ensure(lib.ub_nodecfg_parse(cfg, raw, len(raw), _c_name(source_name), err, ERR_LEN), _text(err) or source_name)
    return cfg


def ub_nodecfg_select_node(cfg: Any, node: str) -> None:
    err = _err()
    ensure(lib.ub_nodecfg_select_node(cfg, _c_name(node), err, ERR_LEN), _text(err) or f"node {node!r}")


def ub_nodecfg_apply(cfg: Any, node: Any) -> None:
    err = _err()
    ensure(lib.ub_nodecfg_apply(cfg, node, err, ERR_LEN), _text(err) or "ub_nodecfg_apply")


def hosted_entities(cfg: Any) -> list[str]:
    return [ffi.string(cfg.entities[cfg.hosts[k]].name).decode("utf-8") for k in range(cfg.host_count)]


def node_names(cfg: Any) -> list[str]:
    return [ffi.string(cfg.nodes[k].name).decode("utf-8") for k in range(cfg.node_count)]
