"""Wrappers for ub_catalogue.h: content (directory) and entity IDs, computed by the C runtime."""

from __future__ import annotations

from uavbus._bindings.ub_error import InvalidArgumentError, ensure
from uavbus._ub import ffi, lib

DIR_ID_LEN: int = lib.UB_DIR_ID_LEN
ENTITY_ID_LEN: int = lib.UB_ENTITY_ID_LEN


def _c_name(name: str) -> bytes:
    raw = name.encode("utf-8")
    if b"\0" in raw:
        # C would stop at the NUL and silently compute the ID of a shorter name.
        raise InvalidArgumentError(f"name {name!r} contains a NUL character")
    return raw


def ub_dir_id_paper(name: str) -> bytes:
    """The paper's content ID of `name`: its first 8 and last 8 characters (16 bytes)."""
    out = ffi.new("uint8_t[]", DIR_ID_LEN)
    lib.ub_dir_id_paper(_c_name(name), out)
    return bytes(ffi.buffer(out))


def ub_entity_id(name: str) -> bytes:
    """The entity ID of `name`: the name NUL-padded to 12 bytes. Raises RangeError when longer."""
    out = ffi.new("uint8_t[]", ENTITY_ID_LEN)
    ensure(lib.ub_entity_id(_c_name(name), out), f"entity name {name!r}")
    return bytes(ffi.buffer(out))
