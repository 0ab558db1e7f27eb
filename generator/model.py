"""The validated, immutable catalogue model: what is packed, how, and under which IDs.

Built from front-end records (frontend.py) by build_catalogue(); every dataclass checks itself on
construction, so a model that exists is consistent. Also computes layout fingerprints and the
deterministic self-test values (mavgen `gen_test_value` style) shared by the C and Python checks.
"""

from __future__ import annotations

import dataclasses
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
from .frontend import FeField, FeInstance, FeOther, FeRecord, FeRecordRef, FeScalar, FeUnit, SourceLoc


class ModelError(Exception):
    """A catalogue that must not be generated. exit_code: 1 = uniqueness, 2 = input problem."""

    exit_code = 2


class DuplicateDefinitionError(ModelError):
    exit_code = 1


class CollisionError(ModelError):
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


# ---------------------------------------------------------------------------------------------
# Model classes


@dataclass(frozen=True)
class Field:
    """One member of a struct. Exactly one of `wire` (a packed scalar or bitfield), `struct` (a
    nested struct, by StructType.name) or `skipped` (the reason it is not on the wire) is set."""

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
class Instance:
    """One catalogued instance; an array element is its own instance, named `base[i][j]`."""

    name: str
    type: str  # StructType.name
    id: bytes
    loc: SourceLoc
    base: str
    index: tuple[int, ...]

    def __post_init__(self) -> None:
        if len(self.id) != ids.DIR_ID_LEN:
            raise ValueError(f"{self.loc}: ID of {self.name} is not {ids.DIR_ID_LEN} bytes")
        if self.name != self.base + "".join(f"[{i}]" for i in self.index):
            raise ValueError(f"{self.loc}: element name {self.name} does not match {self.base}{list(self.index)}")

    @property
    def ident(self) -> str:
        """A C identifier fragment: `name[1][2]` -> `name_1_2`."""
        return self.base + "".join(f"_{i}" for i in self.index)


@dataclass(frozen=True)
class SkippedInstance:
    name: str
    loc: SourceLoc
    reason: str


@dataclass(frozen=True)
class Catalogue:
    id_scheme: str
    types: tuple[StructType, ...]  # sorted by name
    instances: tuple[Instance, ...]  # sorted by ID
    skipped_instances: tuple[SkippedInstance, ...] = ()

    def __post_init__(self) -> None:
        if self.id_scheme not in ids.ID_SCHEMES:
            raise ValueError(f"unknown ID scheme {self.id_scheme}")
        by_name = {t.name: t for t in self.types}
        if len(by_name) != len(self.types) or [t.name for t in self.types] != sorted(by_name):
            raise ValueError("types must be unique and sorted by name")
        for t in self.types:
            for f in t.fields:
                if f.struct is not None and f.struct not in by_name:
                    raise ValueError(f"{f.loc}: {t.name}.{f.name} needs type {f.struct}, not in the catalogue")
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

    def type(self, name: str) -> StructType:
        for t in self.types:
            if t.name == name:
                return t
        raise KeyError(name)

    @property
    def named_types(self) -> tuple[StructType, ...]:
        """Types with a C spelling: the ones with codecs in C and in the self-test."""
        return tuple(t for t in self.types if t.c_name is not None)

    @property
    def max_packed_size(self) -> int:
        return max((t.packed_size for t in self.types), default=0)


def _dupes(items: Iterable[str]) -> set[str]:
    seen: set[str] = set()
    return {x for x in items if x in seen or seen.add(x)}  # type: ignore[func-returns-value]


# ---------------------------------------------------------------------------------------------
# Building


def build_catalogue(units: list[FeUnit], id_scheme: str = "paper", relpath: Callable[[str], str] = str) -> Catalogue:
    """The union of all translation units: checks duplicates, IDs and uniqueness."""
    records = _merge_records(units, relpath)
    fe_instances = _merge_instances(units, relpath)
    needed = _reachable(records, {i.type_key for i in fe_instances})
    types = _make_types(records, needed, relpath)
    instances = _expand_instances(fe_instances, id_scheme, relpath)
    _check_unique(instances, id_scheme)
    skipped = _merge_skipped(units, relpath)
    return Catalogue(id_scheme, tuple(types[k] for k in sorted(types)), tuple(sorted(instances, key=lambda i: i.id)), skipped)


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
    fields = tuple((f.name, f.type, f.dims, f.offset_bits, f.bit_width) for f in rec.fields)
    return (rec.c_name, rec.size, rec.align, rec.packed, fields)


def _merge_instances(units: list[FeUnit], relpath: Callable[[str], str]) -> list[FeInstance]:
    merged: dict[str, FeInstance] = {}
    for unit in units:
        for inst in unit.instances:
            old = merged.get(inst.name)
            if old is None:
                merged[inst.name] = inst
            elif (old.type_key, old.dims) != (inst.type_key, inst.dims):
                a, b = sorted((_fmt(old.loc, relpath), _fmt(inst.loc, relpath)))
                raise DuplicateDefinitionError(
                    f"{a}: error: instance '{inst.name}' is declared with another type here and at {b} "
                    f"({_decl_text(old)} vs {_decl_text(inst)})"
                )
            elif _loc_key(inst.loc, relpath) < _loc_key(old.loc, relpath):
                merged[inst.name] = inst
    return [merged[k] for k in sorted(merged)]


def _decl_text(inst: FeInstance) -> str:
    return inst.type_key + "".join(f"[{d}]" for d in inst.dims)


def _merge_skipped(units: list[FeUnit], relpath: Callable[[str], str]) -> tuple[SkippedInstance, ...]:
    found: dict[str, SkippedInstance] = {}
    for unit in units:
        for name, loc, reason in unit.skipped_instances:
            found.setdefault(name, SkippedInstance(name, SourceLoc(relpath(loc.file), loc.line), reason))
    return tuple(found[k] for k in sorted(found))


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


def _make_types(records: dict[str, FeRecord], needed: set[str], relpath: Callable[[str], str]) -> dict[str, StructType]:
    done: dict[str, StructType] = {}

    def make(key: str) -> StructType:
        if key in done:
            return done[key]
        rec = records[key]
        fields = tuple(_make_field(f, relpath) for f in rec.fields)
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


def _make_field(f: FeField, relpath: Callable[[str], str]) -> Field:
    loc = SourceLoc(relpath(f.loc.file), f.loc.line)
    t = f.type
    if isinstance(t, FeOther):
        t = dataclasses.replace(t, spelling=_spelling(t.spelling, relpath))
    common = dict(name=f.name, dims=f.dims, offset_bits=f.offset_bits, loc=loc)
    if isinstance(t, FeOther):
        reason = {"pointer": SKIP_POINTER, "union": SKIP_UNION, "flexible": SKIP_FLEXIBLE}.get(t.what)
        return Field(**common, c_spelling=t.spelling, skipped=reason or f"{SKIP_UNSUPPORTED} ({t.spelling})")
    if isinstance(t, FeRecordRef):
        return Field(**common, c_spelling=t.key, struct=t.key)
    return _scalar_field(f, t, common)


def _scalar_field(f: FeField, t: FeScalar, common: dict) -> Field:
    if t.plain_char and f.dims:
        return Field(**common, c_spelling=t.spelling, skipped=SKIP_STRING)
    if f.bit_width is not None:
        wire = PRIMITIVES["bool"] if t.kind == "bool" else bitfield_container(f.bit_width, t.signed)
        return Field(**common, c_spelling=t.spelling, wire=wire, bits=f.bit_width)
    if t.kind == "bool" and t.size == 1:
        return Field(**common, c_spelling=t.spelling, wire=PRIMITIVES["bool"])
    if t.kind == "float" and (t.size in (4, 8) or t.is_long_double):
        wire = PRIMITIVES["f64" if t.is_long_double or t.size == 8 else "f32"]
        return Field(**common, c_spelling=t.spelling, wire=wire, long_double=t.is_long_double)
    if t.kind == "int" and t.size in (1, 2, 4, 8):
        return Field(**common, c_spelling=t.spelling, wire=int_primitive(t.size, t.signed))
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


def _expand_instances(fe: list[FeInstance], scheme: str, relpath: Callable[[str], str]) -> list[Instance]:
    out = []
    for inst in fe:
        loc = SourceLoc(relpath(inst.loc.file), inst.loc.line)
        for index in product(*(range(d) for d in inst.dims)):
            name = inst.name + "".join(f"[{i}]" for i in index)
            try:
                ident = ids.dir_id(name, scheme)
            except ids.IdError as exc:
                raise ModelError(f"{loc}: error: {exc}") from exc
            out.append(Instance(name, inst.type_key, ident, loc, inst.name, tuple(index)))
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
    """A value that fits the field exactly (floats are exact binary fractions)."""
    assert f.wire is not None
    if f.wire.name == "bool":
        return k % 2 == 1
    if f.wire.name == "f32":
        return (k * 37 % 4096) * 0.25 - 512.0
    if f.wire.name == "f64":
        return (k * 7919 % 100003) * 0.125 - 6000.5
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
    """The test values as the nested dict `to_dict()` returns (arrays as nested lists)."""
    flat = {leaf.path: leaf.value for leaf in leaves}
    return _tree(cat, t, (), flat)


def _tree(cat: Catalogue, t: StructType, prefix: Path, flat: dict) -> dict:
    out: dict = {}
    for f in t.packed_fields:
        out[f.name] = _tree_dims(cat, f, prefix + (f.name,), f.dims, flat)
    return out


def _tree_dims(cat: Catalogue, f: Field, prefix: Path, dims: tuple[int, ...], flat: dict):
    if dims:
        return [_tree_dims(cat, f, prefix + (i,), dims[1:], flat) for i in range(dims[0])]
    if f.struct:
        return _tree(cat, cat.type(f.struct), prefix, flat)
    return flat[prefix]


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
