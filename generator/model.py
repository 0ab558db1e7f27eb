"""The validated, immutable catalogue model: what is packed, how, and under which IDs.

Built from front-end records (frontend.py) by build_catalogue(); every dataclass checks itself on
construction, so a model that exists is consistent. Also computes layout fingerprints and the
deterministic self-test values (mavgen `gen_test_value` style) shared by the C and Python checks.
"""

from __future__ import annotations

import dataclasses
import fnmatch
import hashlib
import math
import os
import re
import struct
import zlib
from dataclasses import dataclass
from itertools import product
from typing import Callable, Iterable, Iterator, Union

from . import ids
from .frontend import FeEnum, FeField, FeInstance, FeOther, FeRecord, FeRecordRef, FeScalar, FeUnit, SourceLoc


class ModelError(Exception):
    """A catalogue that must not be generated. exit_code: 1 = uniqueness, 2 = input problem."""

    exit_code = 2


class DuplicateDefinitionError(ModelError):
    exit_code = 1


class CollisionError(ModelError):
    exit_code = 1


class PayloadLimitError(ModelError):
    exit_code = 1


class CatalogueRefusedError(ModelError):
    """Several of the problems above at once."""

    exit_code = 1


# ---------------------------------------------------------------------------------------------
# Wire types


@dataclass(frozen=True)
class Primitive:
    """A wire type: little-endian, no padding."""

    name: str  # u8 i8 u16 i16 u32 i32 u64 i64 f32 f64 bool
    size: int
    signed: bool
    is_float: bool
    py_format: str  # struct module code
    c_type: str  # C type of the value on the wire

    def __post_init__(self) -> None:
        if self.size not in (1, 2, 4, 8) or len(self.py_format) != 1:
            raise ValueError(f"bad primitive {self.name}")

    @property
    def bits(self) -> int:
        return self.size * 8


PRIMITIVES: dict[str, Primitive] = {
    p.name: p
    for p in (
        Primitive("bool", 1, False, False, "?", "uint8_t"),
        Primitive("u8", 1, False, False, "B", "uint8_t"),
        Primitive("i8", 1, True, False, "b", "int8_t"),
        Primitive("u16", 2, False, False, "H", "uint16_t"),
        Primitive("i16", 2, True, False, "h", "int16_t"),
        Primitive("u32", 4, False, False, "I", "uint32_t"),
        Primitive("i32", 4, True, False, "i", "int32_t"),
        Primitive("u64", 8, False, False, "Q", "uint64_t"),
        Primitive("i64", 8, True, False, "q", "int64_t"),
        Primitive("f32", 4, True, True, "f", "float"),
        Primitive("f64", 8, True, True, "d", "double"),
    )
}


def int_primitive(size: int, signed: bool) -> Primitive:
    return PRIMITIVES[f"{'i' if signed else 'u'}{size * 8}"]


def bitfield_container(width: int, signed: bool) -> Primitive:
    """The smallest of u8/u16/u32/u64 (i8...) that holds `width` bits."""
    for size in (1, 2, 4, 8):
        if width <= size * 8:
            return int_primitive(size, signed)
    raise ValueError(f"bitfield of {width} bits is wider than 64")


# Skip reasons, as written into the catalogue (docs/catalogue.md).
SKIP_POINTER = "pointer"
SKIP_STRING = "string"
SKIP_FLEXIBLE = "flexible array member"
SKIP_UNION = "union"
SKIP_UNSUPPORTED = "unsupported type"
# A const bitfield has no address, so unpack can neither assign it nor write its bytes.
SKIP_CONST_BITFIELD = "const bitfield (unpack cannot write it: drop the const to send it)"

STRINGS_SKIP = "skip"  # the paper's rule: `char` arrays are not sent
STRINGS_BYTES = "bytes"  # `char` arrays are sent as their bytes (all of them, NULs included)
DEFAULT_MAX_PAYLOAD = 16384  # UB_MAX_DIRECTORY of the default runtime build (runtime_c/include/ub/ub_config.h)
MAX_DIRECTORY_LIMIT = 65535  # the largest UB_MAX_DIRECTORY a runtime accepts (16-bit reassembled size)


@dataclass(frozen=True)
class BuildOptions:
    """What the user chose. `max_payload` is the one number the runtime's node can carry
    (UB_MAX_DIRECTORY: above UB_MAX_PAYLOAD in fragments); a type packing to more is refused
    (or, with keep_going, left out)."""

    id_scheme: str = "paper"
    strings: str = STRINGS_SKIP
    string_fields: tuple[str, ...] = ()  # fnmatch patterns on "<type name>.<member>"
    max_payload: int = DEFAULT_MAX_PAYLOAD
    keep_going: bool = False
    # Handle-based object systems (UAVObjects, uORB): instances made from types. A pattern is a regex
    # matched in full against each type name (`struct tag` or typedef); the instance is named by its
    # first group, else by the type name. A listed instance is (name, type name, where it is listed).
    instance_patterns: tuple[str, ...] = ()
    instance_list: tuple[tuple[str, str, SourceLoc], ...] = ()
    left_out: tuple[str, ...] = ()  # inputs not catalogued (--keep-going failures, --exclude): absolute paths
    abi: str = ""  # whose layout clang matched: `arm-none-eabi-gcc (arm-none-eabi)`; '' for the host's default

    def __post_init__(self) -> None:
        for pat in self.instance_patterns:
            try:
                re.compile(pat)
            except re.error as exc:
                raise ValueError(f"--instance-per-type '{pat}' is not a regular expression: {exc}") from None
        if self.strings not in (STRINGS_SKIP, STRINGS_BYTES):
            raise ValueError(f"strings must be '{STRINGS_SKIP}' or '{STRINGS_BYTES}', not {self.strings!r}")
        if self.max_payload <= 0:
            raise ValueError(f"the payload limit must be positive, not {self.max_payload}")

    def string_as_bytes(self, type_name: str, member: str) -> bool:
        return self.strings == STRINGS_BYTES or any(
            fnmatch.fnmatchcase(f"{type_name}.{member}", pat) for pat in self.string_fields)


# ---------------------------------------------------------------------------------------------
# Model classes


@dataclass(frozen=True)
class Field:
    """One member of a struct. Exactly one of `wire` (a packed scalar or bitfield), `struct` (a
    nested struct, by StructType.name) or `skipped` (the reason it is not on the wire) is set.
    `enum` names the member's EnumType; `text` marks a `char` array sent as bytes (wire u8)."""

    name: str
    dims: tuple[int, ...]
    offset_bits: int
    loc: SourceLoc
    c_spelling: str
    wire: Primitive | None = None
    struct: str | None = None
    bits: int | None = None
    long_double: bool = False
    skipped: str | None = None
    enum: str | None = None
    text: bool = False
    readonly: bool = False  # declared const: unpack writes its storage bytes instead of assigning
    unit: str | None = None  # from the header's comment ("m/s"), see parse_comment()
    doc: str | None = None   # the rest of that comment

    def __post_init__(self) -> None:
        kinds = sum(x is not None for x in (self.wire, self.struct, self.skipped))
        if kinds != 1:
            raise ValueError(f"{self.loc}: field '{self.name}' must be exactly one of wire/struct/skipped")
        if any(d <= 0 for d in self.dims):
            raise ValueError(f"{self.loc}: field '{self.name}' has an empty array dimension {self.dims}")
        if self.bits is not None and (self.wire is None or self.dims or not 0 < self.bits <= self.wire.bits):
            raise ValueError(f"{self.loc}: bitfield '{self.name}' of {self.bits} bits does not fit its container")
        if self.skipped is None and not self.name:
            raise ValueError(f"{self.loc}: a packed field needs a name")
        if self.text and (self.wire is None or self.wire.name != "u8" or not self.dims):
            raise ValueError(f"{self.loc}: text field '{self.name}' must be a u8 array")
        if self.enum is not None and (self.wire is None or self.wire.is_float or self.wire.name == "bool"):
            raise ValueError(f"{self.loc}: enum field '{self.name}' must have an integer wire type")
        if self.readonly and self.bits is not None:
            raise ValueError(f"{self.loc}: const bitfield '{self.name}' cannot be unpacked (it has no address)")

    @property
    def packed(self) -> bool:
        return self.skipped is None

    @property
    def count(self) -> int:
        return math.prod(self.dims)

    @property
    def wire_name(self) -> str:
        """The wire type as written in the catalogue: a primitive name, 'struct' or None (skipped)."""
        return self.wire.name if self.wire else ("struct" if self.struct else "none")

    @property
    def checked(self) -> bool:
        """Unpack refuses some wire values of this scalar: a bool byte other than 0/1, or a bitfield
        container holding bits outside the field's width (docs/catalogue.md, canonical codecs)."""
        if self.wire is None:
            return False
        if self.wire.name == "bool":
            return True
        return self.bits is not None and self.bits < self.wire.bits

    def bit_range(self) -> tuple[int, int]:
        """The values a bitfield of this width holds (two's complement when signed)."""
        assert self.wire is not None and self.bits is not None
        if self.wire.signed:
            return -(1 << (self.bits - 1)), (1 << (self.bits - 1)) - 1
        return 0, (1 << self.bits) - 1


@dataclass(frozen=True)
class StructType:
    name: str  # "struct tag", a typedef name, or "<parent>::<member>" for an unnamed type
    c_name: str | None  # None for an unnamed type (it has no C spelling)
    size: int  # clang's sizeof
    align: int
    packed_attr: bool
    fields: tuple[Field, ...]
    loc: SourceLoc
    packed_size: int
    fingerprint: int
    canonical: str  # the text the fingerprint hashes

    def __post_init__(self) -> None:
        if not 0 <= self.fingerprint <= 0xFFFFFFFF:
            raise ValueError(f"{self.loc}: fingerprint of {self.name} out of range")
        if self.packed_size < 0 or self.size < 0:
            raise ValueError(f"{self.loc}: {self.name} has a negative size")
        names = [f.name for f in self.fields if f.name]
        if len(names) != len(set(names)):
            raise ValueError(f"{self.loc}: {self.name} has two members of one name")

    @property
    def ident(self) -> str:
        """A C identifier fragment for the type: the tag or typedef name (`parent__member` if unnamed)."""
        base = self.name.removeprefix("struct ")
        return base.replace("::", "__").replace("struct ", "")

    @property
    def packed_fields(self) -> tuple[Field, ...]:
        return tuple(f for f in self.fields if f.packed)


@dataclass(frozen=True)
class EnumType:
    """An enum used by some catalogued member: its constants in declaration order."""

    name: str  # "enum tag", a typedef name, or "<parent>::<member>" for an unnamed enum
    constants: tuple[tuple[str, int], ...]
    loc: SourceLoc

    def __post_init__(self) -> None:
        names = [n for n, _ in self.constants]
        if len(names) != len(set(names)):
            raise ValueError(f"{self.loc}: {self.name} has two constants of one name")


_NON_IDENT = re.compile(r"[^A-Za-z0-9_]")


@dataclass(frozen=True)
class Instance:
    """One catalogued instance; an array element is its own instance, named `base[i][j]`. An
    instance defined in several files is catalogued once per file, named `base[i]@qualifier`."""

    name: str
    type: str  # StructType.name
    id: bytes
    loc: SourceLoc
    base: str
    index: tuple[int, ...]
    qualifier: str | None = None
    runtime: bool = False  # made from its type (handle-based objects): the application binds its storage

    def __post_init__(self) -> None:
        if len(self.id) != ids.DIR_ID_LEN:
            raise ValueError(f"{self.loc}: ID of {self.name} is not {ids.DIR_ID_LEN} bytes")
        want = self.base + "".join(f"[{i}]" for i in self.index) + (f"@{self.qualifier}" if self.qualifier else "")
        if self.name != want:
            raise ValueError(f"{self.loc}: element name {self.name} does not match {want}")

    @property
    def ident(self) -> str:
        """A C identifier fragment: `name[1][2]` -> `name_1_2`, `name@apps/x` -> `name__apps_x`."""
        out = self.base + "".join(f"_{i}" for i in self.index)
        return out + "__" + _NON_IDENT.sub("_", self.qualifier) if self.qualifier else out


@dataclass(frozen=True)
class SkippedInstance:
    name: str
    loc: SourceLoc
    reason: str


@dataclass(frozen=True)
class Note:
    """Something the user should read: `severity` is 'warning' or 'note'; loc may be None."""

    severity: str
    text: str
    loc: SourceLoc | None = None

    def __str__(self) -> str:
        return f"{self.loc}: {self.severity}: {self.text}" if self.loc else f"{self.severity}: {self.text}"


@dataclass(frozen=True)
class IncludeFile:
    """An input header that no -I directory finds: the generated header includes it by its path
    relative to the output directory (the renderer spells it), so compiling needs no extra -I."""

    path: str  # absolute, normalised

    def __post_init__(self) -> None:
        if not os.path.isabs(self.path):
            raise ValueError(f"include path must be absolute: {self.path}")


@dataclass(frozen=True)
class Catalogue:
    id_scheme: str
    types: tuple[StructType, ...]  # sorted by name
    instances: tuple[Instance, ...]  # sorted by ID
    skipped_instances: tuple[SkippedInstance, ...] = ()
    enums: tuple[EnumType, ...] = ()  # sorted by name
    # What the generated C header #includes, in order: '"a.h"', '<b.h>', or an IncludeFile.
    includes: tuple[Union[str, IncludeFile], ...] = ()
    notes: tuple[Note, ...] = ()
    max_payload: int = DEFAULT_MAX_PAYLOAD
    abi: str = ""  # BuildOptions.abi: the compiler whose layout the sizes and offsets are
    _by_name: dict = dataclasses.field(default_factory=dict, repr=False, compare=False)
    _checks: dict = dataclasses.field(default_factory=dict, repr=False, compare=False)  # has_checks() memo

    def __post_init__(self) -> None:
        if self.id_scheme not in ids.ID_SCHEMES:
            raise ValueError(f"unknown ID scheme {self.id_scheme}")
        by_name = {t.name: t for t in self.types}
        if len(by_name) != len(self.types) or [t.name for t in self.types] != sorted(by_name):
            raise ValueError("types must be unique and sorted by name")
        enums = {e.name for e in self.enums}
        if len(enums) != len(self.enums) or [e.name for e in self.enums] != sorted(enums):
            raise ValueError("enums must be unique and sorted by name")
        for t in self.types:
            for f in t.fields:
                if f.struct is not None and f.struct not in by_name:
                    raise ValueError(f"{f.loc}: {t.name}.{f.name} needs type {f.struct}, not in the catalogue")
                if f.enum is not None and f.enum not in enums:
                    raise ValueError(f"{f.loc}: {t.name}.{f.name} needs enum {f.enum}, not in the catalogue")
        idents = [t.ident for t in self.types]
        if len(set(idents)) != len(idents):
            raise ModelError("two types map to one C identifier: " + ", ".join(sorted(_dupes(idents))))
        id_list = [i.id for i in self.instances]
        if id_list != sorted(set(id_list)):
            raise ValueError("instances must have unique IDs, sorted")
        inst_idents = [i.ident for i in self.instances]
        if len(set(inst_idents)) != len(inst_idents):
            raise ModelError("two instances map to one C identifier: " + ", ".join(sorted(_dupes(inst_idents))))
        for inst in self.instances:
            if by_name.get(inst.type) is None or by_name[inst.type].c_name is None:
                raise ValueError(f"{inst.loc}: instance {inst.name} has no named type")
        self._by_name.update(by_name)

    def type(self, name: str) -> StructType:
        try:
            return self._by_name[name]
        except KeyError:
            raise KeyError(name) from None

    @property
    def named_types(self) -> tuple[StructType, ...]:
        """Types with a C spelling: the ones with codecs in C and in the self-test."""
        return tuple(t for t in self.types if t.c_name is not None)

    @property
    def has_readonly(self) -> bool:
        """Some packed member is const (unpack then writes storage bytes: docs/catalogue.md, const members)."""
        return any(f.readonly for t in self.types for f in t.packed_fields)

    @property
    def max_packed_size(self) -> int:
        return max((t.packed_size for t in self.types), default=0)

    def has_checks(self, t: StructType) -> bool:
        """Unpack of `t` refuses some byte strings (a checked scalar somewhere inside)."""
        known = self._checks.get(t.name)
        if known is None:
            known = any(f.checked or (f.struct is not None and self.has_checks(self.type(f.struct)))
                        for f in t.packed_fields)
            self._checks[t.name] = known
        return known

    def skipped_fields(self) -> dict[str, list[tuple[StructType, Field]]]:
        """Skipped members by reason (the reason's first word: 'unsupported type (x)' -> 'unsupported type')."""
        out: dict[str, list[tuple[StructType, Field]]] = {}
        for t in self.types:
            for f in t.fields:
                if f.skipped:
                    out.setdefault(f.skipped.split(" (")[0], []).append((t, f))
        return dict(sorted(out.items()))


def _dupes(items: Iterable[str]) -> set[str]:
    seen: set[str] = set()
    return {x for x in items if x in seen or seen.add(x)}  # type: ignore[func-returns-value]


# ---------------------------------------------------------------------------------------------
# Building


def build_catalogue(units: list[FeUnit], id_scheme: str = "paper", relpath: Callable[[str], str] = str,
                    options: BuildOptions | None = None) -> Catalogue:
    """The union of all translation units: checks duplicates, IDs, sizes and uniqueness. Every
    problem of one run is reported at once (a ModelError carries the notes gathered so far)."""
    notes: list[Note] = []
    try:
        return _build(units, id_scheme, relpath, options, notes)
    except ModelError as exc:
        exc.notes = tuple(notes)  # type: ignore[attr-defined]
        raise


def _build(units: list[FeUnit], id_scheme: str, relpath: Callable[[str], str], options: BuildOptions | None,
           notes: list[Note]) -> Catalogue:
    opts = dataclasses.replace(options or BuildOptions(), id_scheme=id_scheme)
    records = _merge_records(units, relpath)
    fe_enums = _merge_enums(units, relpath)
    # A left-out input that the generated header includes anyway (a .c input's #include line brings it,
    # in the context it needs) still declares its instances there: only the others are really left out.
    _, _, reached = _include_plan(units, {i.type_key for unit in units for i in unit.instances})
    fe_instances, skipped = _merge_instances(units, relpath, notes, frozenset(opts.left_out) - reached)
    made = _runtime_instances(units, opts, {i.name for i, _ in fe_instances}, relpath, notes)
    fe_instances += [(i, None) for i in made]
    includes, unreachable, _ = _include_plan(units, {i.type_key for i, _ in fe_instances})
    for key, where in sorted(unreachable.items()):
        users = sorted({i.name for i, _ in fe_instances if i.type_key == key})
        notes.append(Note("warning", f"'{key}' is defined in {relpath(where.file)}, a .c file the generated C cannot "
                                     f"include: {len(users)} instance(s) not catalogued ({', '.join(users)}); move the "
                                     "definition into a header that file includes",
                          SourceLoc(relpath(where.file), where.line)))
        for inst, _ in fe_instances:
            if inst.type_key == key:
                skipped[inst.name] = SkippedInstance(inst.name, SourceLoc(relpath(inst.loc.file), inst.loc.line),
                                                     f"type defined in a .c file: '{key}' (move it to a header)")
    fe_instances = [(i, q) for i, q in fe_instances if i.type_key not in unreachable]
    needed = _reachable(records, {i.type_key for i, _ in fe_instances})
    types = _make_types(records, needed, relpath, opts)
    problems: list[str] = []
    fe_instances = _apply_payload_limit(types, fe_instances, skipped, opts, notes, relpath, problems)
    kept = _reachable(records, {i.type_key for i, _ in fe_instances})
    types = {k: t for k, t in types.items() if k in kept}
    instances = _expand_instances(fe_instances, id_scheme, relpath)
    try:
        _check_unique(instances, id_scheme)
    except CollisionError as exc:
        if not problems:
            raise
        problems.append(str(exc))
    if problems:
        raise (PayloadLimitError if len(problems) == 1 else CatalogueRefusedError)("\n".join(problems))
    used_enums = {f.enum for t in types.values() for f in t.fields if f.enum}
    enums = tuple(EnumType(e.key, e.constants, SourceLoc(relpath(e.loc.file), e.loc.line))
                  for k, e in sorted(fe_enums.items()) if k in used_enums)
    notes += _hints(units, instances, skipped, types, opts, relpath)
    return Catalogue(id_scheme, tuple(types[k] for k in sorted(types)), tuple(sorted(instances, key=lambda i: i.id)),
                     tuple(skipped[k] for k in sorted(skipped)), enums, includes, tuple(notes), opts.max_payload,
                     opts.abi)


def _loc_key(loc: SourceLoc, relpath: Callable[[str], str]) -> tuple[str, int]:
    return (relpath(loc.file), loc.line)


def _merge_records(units: list[FeUnit], relpath: Callable[[str], str]) -> dict[str, FeRecord]:
    merged: dict[str, FeRecord] = {}
    for unit in units:
        for rec in unit.records:
            old = merged.get(rec.key)
            if old is None:
                merged[rec.key] = rec
            elif _record_shape(old, relpath) != _record_shape(rec, relpath):
                a, b = sorted((_fmt(old.loc, relpath), _fmt(rec.loc, relpath)))
                raise DuplicateDefinitionError(
                    f"{a}: error: '{rec.key}' is defined differently here and at {b}; "
                    "one name must mean one layout in every input (rename one, or make them identical)"
                )
            elif _loc_key(rec.loc, relpath) < _loc_key(old.loc, relpath):
                merged[rec.key] = rec
    return merged


def _record_shape(rec: FeRecord, relpath: Callable[[str], str]) -> tuple:
    fields = tuple((f.name, _shape_type(f.type, relpath), f.dims, f.offset_bits, f.bit_width) for f in rec.fields)
    return (rec.c_name, rec.size, rec.align, rec.packed, fields)


def _shape_type(t: object, relpath: Callable[[str], str]) -> object:
    """A field type for comparison across inputs (clang's spelling of unnamed things holds paths)."""
    if isinstance(t, (FeScalar, FeOther)):
        return dataclasses.replace(t, spelling=_spelling(t.spelling, relpath))
    return t


def _merge_enums(units: list[FeUnit], relpath: Callable[[str], str]) -> dict[str, FeEnum]:
    merged: dict[str, FeEnum] = {}
    for unit in units:
        for e in unit.enums:
            old = merged.get(e.key)
            if old is None:
                merged[e.key] = e
            elif old.constants != e.constants:
                a, b = sorted((_fmt(old.loc, relpath), _fmt(e.loc, relpath)))
                raise DuplicateDefinitionError(
                    f"{a}: error: '{e.key}' has other constants here than at {b}; "
                    "one enum name must mean one set of constants in every input")
            elif _loc_key(e.loc, relpath) < _loc_key(old.loc, relpath):
                merged[e.key] = e
    return merged


def _merge_instances(units: list[FeUnit], relpath: Callable[[str], str], notes: list[Note],
                     left_out: frozenset[str] = frozenset()
                     ) -> tuple[list[tuple[FeInstance, str | None]], dict[str, SkippedInstance]]:
    """The instances of the union, as (record, qualifier), and the skipped ones by name.

    One name declared in several inputs is one instance, at its first place. One name *defined*
    in several files (each translation unit's definition counts once, a header's definition is
    one file however many inputs include it) is one instance per file, qualified by the file:
    `name@<shortest trailing path without suffix that tells the files apart>`."""
    seen: dict[str, list[tuple[int, FeInstance]]] = {}
    for k, unit in enumerate(units):
        for inst in unit.instances:
            seen.setdefault(inst.name, []).append((k, inst))
    out: list[tuple[FeInstance, str | None]] = []
    gone: dict[str, SkippedInstance] = {}
    for name in sorted(seen):
        places = seen[name]
        # A declaration in an input that was left out (it did not parse, or --exclude) is seen through
        # another input that includes it, but the generated C cannot include it: use another place.
        usable = [(k, i) for k, i in places if os.path.abspath(i.loc.file) not in left_out]
        if len(usable) < len(places):
            hidden = min((i for _, i in places if (_, i) not in usable), key=lambda i: _loc_key(i.loc, relpath))
            where = SourceLoc(relpath(hidden.loc.file), hidden.loc.line)
            if not usable:
                gone[name] = SkippedInstance(name, where, f"declared in {where.file}, an input left out "
                                                          "(it does not parse, or --exclude): the generated C "
                                                          "could not refer to it")
                continue
            other = min((i for _, i in usable), key=lambda i: _loc_key(i.loc, relpath))
            notes.append(Note("note", f"'{name}' is declared in {where.file}, an input left out; catalogued from "
                                      f"{_fmt(other.loc, relpath)}", where))
            places = usable
        first = min((inst for _, inst in places), key=lambda i: _loc_key(i.loc, relpath))
        for _, inst in places:
            if (first.type_key, first.dims) != (inst.type_key, inst.dims):
                a, b = sorted((_fmt(first.loc, relpath), _fmt(inst.loc, relpath)))
                raise DuplicateDefinitionError(
                    f"{a}: error: instance '{name}' is declared with another type here and at {b} "
                    f"({_decl_text(first)} vs {_decl_text(inst)})"
                )
        definitions: dict[str, FeInstance] = {}
        for k in sorted({k for k, _ in places}):
            defs = [inst for j, inst in places if j == k and inst.definition]
            if defs:
                own = [d for d in defs if os.path.normpath(d.loc.file) == os.path.normpath(units[k].file)]
                pick = (own or defs)[0]
                definitions.setdefault(relpath(pick.loc.file), pick)
        if len(definitions) <= 1:
            out.append((first, None))
            continue
        quals = _qualifiers(sorted(definitions))
        names = [f"{name}@{quals[f]}" for f in sorted(definitions)]
        notes.append(Note("note", f"'{name}' is defined in {len(definitions)} files; catalogued once per file as "
                                  f"{', '.join(names)} (docs/catalogue.md, duplicate definitions)",
                          SourceLoc(relpath(first.loc.file), first.loc.line)))
        out += [(definitions[f], quals[f]) for f in sorted(definitions)]
    catalogued = set(seen) - set(gone)
    skipped: dict[str, SkippedInstance] = dict(gone)
    for unit in units:
        for name, loc, reason in unit.skipped_instances:
            if name not in catalogued:
                skipped.setdefault(name, SkippedInstance(name, SourceLoc(relpath(loc.file), loc.line), reason))
    return out, skipped


def _runtime_instances(units: list[FeUnit], opts: BuildOptions, taken: set[str], relpath: Callable[[str], str],
                       notes: list[Note]) -> list[FeInstance]:
    """Instances of handle-based object systems, made from their types (--instance-per-type,
    --instances-from): every data type is defined in the headers, but the objects are created at run
    time behind handles, so no global instance leads to them. Each gets an ID and a NULL entry in the
    bind table; the application binds its storage (ub_node_bind())."""
    if not opts.instance_patterns and not opts.instance_list:
        return []
    names: dict[str, str] = {}
    records = {r.key: r for unit in units for r in unit.records}
    for unit in units:
        for name, key in unit.named_records:
            names.setdefault(name, key)
    out: dict[str, FeInstance] = {}
    used_keys: set[str] = set()

    def add(name: str, key: str, loc: SourceLoc, origin: str) -> None:
        if not is_identifier(name):
            raise ModelError(f"{origin}: error: instance name '{name}' is not a C identifier")
        if name in taken:
            notes.append(Note("note", f"'{name}' ({origin}) is also an instance the inputs declare: "
                                      "that one is catalogued"))
            return
        if name in out:
            if out[name].type_key != key:
                raise ModelError(f"{origin}: error: instance '{name}' is made from two types "
                                 f"({out[name].type_key}, {key})")
            return
        out[name] = FeInstance(name, key, (), loc, False, runtime=True)
        used_keys.add(key)

    for name, type_name, where in opts.instance_list:
        key = names.get(type_name)
        if key is None:
            close = sorted(n for n in names if type_name.lower() in n.lower())[:3]
            raise ModelError(f"{where}: error: '{type_name}' is not a struct type the inputs define"
                             + (f" (did you mean {', '.join(close)}?)" if close else f" ({len(names)} types seen)"))
        add(name, key, where, str(where))
    for pat in opts.instance_patterns:
        rx = re.compile(pat)
        hits = 0
        for type_name in sorted(names):
            m = rx.fullmatch(type_name)
            if m is None or names[type_name] in used_keys:
                continue
            hits += 1
            name = (m.group(1) if rx.groups else type_name.removeprefix("struct ")) or type_name
            rec = records[names[type_name]]
            add(name, names[type_name], rec.loc, f"--instance-per-type '{pat}' ({type_name})")
        if not hits:
            sample = ", ".join(sorted(names)[:5]) + (", ..." if len(names) > 5 else "")
            notes.append(Note("warning", f"--instance-per-type '{pat}' matches no struct type in full "
                                         f"({len(names)} types seen: {sample})"))
    return [out[k] for k in sorted(out)]


def _qualifiers(files: list[str]) -> dict[str, str]:
    """The shortest trailing path, without the suffix, that tells each file from the others:
    `apps/sc/tables/sc_rts001.c` -> `sc_rts001`; `a/tbl.c`, `b/tbl.c` -> `a/tbl`, `b/tbl`."""
    parts = {f: tuple(os.path.splitext(f)[0].split("/")) for f in files}
    out = {}
    for f, p in parts.items():
        for n in range(1, len(p) + 1):
            if all(q[-n:] != p[-n:] for g, q in parts.items() if g != f):
                out[f] = "/".join(p[-n:])
                break
        else:
            out[f] = "/".join(p)
    return out


def _decl_text(inst: FeInstance) -> str:
    return inst.type_key + "".join(f"[{d}]" for d in inst.dims)


def _include_plan(units: list[FeUnit], type_keys: set[str]
                  ) -> tuple[tuple[Union[str, IncludeFile], ...], dict[str, SourceLoc], frozenset[str]]:
    """What the generated header #includes so every instance type is visible, in the context clang
    parsed it in, and the types no header can reach (key -> where the .c defines it).

    A type seen through a header input: that header (it parsed on its own, so it is self-contained).
    A type seen only through `.c` inputs: the first such input's own #include lines, in order, up to
    the one that brings the type in; the headers before it are what a non-self-contained header
    needs. A type defined inside a `.c` file cannot be reached. Also returns the files included
    (absolute paths)."""
    chosen: dict[str, tuple[int, int]] = {}  # key -> (unit, index into top_includes; -1 = self_include)
    defined_in_c: dict[str, SourceLoc] = {}
    seen = [{r.key: r.loc for r in unit.records} for unit in units]
    vias = [dict(unit.record_via) for unit in units]
    for key in sorted(type_keys):
        for k, unit in enumerate(units):
            if key not in seen[k]:
                continue
            if not unit.is_source:
                chosen[key] = (k, -1)
                break
            via = vias[k].get(key, -1)
            if via >= 0:
                chosen[key] = (k, via)
                break
            defined_in_c.setdefault(key, seen[k][key])
    unreachable = {k: loc for k, loc in defined_in_c.items() if k not in chosen}
    wanted: dict[int, int] = {}
    for k, via in chosen.values():
        wanted[k] = max(wanted.get(k, -1), via)
    includes: list[Union[str, IncludeFile]] = []
    opened: set[str] = set()
    for k in sorted(wanted):
        unit = units[k]
        refs = [unit.self_include] if not unit.is_source else list(unit.top_includes[:wanted[k] + 1])
        for ref in refs:
            assert ref is not None
            path = os.path.normpath(os.path.abspath(ref.path))
            entry: Union[str, IncludeFile] = ref.text or IncludeFile(path)
            if path not in opened and entry not in includes:
                opened.add(path)
                includes.append(entry)
    return tuple(includes), unreachable, frozenset(opened)


def _apply_payload_limit(types: dict[str, StructType], fe_instances: list[tuple[FeInstance, str | None]],
                         skipped: dict[str, SkippedInstance], opts: BuildOptions, notes: list[Note],
                         relpath: Callable[[str], str], problems: list[str]) -> list[tuple[FeInstance, str | None]]:
    """Every type packing to more than the payload limit, named; a problem (the catalogue is
    refused), or with keep_going its instances are left out (a node refuses such a catalogue)."""
    big = sorted((t for t in types.values() if t.packed_size > opts.max_payload), key=lambda t: (str(t.loc), t.name))
    if not big:
        return fe_instances
    lines = [f"  {t.loc}: {t.name}: {t.packed_size} bytes on the wire" for t in big]
    largest = max(t.packed_size for t in big)
    # What a user must know to choose: one frame carries UB_MAX_PAYLOAD; larger types already travel
    # in fragments, up to UB_MAX_DIRECTORY, which a runtime can raise to 65535 (16-bit reassembled size).
    raise_it = (f"build the runtime with -DUB_MAX_DIRECTORY={largest} and pass --max-payload {largest}"
                if largest <= MAX_DIRECTORY_LIMIT else
                f"no runtime carries more than {MAX_DIRECTORY_LIMIT} bytes (the reassembled size is 16 bits)")
    fix = ("note: a type above one frame (UB_MAX_PAYLOAD, 1024 bytes by default) travels in fragments, up to the "
           f"fragment limit UB_MAX_DIRECTORY ({opts.max_payload} here, --max-payload; at most {MAX_DIRECTORY_LIMIT})\n"
           f"fix: split the type, skip members, leave its instances out with --keep-going, or {raise_it}")
    if not opts.keep_going:
        problems.append(f"error: {len(big)} type(s) pack to more than the payload limit of {opts.max_payload} "
                        "bytes (--max-payload; the runtime's fragment limit UB_MAX_DIRECTORY):\n" + "\n".join(lines)
                        + "\n" + fix)
        return fe_instances
    too_big = {t.name for t in big}
    notes.append(Note("warning", f"{len(big)} type(s) pack to more than the payload limit of {opts.max_payload} "
                                 "bytes; their instances are not catalogued:\n" + "\n".join(lines) + "\n" + fix))
    kept = []
    for inst, qual in fe_instances:
        if inst.type_key in too_big:
            name = inst.name + (f"@{qual}" if qual else "")
            skipped[name] = SkippedInstance(name, SourceLoc(relpath(inst.loc.file), inst.loc.line),
                                            f"larger than the payload limit ({types[inst.type_key].packed_size} > "
                                            f"{opts.max_payload} bytes)")
        else:
            kept.append((inst, qual))
    return kept


def _hints(units: list[FeUnit], instances: list[Instance], skipped: dict[str, SkippedInstance],
           types: dict[str, StructType], opts: BuildOptions, relpath: Callable[[str], str]) -> list[Note]:
    out = []
    if not instances:
        defined = sorted({name for unit in units for name, _ in unit.defined_types})
        if defined:
            example = defined[0]
            var = re.sub(r"\W", "", example.removeprefix("struct ")).removesuffix("_t") or "x"
            more = f" ({', '.join(defined[:5])}{', ...' if len(defined) > 5 else ''})"
            out.append(Note("warning", f"no instance to catalogue: the inputs define {len(defined)} struct type(s){more} "
                                       "but declare no instance of one with external linkage; declare each directory "
                                       f"the system shares, e.g. `extern {example} {var};` in a header the inputs "
                                       "include, or, for objects created at run time behind handles (UAVObjects, "
                                       "uORB topics), make one instance per type with --instance-per-type 'REGEX' "
                                       "or --instances-from FILE (docs/catalogue.md, what is catalogued)"))
        elif not skipped:
            out.append(Note("warning", "no instance to catalogue: the inputs define no struct type and declare no "
                                       "instance (docs/catalogue.md, what is catalogued)"))
    for pat in opts.string_fields:
        if not any(fnmatch.fnmatchcase(f"{t.name}.{f.name}", pat) for t in types.values() for f in t.fields):
            out.append(Note("warning", f"--string-field '{pat}' matches no member (write it as '<type name>.<member>', "
                                       "e.g. 'struct tbl_row.name' or '*.callsign')"))
    return out


def _fmt(loc: SourceLoc, relpath: Callable[[str], str]) -> str:
    return f"{relpath(loc.file)}:{loc.line}"


def _reachable(records: dict[str, FeRecord], roots: set[str]) -> set[str]:
    seen: set[str] = set()
    todo = sorted(roots)
    while todo:
        key = todo.pop()
        if key in seen:
            continue
        seen.add(key)
        todo += [f.type.key for f in records[key].fields if isinstance(f.type, FeRecordRef)]
    return seen


def _make_types(records: dict[str, FeRecord], needed: set[str], relpath: Callable[[str], str],
                opts: BuildOptions) -> dict[str, StructType]:
    done: dict[str, StructType] = {}

    def make(key: str) -> StructType:
        if key in done:
            return done[key]
        rec = records[key]
        fields = tuple(_make_field(f, relpath, opts.string_as_bytes(key, f.name)) for f in rec.fields)
        for f in fields:
            if f.struct:
                make(f.struct)
        canonical = canonical_text(fields, done)
        packed = sum(_field_packed_size(f, done) for f in fields)
        loc = SourceLoc(relpath(rec.loc.file), rec.loc.line)
        done[key] = StructType(rec.key, rec.c_name, rec.size, rec.align, rec.packed, fields, loc, packed,
                               fingerprint(canonical), canonical)
        return done[key]

    for key in sorted(needed):
        make(key)
    return done


_ANONYMOUS_AT = re.compile(r"\((unnamed|anonymous) at ([^():]+):(\d+):(\d+)\)")


def _spelling(text: str, relpath: Callable[[str], str]) -> str:
    """clang spells anonymous records with the header's absolute path; write it relative, so the
    output does not depend on where the tree is checked out."""
    return _ANONYMOUS_AT.sub(lambda m: f"({m[1]} at {relpath(m[2])}:{m[3]}:{m[4]})", text)


# Units in member comments (docs/catalogue.md#units): `[m/s] speed over ground` anywhere a comment starts, or
# the convention of the flightsw headers, a unit then a comma: `/* m/s^2, body axes */`. A unit is made of
# known unit words joined by / * . and raised by ^N; anything else is description only.
_UNIT_WORDS = {"m", "km", "cm", "mm", "ft", "nmi", "s", "ms", "us", "ns", "min", "h", "Hz", "kHz", "rad", "deg", "g",
               "kg", "N", "Pa", "hPa", "kPa", "bar", "K", "C", "degC", "V", "mV", "A", "mA", "W", "J", "T", "G",
               "gauss", "Gauss", "rpm", "%", "dB", "dBm", "B", "kB", "bit", "m/s", "kt", "lsb", "counts", "ppm"}
_UNIT = re.compile(r"^[A-Za-z%°]+(?:\^-?\d+)?(?:[/*.·][A-Za-z%°]+(?:\^-?\d+)?)*$")
_BRACKETED = re.compile(r"^\[([^\]\s][^\]]*)\]\s*(.*)$", re.S)


def parse_comment(comment: str | None) -> tuple[str | None, str | None]:
    """(unit, description) from a member's comment; (None, the comment) when it names no unit."""
    if not comment:
        return None, None
    text = " ".join(comment.split())
    m = _BRACKETED.match(text)
    if m:
        return m.group(1).strip(), (m.group(2).strip() or None)
    head, sep, rest = text.partition(",")
    head = head.strip()
    if (sep or head == text) and _UNIT.match(head) and all(w in _UNIT_WORDS for w in re.split(r"[/*.·]", re.sub(r"\^-?\d+", "", head))):
        return head, rest.strip() or None
    return None, text


def _make_field(f: FeField, relpath: Callable[[str], str], text: bool = False) -> Field:
    loc = SourceLoc(relpath(f.loc.file), f.loc.line)
    t = f.type
    if isinstance(t, (FeOther, FeScalar)):
        t = dataclasses.replace(t, spelling=_spelling(t.spelling, relpath))
    unit, doc = parse_comment(f.comment)
    common = dict(name=f.name, dims=f.dims, offset_bits=f.offset_bits, loc=loc, readonly=f.readonly, unit=unit, doc=doc)
    if f.readonly and f.bit_width is not None:
        return Field(**common, c_spelling=getattr(t, "spelling", ""), skipped=SKIP_CONST_BITFIELD)
    if isinstance(t, FeOther):
        reason = {"pointer": SKIP_POINTER, "union": SKIP_UNION, "flexible": SKIP_FLEXIBLE}.get(t.what)
        return Field(**common, c_spelling=t.spelling, skipped=reason or f"{SKIP_UNSUPPORTED} ({t.spelling})")
    if isinstance(t, FeRecordRef):
        return Field(**common, c_spelling=t.key, struct=t.key)
    return _scalar_field(f, t, common, text)


def _scalar_field(f: FeField, t: FeScalar, common: dict, text: bool = False) -> Field:
    if t.plain_char and f.dims and f.bit_width is None:
        if text:
            return Field(**common, c_spelling=t.spelling, wire=PRIMITIVES["u8"], text=True)
        return Field(**common, c_spelling=t.spelling, skipped=SKIP_STRING)
    enum = t.enum_key if t.is_enum else None
    if f.bit_width is not None:
        wire = PRIMITIVES["bool"] if t.kind == "bool" else bitfield_container(f.bit_width, t.signed)
        return Field(**common, c_spelling=t.spelling, wire=wire, bits=f.bit_width, enum=enum if wire.name != "bool" else None)
    if t.kind == "bool" and t.size == 1:
        return Field(**common, c_spelling=t.spelling, wire=PRIMITIVES["bool"])
    if t.kind == "float" and (t.size in (4, 8) or t.is_long_double):
        wire = PRIMITIVES["f64" if t.is_long_double or t.size == 8 else "f32"]
        return Field(**common, c_spelling=t.spelling, wire=wire, long_double=t.is_long_double)
    if t.kind == "int" and t.size in (1, 2, 4, 8):
        return Field(**common, c_spelling=t.spelling, wire=int_primitive(t.size, t.signed), enum=enum)
    return Field(**common, c_spelling=t.spelling, skipped=f"{SKIP_UNSUPPORTED} ({t.spelling})")


def _field_packed_size(f: Field, types: dict[str, StructType]) -> int:
    if f.wire is not None:
        return f.wire.size * f.count
    if f.struct is not None:
        return types[f.struct].packed_size * f.count
    return 0


def canonical_text(fields: Iterable[Field], types: dict[str, StructType]) -> str:
    """The fingerprinted text: packed fields in order, `name:wire[d]...[/bits]` joined by ';', a nested
    struct written as `name:{...}[d]` with its own text inside. The type's own name is not part of it."""
    items = []
    for f in fields:
        if not f.packed:
            continue
        wire = "{" + types[f.struct].canonical + "}" if f.struct else f.wire_name
        dims = "".join(f"[{d}]" for d in f.dims)
        bits = f"/{f.bits}" if f.bits is not None else ""
        items.append(f"{f.name}:{wire}{dims}{bits}")
    return ";".join(items)


def fingerprint(canonical: str) -> int:
    """First 4 bytes of SHA-256 over the canonical text (UTF-8), read little-endian."""
    return int.from_bytes(hashlib.sha256(canonical.encode("utf-8")).digest()[:4], "little")


def _expand_instances(fe: list[tuple[FeInstance, str | None]], scheme: str, relpath: Callable[[str], str]) -> list[Instance]:
    out = []
    for inst, qual in fe:
        loc = SourceLoc(relpath(inst.loc.file), inst.loc.line)
        for index in product(*(range(d) for d in inst.dims)):
            name = inst.name + "".join(f"[{i}]" for i in index) + (f"@{qual}" if qual else "")
            try:
                ident = ids.dir_id(name, scheme)
            except ids.IdError as exc:
                raise ModelError(f"{loc}: error: {exc}") from exc
            out.append(Instance(name, inst.type_key, ident, loc, inst.name, tuple(index), qual, inst.runtime))
    return out


def _check_unique(instances: list[Instance], scheme: str) -> None:
    groups: dict[bytes, list[Instance]] = {}
    for inst in instances:
        groups.setdefault(inst.id, []).append(inst)
    clashes = [sorted(g, key=lambda i: i.name) for g in groups.values() if len(g) > 1]
    if not clashes:
        return
    lines = [f"error: {len(clashes)} group(s) of instances share a content ID under the '{scheme}' rule:"]
    for group in sorted(clashes, key=lambda g: g[0].name):
        lines.append(f"  ID {format_id(group[0].id)}:")
        lines += [f"    {i.loc}: {i.name}" for i in group]
    lines.append(
        "fix: rename the instances so their first 8 and last 8 characters differ, or generate with "
        "`--id-scheme hashed` on every node of the system (the scheme is part of the catalogue)."
        if scheme == "paper"
        else "fix: rename the instances (the hashed scheme cannot tell these names apart)."
    )
    raise CollisionError("\n".join(lines))


def format_id(raw: bytes) -> str:
    """An ID for humans: printable characters as-is, others as \\xNN."""
    return '"' + "".join(chr(b) if 0x20 <= b < 0x7F and b != 0x22 else f"\\x{b:02x}" for b in raw) + '"'


# ---------------------------------------------------------------------------------------------
# Self-test values: computed once here, emitted into both the C and the Python self-test.


Path = tuple[Union[str, int], ...]


@dataclass(frozen=True)
class Leaf:
    path: Path  # field names and array indexes from the top of the type
    field: Field
    value: Union[int, float, bool]


def test_leaves(cat: Catalogue, t: StructType) -> list[Leaf]:
    """One deterministic value per packed scalar, in wire order."""
    counter = iter(range(1 + t.fingerprint % 101, 1 << 62))
    return list(_leaves(cat, t, (), counter))


def _leaves(cat: Catalogue, t: StructType, prefix: Path, counter: Iterator[int]) -> Iterator[Leaf]:
    for f in t.packed_fields:
        for index in product(*(range(d) for d in f.dims)):
            path = prefix + (f.name,) + index
            if f.struct:
                yield from _leaves(cat, cat.type(f.struct), path, counter)
            else:
                yield Leaf(path, f, test_value(f, next(counter)))


def test_value(f: Field, k: int) -> Union[int, float, bool]:
    """A value that fits the field exactly (floats are exact binary fractions; text is printable
    ASCII with a NUL now and then, so bytes after a terminator travel too)."""
    assert f.wire is not None
    if f.wire.name == "bool":
        return k % 2 == 1
    if f.wire.name == "f32":
        return (k * 37 % 4096) * 0.25 - 512.0
    if f.wire.name == "f64":
        return (k * 7919 % 100003) * 0.125 - 6000.5
    if f.text:
        return 0 if k % 11 == 0 else 32 + (k * 7) % 95
    width = f.bits if f.bits is not None else f.wire.bits
    span = (1 << width) - 1  # signed values stay in [-(2^(w-1)-1), 2^(w-1)-1]
    raw = (k * 2654435761 + 40503) % span if span else 0
    return raw + 1 - (1 << (width - 1)) if f.wire.signed else raw


def expected_packed(cat: Catalogue, t: StructType) -> bytes:
    """The test values packed by an independent per-leaf encoder (the oracle for both self-tests)."""
    return b"".join(struct.pack("<" + leaf.field.wire.py_format, leaf.value) for leaf in test_leaves(cat, t))  # type: ignore[union-attr]


def expected_digest(cat: Catalogue) -> int:
    crc = 0
    for t in cat.named_types:
        crc = zlib.crc32(expected_packed(cat, t), crc)
    return crc


def value_tree(leaves: list[Leaf], cat: Catalogue, t: StructType) -> dict:
    """The test values as the nested dict `to_dict()` returns (arrays as nested lists; a text
    member's innermost dimension as one `bytes`)."""
    flat = {leaf.path: leaf.value for leaf in leaves}
    return _tree(cat, t, (), flat)


def _tree(cat: Catalogue, t: StructType, prefix: Path, flat: dict) -> dict:
    out: dict = {}
    for f in t.packed_fields:
        out[f.name] = _tree_dims(cat, f, prefix + (f.name,), f.dims, flat)
    return out


def _tree_dims(cat: Catalogue, f: Field, prefix: Path, dims: tuple[int, ...], flat: dict):
    if f.text and len(dims) == 1:
        return bytes(flat[prefix + (i,)] for i in range(dims[0]))
    if dims:
        return [_tree_dims(cat, f, prefix + (i,), dims[1:], flat) for i in range(dims[0])]
    if f.struct:
        return _tree(cat, cat.type(f.struct), prefix, flat)
    return flat[prefix]


@dataclass(frozen=True)
class WireCheck:
    """A scalar whose wire bytes unpack may refuse (Field.checked) or whose value may not come
    back bit for bit (a long double's NaN payload): where it sits in a packed image of its type."""

    offset: int  # byte offset in the packed image
    leaf: int  # index in the flat value tuple of the type's Python struct (a text row is one value)
    field: Field

    @property
    def kind(self) -> str:
        """'bool', 'bits' (a bitfield narrower than its container), 'ldouble' or 'f32'."""
        assert self.field.wire is not None
        if self.field.wire.name == "bool":
            return "bool"
        if self.field.checked:
            return "bits"
        return "ldouble" if self.field.long_double else "f32"


def wire_checks(cat: Catalogue, t: StructType, f32: bool = False) -> list[WireCheck]:
    """Every checked scalar and every long double of `t` (and every f32 with `f32`: Python's struct
    quiets a signalling NaN), nested ones included, in wire order."""
    out: list[WireCheck] = []
    _walk_checks(cat, t, 0, [0], out, f32)
    return out


def _walk_checks(cat: Catalogue, t: StructType, base: int, leaf: list[int], out: list[WireCheck], f32: bool) -> int:
    at = base
    for f in t.packed_fields:
        if f.text:  # one bytes value per innermost row in Python's flat tuple
            at += f.count
            leaf[0] += f.count // f.dims[-1]
            continue
        for _ in range(f.count):
            if f.struct:
                at = _walk_checks(cat, cat.type(f.struct), at, leaf, out, f32)
                continue
            assert f.wire is not None
            if f.checked or f.long_double or (f32 and f.wire.name == "f32"):
                out.append(WireCheck(at, leaf[0], f))
            at += f.wire.size
            leaf[0] += 1
    return at


# ---------------------------------------------------------------------------------------------
# Paths


def make_relpath(inputs: list[str], cwd: str | None = None) -> Callable[[str], str]:
    """Paths as written into outputs: relative to the current directory when the inputs lie below
    it, else to the inputs' common root, so output does not depend on where the tree is checked out."""
    here = os.path.abspath(cwd or os.getcwd())
    absolute = [os.path.abspath(p) for p in inputs]
    below = all(os.path.commonpath([here, p]) == here for p in absolute) if absolute else True
    root = here if below else os.path.commonpath([os.path.dirname(p) for p in absolute])

    def rel(path: str) -> str:
        if path.startswith("<"):
            return path
        return os.path.relpath(os.path.abspath(path), root).replace(os.sep, "/")

    return rel


_IDENT = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


def is_identifier(text: str) -> bool:
    return bool(_IDENT.match(text))
