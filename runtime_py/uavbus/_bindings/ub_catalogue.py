"""Wrappers for ub_catalogue.h: content (directory) and entity IDs, computed by the C runtime, and
the run-time `ub_catalogue_t` built from a catalogue JSON."""

from __future__ import annotations

from typing import Any

from uavbus._bindings.ub_error import InvalidArgumentError, LayoutError, ensure
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


class CCatalogue:
    """Owner of a run-time `ub_catalogue_t` and of every C object it points to (names, descriptor
    arrays, JSON text): the router keeps raw pointers, so all of them live as long as this does."""

    def __init__(self, catalogue: Any, keep: list[Any]) -> None:
        self.catalogue = catalogue
        self._keep = keep


def _c_string(text: str, keep: list[Any]) -> Any:
    s = ffi.new("char[]", _c_name(text))
    keep.append(s)
    return s


def build_c_catalogue(cat: Any) -> CCatalogue:
    """A `ub_catalogue_t *` for `cat` (a uavbus.catalogue.Catalogue): its named types with
    pack/unpack NULL, its instances in their (ID-sorted) order, its compact JSON."""
    if cat.abi_version != lib.UB_CATALOGUE_ABI_VERSION:
        raise LayoutError(f"{cat.origin}: catalogue ABI {cat.abi_version}, runtime expects "
                          f"{lib.UB_CATALOGUE_ABI_VERSION}; regenerate it with `uavbus gen`")
    keep: list[Any] = []
    named = cat.named_types
    types = ffi.new("ub_type_desc_t[]", max(len(named), 1))
    index_of: dict[str, int] = {}
    for k, t in enumerate(named):
        types[k].name = _c_string(t.name, keep)
        types[k].fingerprint = t.fingerprint
        types[k].packed_size = t.packed_size
        types[k].c_size = t.c_size
        types[k].pack = ffi.NULL
        types[k].unpack = ffi.NULL
        index_of[t.name] = k
    insts = ffi.new("ub_instance_desc_t[]", max(len(cat.instances), 1))
    for k, inst in enumerate(cat.instances):
        if inst.type.name not in index_of:
            raise LayoutError(f"{cat.origin}: instance {inst.name} has a type without a C name")
        ffi.memmove(insts[k].id, inst.id, DIR_ID_LEN)
        insts[k].name = _c_string(inst.name, keep)
        insts[k].type = ffi.addressof(types, index_of[inst.type.name])
    c = ffi.new("ub_catalogue_t *")
    c.name = _c_string(cat.name, keep)
    c.id_scheme = lib.UB_ID_SCHEME_HASHED if cat.id_scheme == "hashed" else lib.UB_ID_SCHEME_PAPER
    c.abi_version = cat.abi_version
    c.types, c.n_types = types, len(named)
    c.instances, c.n_instances = insts, len(cat.instances)
    c.max_packed_size = max((t.packed_size for t in named), default=0)
    json_bytes = cat.json_text.encode("ascii")
    c.json = _c_string(cat.json_text, keep)
    c.json_len = len(json_bytes)
    keep += [types, insts]
    return CCatalogue(c, keep)


def ub_catalogue_find(c_cat: Any, dir_id: bytes) -> int:
    """Index of the instance with content ID `dir_id` (the C binary search); NotFoundError if none."""
    if len(dir_id) != DIR_ID_LEN:
        raise InvalidArgumentError(f"content ID must be {DIR_ID_LEN} bytes, got {len(dir_id)}")
    return ensure(lib.ub_catalogue_find(c_cat, dir_id), f"content ID {dir_id.hex()}")


def ub_catalogue_find_name(c_cat: Any, name: str) -> int:
    return ensure(lib.ub_catalogue_find_name(c_cat, _c_name(name)), f"instance {name!r}")
