"""Wrappers for ub_nodecfg.h: the C configuration loader, the only one (uavbus.config sits on top)."""

from __future__ import annotations

import os
import time
from typing import Any

from uavbus._bindings.ub_catalogue import _c_name
from uavbus._bindings.ub_error import IoError, ensure
from uavbus._ub import ffi, lib

ERR_LEN: int = lib.UB_NODECFG_ERR_LEN
LIMIT_FIELDS = ("max_entities", "max_links_per_entity", "max_local_entities", "max_ports", "max_port_params")


def _err() -> Any:
    return ffi.new("char[]", ERR_LEN)


def text(chars: Any) -> str:
    """A NUL-terminated C char array as str."""
    return ffi.string(chars).decode("utf-8", "replace")


def build_limits() -> dict[str, int]:
    c = ffi.new("ub_nodecfg_limits_t *")
    lib.ub_nodecfg_build_limits(c)
    return {k: int(getattr(c, k)) for k in LIMIT_FIELDS}


def parse(data: bytes, source_name: str, limits: dict[str, int] | None = None) -> Any:
    """ub_nodecfg_parse_limits(): the parsed `ub_nodecfg_t *` (cffi-owned), or a UbError with the message."""
    cfg = ffi.new("ub_nodecfg_t *")
    c_limits = ffi.NULL
    if limits is not None:
        c_limits = ffi.new("ub_nodecfg_limits_t *")
        for k in LIMIT_FIELDS:
            value = int(limits.get(k, 0))
            if not 0 <= value <= 255:
                value = 255  # the C loader refuses it with a message naming the field and the build's value
            setattr(c_limits, k, value)
    err = _err()
    rc = lib.ub_nodecfg_parse_limits(cfg, data, len(data), _c_name(source_name), c_limits, err, ERR_LEN)
    ensure(rc, text(err) or source_name)
    return cfg


def load_file(path: str, limits: dict[str, int] | None = None) -> Any:
    """Reads `path` and parses it (the C loader sees the bytes; messages name `path`)."""
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError as exc:
        # Same wording as ub_nodecfg_load_file().
        raise IoError(f"{path}: cannot open: {os.strerror(exc.errno or 0)}") from None
    return parse(data, path, limits)


def copy(cfg: Any) -> Any:
    out = ffi.new("ub_nodecfg_t *")
    out[0] = cfg[0]
    return out


def ub_nodecfg_select_node(cfg: Any, node: str) -> None:
    err = _err()
    ensure(lib.ub_nodecfg_select_node(cfg, _c_name(node), err, ERR_LEN), text(err) or f"node {node!r}")


def ub_nodecfg_apply(cfg: Any, node: Any) -> None:
    err = _err()
    ensure(lib.ub_nodecfg_apply(cfg, node, err, ERR_LEN), text(err) or "ub_nodecfg_apply")


def ub_nodecfg_apply_priorities(cfg: Any, node: Any, cat: Any) -> Any:
    """The file's "priorities" onto the node (ub_prio.h). Returns the class table the C node points to (keep it
    alive), or None when the file has no such section."""
    if cfg.priority_count == 0:
        return None
    err = _err()
    table = ffi.new("uint8_t[]", max(1, cat.n_instances))
    ensure(lib.ub_nodecfg_apply_priorities(cfg, node, cat, table, cat.n_instances, err, ERR_LEN),
           text(err) or "ub_nodecfg_apply_priorities")
    return table


def hosted_entities(cfg: Any) -> tuple[str, ...]:
    return tuple(text(cfg.entities[cfg.hosts[k]].name) for k in range(cfg.host_count))


def nodes(cfg: Any) -> dict[str, tuple[str, ...]]:
    return {text(n.name): tuple(text(cfg.entities[n.entity[k]].name) for k in range(n.entity_count))
            for n in (cfg.nodes[i] for i in range(cfg.node_count))}


def rows(cfg: Any) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """(entity rows, port entries) as plain dicts, in file order."""
    count = cfg.entity_count
    entities = []
    for i in range(count):
        e = cfg.entities[i]
        entities.append({"name": text(e.name), "links": tuple(text(e.links[k]) for k in range(e.link_count)),
                         "masks": tuple(int(e.mask[j]) for j in range(count)), "line": int(e.line)})
    ports = []
    for i in range(cfg.port_count):
        p = cfg.ports[i]
        ports.append({"name": text(p.name), "transport": text(p.transport),
                      "params": {text(p.params[k].key): text(p.params[k].value) for k in range(p.param_count)},
                      "line": int(p.line)})
    return entities, ports


def mask_parse(mask_text: str) -> int | None:
    """ub_link_mask_parse(): the bits, or None when the text is not the paper's notation."""
    raw = mask_text.encode("utf-8", "replace")
    if b"\0" in raw:
        return None
    out = ffi.new("uint8_t *")
    return int(out[0]) if lib.ub_link_mask_parse(raw, out) == 0 else None


def mask_format(mask: int) -> str:
    out = ffi.new("char[11]")
    lib.ub_link_mask_format(mask, out)
    return ffi.string(out).decode("ascii")


def ub_nodecfg_apply_security(cfg: Any, node: Any) -> tuple[Any, Any] | None:
    """Applies the config's "security" section to `node` through the C loader (keys, counter file,
    policy); returns the (ub_sec_t, ub_counter_file_t) cdata the node now uses, which must live as
    long as the node, or None when the config has no such section."""
    if not cfg.security.present:
        return None
    sec = ffi.new("ub_sec_t *")
    counter = ffi.new("ub_counter_file_t *")
    cap = 2 * ERR_LEN + lib.UB_SECFILE_ERR_LEN
    err = ffi.new("char[]", cap)
    rc = lib.ub_nodecfg_apply_security(cfg, node, sec, counter, ffi.NULL, time.time_ns() // 1000, err, cap)
    ensure(rc, text(err) or "ub_nodecfg_apply_security")
    return sec, counter


def counter_mark(counter: Any) -> int:
    """The last counter mark read or stored by the counter file of ub_nodecfg_apply_security()."""
    return int(lib.ub_counter_file_mark(counter))
