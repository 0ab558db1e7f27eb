"""Enum constants of a catalogue as Python `IntEnum`s, and their names for display.

A catalogue written by a generator that records enums has a top-level ``"enums"`` section,
``{"<enum type name>": {"<CONSTANT>": value, ...}}`` (constants in declaration order), and every field
object says ``"enum": "<enum type name>"`` or ``null`` (docs/catalogue.md). Older catalogues have
neither: then nothing here changes a value, and names fall back to the numbers.

    enums = catalogue_enums(cat)
    Mode = enums.int_enum("flightMode_t")        # an IntEnum: Mode.MODE_AUTO == 3
    enums.field_enum("onboardSet_t", "mode")     # the same class, or None for a plain integer member
    enums.label("flightMode_t", 3)               # "MODE_AUTO"; a value with no constant stays "7"
    enums.apply(cat.type("onboardSet_t"), value) # the decoded dict with IntEnum members where they belong

An `IntEnum` is an `int`: arithmetic, comparisons, `struct.pack` and `json.dumps` see the number.
"""

from __future__ import annotations

import enum
import json
import re
from typing import Any

__all__ = ["CatalogueEnums", "catalogue_enums"]

_IDENT = re.compile(r"[^0-9A-Za-z_]")
_IDENT_FULL = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


class CatalogueEnums:
    """The enum constants of one catalogue (empty for a catalogue written before enums were recorded)."""

    def __init__(self, doc: dict[str, Any], origin: str = "<catalogue>") -> None:
        raw = doc.get("enums") or {}
        if not isinstance(raw, dict) or not all(
                isinstance(consts, dict) and all(isinstance(c, str) and _IDENT_FULL.fullmatch(c) and type(v) is int
                                                 for c, v in consts.items()) for consts in raw.values()):
            from uavbus.catalogue import CatalogueError

            raise CatalogueError(f"{origin}: 'enums' must map enum type names to {{CONSTANT: integer}} "
                                 "(regenerate the catalogue with `uavbus gen`)")
        self.constants: dict[str, dict[str, int]] = {str(name): dict(consts) for name, consts in raw.items()}
        # type name -> member name -> enum type name, for members of an enum type only
        self.members: dict[str, dict[str, str]] = {}
        self._nested: dict[str, dict[str, str]] = {}
        for t in doc.get("types", []) if isinstance(doc.get("types"), list) else []:
            if not isinstance(t, dict) or not isinstance(t.get("fields"), list):
                continue
            fields = [f for f in t["fields"] if isinstance(f, dict) and isinstance(f.get("name"), str)]
            enums = {f["name"]: f["enum"] for f in fields if isinstance(f.get("enum"), str)
                     and f["enum"] in self.constants}
            if enums:
                self.members[str(t.get("name"))] = enums
            self._nested[str(t.get("name"))] = {f["name"]: f["struct"] for f in fields if isinstance(f.get("struct"), str)}
        self._classes: dict[str, type[enum.IntEnum]] = {}
        self._types_with_enums: dict[str, bool] = {}

    def __bool__(self) -> bool:
        return bool(self.constants)

    def int_enum(self, name: str) -> type[enum.IntEnum]:
        """The IntEnum of enum type `name` (KeyError if the catalogue has no such enum)."""
        cls = self._classes.get(name)
        if cls is None:
            consts = self.constants[name]
            class_name = _IDENT.sub("_", name.replace("enum ", "")) or "Enum"
            # Two constants with one value are aliases (the first is the canonical name), as in C.
            cls = enum.IntEnum(class_name, list(consts.items()))  # type: ignore[misc]
            cls.__doc__ = f"Constants of C enum {name!r} (from the catalogue)."
            self._classes[name] = cls
        return cls

    def field_enum(self, type_name: str, member: str) -> type[enum.IntEnum] | None:
        """The IntEnum of member `member` of type `type_name`, or None when it is not an enum member."""
        name = self.members.get(type_name, {}).get(member)
        return self.int_enum(name) if name is not None else None

    def label(self, enum_name: str, value: int) -> str:
        """The constant's name for `value` ("MODE_AUTO"), or the number when no constant has it."""
        for const, v in self.constants.get(enum_name, {}).items():
            if v == value:
                return const
        return str(value)

    def member(self, enum_name: str, value: Any) -> Any:
        """`value` as a member of the enum when one has it (else unchanged: a number with no constant)."""
        if isinstance(value, bool) or not isinstance(value, int):
            return value
        cls = self.int_enum(enum_name)
        try:
            return cls(value)
        except ValueError:
            return value

    def has_enums(self, type_name: str) -> bool:
        """True if `type_name` or a struct nested in it has enum members."""
        known = self._types_with_enums.get(type_name)
        if known is None:
            self._types_with_enums[type_name] = False  # cycle guard (the catalogue refuses cycles anyway)
            known = type_name in self.members or any(
                self.has_enums(sub) for sub in self._nested.get(type_name, {}).values())
            self._types_with_enums[type_name] = known
        return known

    def apply(self, type_: Any, value: Any) -> Any:
        """A decoded value of `type_` (a Catalogue Type) with its enum members as IntEnum members, nested
        structs and arrays included. Returns `value` itself (unchanged) when the type has no enums."""
        if not self.has_enums(type_.name) or not isinstance(value, dict):
            return value
        return self._apply(type_.name, value)

    def _apply(self, type_name: str, value: dict[str, Any]) -> dict[str, Any]:
        enums = self.members.get(type_name, {})
        nested = self._nested.get(type_name, {})
        out = dict(value)
        for name, v in value.items():
            if name in enums:
                out[name] = _map_leaves(v, lambda x, e=enums[name]: self.member(e, x))
            elif name in nested and self.has_enums(nested[name]):
                sub = nested[name]
                out[name] = _map_leaves(v, lambda x, s=sub: self._apply(s, x) if isinstance(x, dict) else x)
        return out

    def labels(self, type_: Any, value: Any) -> Any:
        """Like apply(), but with the constants' names as str (for display, CSV and JSON lines)."""
        applied = self.apply(type_, value)
        return _map_leaves(applied, lambda x: x.name if isinstance(x, enum.IntEnum) else x, into_dicts=True)


def _map_leaves(value: Any, fn: Any, into_dicts: bool = False) -> Any:
    if isinstance(value, list):
        return [_map_leaves(v, fn, into_dicts) for v in value]
    if isinstance(value, dict) and into_dicts:
        return {k: _map_leaves(v, fn, into_dicts) for k, v in value.items()}
    return fn(value)


def catalogue_enums(catalogue: Any) -> CatalogueEnums:
    """The CatalogueEnums of a uavbus.Catalogue (computed once from its JSON and kept on it)."""
    cached = getattr(catalogue, "_uavbus_enums", None)
    if cached is None:
        cached = CatalogueEnums(json.loads(catalogue.json_text), getattr(catalogue, "origin", "<catalogue>"))
        try:
            catalogue._uavbus_enums = cached
        except AttributeError:  # a catalogue-like object that refuses attributes: recompute next time
            pass
    return cached
