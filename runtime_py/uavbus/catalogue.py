"""A directory catalogue read from `<name>.catalogue.json`: types with their wire layout, instances
with their content IDs, dict <-> bytes codecs, and the C `ub_catalogue_t` the router runs on.

The wire format (docs/wire-format.md, generator/model.py) is little-endian with no padding: every
packed member in declaration order, arrays row-major, nested structs inline, a bitfield as its own
whole container (the `wire` type of the field), `long double` as f64, skipped members absent; a
`text` member (a char array sent as data) is one `bytes` per innermost row. This module derives
that layout from the JSON alone, so any process can decode a catalogue it did not build (binary
logs embed the JSON), and the result is byte-identical to the generated `<name>.py`. Like the
generated codecs, decoding refuses what no encoder writes (DecodeError): a bool byte other than 0/1
and a bitfield value wider than its field. Enum constants: `Catalogue.enums`, `Field.enum`.

Pure Python: the cffi extension is imported only when `c_catalogue` is first used.
"""

from __future__ import annotations

import json
import math
import struct
from dataclasses import dataclass, field
from itertools import product
from pathlib import Path
from typing import Any, Callable, Iterator, Union

Value = Union[int, float, bool]

# Wire type -> (struct code, size). Same table as generator/model.py PRIMITIVES.
WIRE_TYPES: dict[str, tuple[str, int]] = {
    "bool": ("?", 1), "u8": ("B", 1), "i8": ("b", 1), "u16": ("H", 2), "i16": ("h", 2),
    "u32": ("I", 4), "i32": ("i", 4), "u64": ("Q", 8), "i64": ("q", 8), "f32": ("f", 4), "f64": ("d", 8),
}


class CatalogueError(ValueError):
    """A catalogue document that cannot be used (says which file/type/field and why)."""


class EncodeError(ValueError):
    """A value that does not fit its field; the message names the field path."""


class DecodeError(ValueError):
    """A packed image holding what no encoder writes (a bool byte other than 0/1, a bitfield value
    wider than its field); the message names the member. The generated C unpack refuses the same
    (UB_ERR_RANGE)."""


@dataclass(frozen=True)
class Field:
    """One member of a type as the catalogue lists it. `wire` is a wire type name, "struct" (then
    `struct` names the nested type) or None for a skipped member (`skipped` says why)."""

    name: str
    wire: str | None
    struct: str | None
    dims: tuple[int, ...]
    bits: int | None
    long_double: bool
    skipped: str | None
    c_offset: int  # byte offset in the C struct (clang), for reference only
    wire_offset: int = -1  # byte offset in the packed image; -1 for skipped members
    wire_size: int = 0  # packed bytes of the whole member (all elements)
    enum: str | None = None  # the member's enum type (Catalogue.enums[enum] holds its constants)
    text: bool = False  # a char array sent as data: one `bytes` per innermost row

    @property
    def packed(self) -> bool:
        return self.skipped is None

    @property
    def count(self) -> int:
        return math.prod(self.dims)

    @property
    def is_struct(self) -> bool:
        return self.struct is not None


@dataclass(frozen=True)
class Type:
    """One struct type with its packed layout. `fields` lists every member (skipped ones too)."""

    name: str
    c_name: str | None
    c_size: int
    packed_size: int
    fingerprint: int
    fields: tuple[Field, ...]
    # Compiled codec, filled by the Catalogue (it needs the other types).
    _struct: struct.Struct = field(repr=False, compare=False, default=struct.Struct("<"))
    _flatten: Callable[[Any, list, str], None] = field(repr=False, compare=False, default=lambda d, out, p: None)
    _build: Callable[[tuple, int], tuple[dict, int]] = field(repr=False, compare=False, default=lambda v, i: ({}, i))
    # Per packed member: (struct.Struct of the member alone, flattener, builder), for Directory access.
    _members: dict[str, tuple[struct.Struct, Any, Any]] = field(repr=False, compare=False, default_factory=dict)
    # Nested types by name (for views on nested members).
    _subtypes: dict[str, "Type"] = field(repr=False, compare=False, default_factory=dict)
    # Plain scalar members (no array, no nested struct, no bitfield range to check): name ->
    # (struct.Struct, wire offset), so a Directory reads and writes them with one pack_into/unpack_from.
    _scalars: dict[str, tuple[Any, int]] = field(repr=False, compare=False, default_factory=dict)
    # What decoding refuses: byte offsets of bools, and (index in the flat value tuple, lowest,
    # highest, member) per bitfield narrower than its container, nested members included.
    _bool_at: tuple[int, ...] = field(repr=False, compare=False, default=())
    _ranges: tuple[tuple[int, int, int, str], ...] = field(repr=False, compare=False, default=())
    _nleaves: int = field(repr=False, compare=False, default=0)  # values in the flat tuple of _struct
    # (byte offset, size) of every bool and narrow-bitfield container, nested members included.
    refusable: tuple[tuple[int, int], ...] = field(repr=False, compare=False, default=())

    @property
    def packed_fields(self) -> tuple[Field, ...]:
        return tuple(f for f in self.fields if f.packed)

    def field(self, name: str) -> Field:
        for f in self.fields:
            if f.name == name and f.packed:
                return f
        raise KeyError(f"type {self.name} has no packed member {name!r} "
                       f"(members: {', '.join(f.name for f in self.packed_fields)})")


@dataclass(frozen=True)
class Instance:
    """One catalogued instance: its position in the ID-sorted table (= the C instance index)."""

    index: int
    name: str
    id: bytes
    type: Type


class Catalogue:
    """A loaded catalogue. Look instances up by name or ID; encode/decode their values."""

    def __init__(self, doc: dict[str, Any], origin: str = "<catalogue>") -> None:
        # A damaged catalogue (a log's embedded copy, a hand-edited file) is bad input whatever the parser
        # met in it: always a CatalogueError naming the origin, never a KeyError from deep inside.
        try:
            self._load(doc, origin)
        except CatalogueError:
            raise
        except (KeyError, TypeError, ValueError, AttributeError, IndexError, RecursionError) as exc:
            detail = f"missing {exc}" if isinstance(exc, KeyError) else f"{type(exc).__name__}: {exc}"
            raise CatalogueError(f"{origin}: not a usable uavbus catalogue ({detail}); regenerate it with "
                                 "`uavbus gen`") from None

    def _load(self, doc: dict[str, Any], origin: str) -> None:
        self.origin = origin
        try:
            self.name: str = doc["catalogue"]
            self.abi_version: int = int(doc["abi_version"])
            self.id_scheme: str = doc["id_scheme"]
            raw_types = {t["name"]: t for t in doc["types"]}
            raw_instances = doc["instances"]
        except (KeyError, TypeError) as exc:
            raise CatalogueError(f"{origin}: not a uavbus catalogue document (missing {exc})") from exc
        if self.id_scheme not in ("paper", "hashed"):
            raise CatalogueError(f"{origin}: unknown id_scheme {self.id_scheme!r}")
        self._json_compact = json.dumps(doc, separators=(",", ":"), ensure_ascii=True)
        raw_enums = doc.get("enums") or {}  # absent in catalogues written before enums were recorded
        if not isinstance(raw_enums, dict) or not all(isinstance(v, dict) for v in raw_enums.values()):
            raise CatalogueError(f"{origin}: 'enums' must map enum names to {{constant: value}}")
        self._enums: dict[str, dict[str, int]] = {k: {c: int(v) for c, v in consts.items()} for k, consts in raw_enums.items()}
        self._types: dict[str, Type] = {}
        for name in raw_types:
            self._make_type(name, raw_types, ())
        instances = []
        for k, raw in enumerate(raw_instances):
            t = self._types.get(raw["type"])
            if t is None:
                raise CatalogueError(f"{origin}: instance {raw['name']} has unknown type {raw['type']!r}")
            instances.append(Instance(k, raw["name"], bytes.fromhex(raw["id"]), t))
        ids = [i.id for i in instances]
        if ids != sorted(set(ids)) or any(len(i) != 16 for i in ids):
            raise CatalogueError(f"{origin}: instance IDs must be 16 bytes, unique and sorted (regenerate it)")
        self.instances: tuple[Instance, ...] = tuple(instances)
        self._by_name = {i.name: i for i in instances}
        self._by_id = {i.id: i for i in instances}
        self._c_built: Any = None  # the tier-2 CCatalogue (owns the C arrays)

    # -- construction --------------------------------------------------------------------------
    @classmethod
    def load(cls, path: str | Path) -> "Catalogue":
        """Reads `<name>.catalogue.json` (pretty or compact)."""
        p = Path(path)
        try:
            text = p.read_text(encoding="utf-8")
        except OSError as exc:
            raise CatalogueError(f"{p}: cannot read the catalogue: {exc.strerror}") from exc
        return cls.from_json_text(text, origin=str(p))

    @classmethod
    def from_json_text(cls, text: str | bytes, origin: str = "<catalogue>") -> "Catalogue":
        """Parses catalogue JSON text (e.g. the copy embedded in a binary log header)."""
        try:
            doc = json.loads(text)
        except json.JSONDecodeError as exc:
            raise CatalogueError(f"{origin}:{exc.lineno}: invalid JSON: {exc.msg}") from exc
        except (UnicodeDecodeError, RecursionError) as exc:
            raise CatalogueError(f"{origin}: not a uavbus catalogue ({type(exc).__name__}: {exc})") from None
        return cls(doc, origin)

    def _make_type(self, name: str, raw_types: dict[str, Any], stack: tuple[str, ...]) -> Type:
        done = self._types.get(name)
        if done is not None:
            return done
        if name in stack:
            raise CatalogueError(f"{self.origin}: type {name} contains itself")
        raw = raw_types.get(name)
        if raw is None:
            raise CatalogueError(f"{self.origin}: type {stack[-1] if stack else '?'} needs {name!r}, not in the catalogue")
        fields: list[Field] = []
        at = 0
        fmt: list[str] = []
        bool_at: list[int] = []
        ranges: list[tuple[int, int, int, str]] = []
        spans: list[tuple[int, int]] = []  # Type.refusable
        leaves = 0
        for rf in raw["fields"]:
            dims = tuple(int(d) for d in rf.get("count") or ())
            f = Field(rf["name"], rf["wire"], rf.get("struct"), dims, rf.get("bits"), bool(rf.get("long_double")),
                      rf.get("skipped"), int(rf.get("offset", 0)), enum=rf.get("enum"), text=bool(rf.get("text")))
            if f.enum is not None and f.enum not in self._enums:
                raise CatalogueError(f"{self.origin}: {name}.{f.name}: enum {f.enum!r} is not in 'enums'")
            if f.skipped is None:
                count = f.count
                if f.wire == "struct":
                    sub = self._make_type(f.struct or "", raw_types, stack + (name,))
                    size = sub.packed_size * count
                    fmt.append(sub._struct.format.lstrip("<") * count)
                    for k in range(count):
                        spans += [(at + k * sub.packed_size + o, n) for o, n in sub.refusable]
                        bool_at += [at + k * sub.packed_size + o for o in sub._bool_at]
                        ranges += [(leaves + k * sub._nleaves + i, lo, hi, m) for i, lo, hi, m in sub._ranges]
                    leaves += count * sub._nleaves
                elif f.text and f.wire == "u8" and dims:
                    size = count
                    fmt.append(f"{dims[-1]}s" * (count // dims[-1]))
                    leaves += count // dims[-1]
                elif f.wire in WIRE_TYPES:
                    code, one = WIRE_TYPES[f.wire]
                    size = one * count
                    fmt.append(f"{count}{code}" if count > 1 else code)
                    if f.wire == "bool":
                        bool_at += [at + k for k in range(count)]
                        spans += [(at + k, 1) for k in range(count)]
                    limits = _range_of(f)
                    if limits is not None:
                        ranges.append((leaves, limits[0], limits[1], f.name))
                        spans.append((at, one))
                    leaves += count
                else:
                    raise CatalogueError(f"{self.origin}: {name}.{f.name}: unknown wire type {f.wire!r}")
                f = Field(f.name, f.wire, f.struct if f.wire == "struct" else None, dims, f.bits, f.long_double,
                          None, f.c_offset, at, size, f.enum, f.text)
                at += size
            fields.append(f)
        if at != raw["packed_size"]:
            raise CatalogueError(f"{self.origin}: {name}: fields pack to {at} bytes but packed_size says "
                                 f"{raw['packed_size']} (regenerate the catalogue with this uavbus version)")
        t = Type(name, raw.get("c_name"), int(raw.get("size", 0)), at, int(raw["fingerprint"], 16), tuple(fields),
                 struct.Struct("<" + "".join(fmt)), _bool_at=tuple(bool_at), _ranges=tuple(ranges), _nleaves=leaves, refusable=tuple(spans))
        t = _with_codec(t, self._types)
        self._types[name] = t
        return t

    # -- lookup --------------------------------------------------------------------------------
    @property
    def types(self) -> tuple[Type, ...]:
        """Every type, sorted by name."""
        return tuple(self._types[k] for k in sorted(self._types))

    def type(self, name: str) -> Type:
        """A type by its catalogue name ("struct gps_out", "waypoint_t", ...)."""
        try:
            return self._types[name]
        except KeyError:
            raise KeyError(f"catalogue {self.name} has no type {name!r}") from None

    def instance(self, name: str) -> Instance:
        """An instance by name ("gpsOut", "batteryCell[0][3]")."""
        try:
            return self._by_name[name]
        except KeyError:
            raise KeyError(f"catalogue {self.name} has no instance {name!r}") from None

    def instance_by_id(self, dir_id: bytes) -> Instance:
        """An instance by its 16-byte content ID (KeyError if unknown)."""
        try:
            return self._by_id[bytes(dir_id)]
        except KeyError:
            raise KeyError(f"catalogue {self.name} has no instance with ID {bytes(dir_id).hex()}") from None

    def find(self, name_or_id: str | bytes) -> Instance | None:
        """An instance by name or 16-byte ID, or None."""
        if isinstance(name_or_id, (bytes, bytearray, memoryview)):
            return self._by_id.get(bytes(name_or_id))
        return self._by_name.get(name_or_id)

    def type_of(self, what: str | Instance | Type) -> Type:
        """The type of an instance (by name), or a type given by its own name."""
        if isinstance(what, Type):
            return what
        if isinstance(what, Instance):
            return what.type
        inst = self._by_name.get(what)
        if inst is not None:
            return inst.type
        if what in self._types:
            return self._types[what]
        raise KeyError(f"catalogue {self.name} has no instance or type {what!r}")

    @property
    def enums(self) -> dict[str, dict[str, int]]:
        """Enum constants the members use: enum type name ("enum tag", a typedef name, or
        "<parent>::<member>") -> {constant: value} in declaration order; {} for a catalogue written
        before enums were recorded. A copy: changing it changes nothing here."""
        return {k: dict(v) for k, v in self._enums.items()}

    def enum_of(self, what: str | Instance | Type, member: str) -> dict[str, int] | None:
        """The constants of `member`'s enum (a member of an instance or type), or None when the
        member is not of an enum type (or the catalogue predates enums)."""
        f = self.type_of(what).field(member)
        return dict(self._enums[f.enum]) if f.enum is not None else None

    def __contains__(self, name: object) -> bool:
        return name in self._by_name

    def __len__(self) -> int:
        return len(self.instances)

    def __iter__(self) -> Iterator[Instance]:
        return iter(self.instances)

    @property
    def max_packed_size(self) -> int:
        """The largest packed image of any type (bytes)."""
        return max((t.packed_size for t in self._types.values()), default=0)

    @property
    def json_text(self) -> str:
        """The compact catalogue JSON (what ub_catalogue_t.json holds and logs embed)."""
        return self._json_compact

    # -- codecs --------------------------------------------------------------------------------
    def encode(self, what: str | Instance | Type, value: dict[str, Any]) -> bytes:
        """The packed wire image of `value` (a nested dict as `decode` returns; every packed member
        must be present). Raises EncodeError naming the member that is missing or does not fit."""
        return encode_type(self.type_of(what), value)

    def decode(self, what: str | Instance | Type, payload: bytes) -> dict[str, Any]:
        """The nested dict of a packed image (the first packed_size bytes of `payload`)."""
        return decode_type(self.type_of(what), payload)

    def default(self, what: str | Instance | Type) -> dict[str, Any]:
        """All-zero value of a type (what a fresh wire image decodes to)."""
        t = self.type_of(what)
        return decode_type(t, bytes(t.packed_size))

    # -- C view --------------------------------------------------------------------------------
    @property
    def c_catalogue(self) -> Any:
        """A `const ub_catalogue_t *` for the C router, built once and owned by this object: types
        with pack/unpack NULL (bound storage is the wire image), instances in ID order."""
        if self._c_built is None:
            from uavbus._bindings.ub_catalogue import build_c_catalogue

            self._c_built = build_c_catalogue(self)
        return self._c_built.catalogue

    @property
    def named_types(self) -> tuple[Type, ...]:
        """Types with a C spelling (the C catalogue's `types` array), in catalogue order."""
        return tuple(t for t in self.types if t.c_name is not None)

    def __repr__(self) -> str:
        return f"<Catalogue {self.name}: {len(self._types)} types, {len(self.instances)} instances>"


# ---------------------------------------------------------------------------------------------
# Codec compilation: per type, a flattener (dict -> leaf list, with range checks) and a builder
# (leaf tuple -> dict), both closures over the field list so encode/decode do no lookups.


def encode_type(t: Type, value: dict[str, Any]) -> bytes:
    leaves: list[Value] = []
    t._flatten(value, leaves, "")
    try:
        return t._struct.pack(*leaves)
    except struct.error as exc:  # a float into an int, or a value outside the container
        raise EncodeError(f"{t.name}: {exc} (check the value types)") from exc


def decode_type(t: Type, payload: bytes) -> dict[str, Any]:
    if len(payload) < t.packed_size:
        raise ValueError(f"{t.name} needs {t.packed_size} bytes, got {len(payload)}")
    values = t._struct.unpack_from(payload)
    if t._bool_at or t._ranges:
        _check_wire(t, payload, values)
    out, _ = t._build(values, 0)
    return out


def refused(t: Type, payload: bytes) -> str | None:
    """Why every codec refuses this packed image of `t` (a bool byte other than 0/1, a bitfield
    value outside its width), or None when it decodes; cheap for types without such members."""
    if not (t._bool_at or t._ranges) or len(payload) < t.packed_size:
        return None
    try:
        _check_wire(t, payload, t._struct.unpack_from(payload))
    except DecodeError as exc:
        return str(exc)
    return None


def _check_wire(t: Type, payload: Any, values: tuple) -> None:
    """DecodeError if the image holds what no encoder writes (same rule as the generated codecs)."""
    for off in t._bool_at:
        b = payload[off]
        if b > 1:
            raise DecodeError(f"{t.name}: bool byte {b} at offset {off} is not 0 or 1")
    for k, lo, hi, member in t._ranges:
        if not lo <= values[k] <= hi:
            raise DecodeError(f"{t.name}.{member}: {values[k]} does not fit the bitfield's range [{lo}, {hi}]")


def read_member(t: Type, name: str, buf: Any, offset: int) -> Any:
    """Member `name` of a packed image of `t` held in `buf` at `offset` (scalar, nested lists, dict).
    DecodeError if the member holds what no encoder writes."""
    f = t.field(name)
    s, _, build = t._members[name]
    values = s.unpack_from(buf, offset + f.wire_offset)
    sub = t._subtypes.get(f.struct) if f.struct else None
    if f.wire == "bool" or sub is not None and (sub._bool_at or sub._ranges):
        image = bytes(buf[offset + f.wire_offset:offset + f.wire_offset + f.wire_size])
        for k in range(f.count if sub is not None else 0):
            _check_wire(sub, image[k * sub.packed_size:], values[k * sub._nleaves:])  # type: ignore[union-attr]
        if f.wire == "bool" and any(b > 1 for b in image):
            raise DecodeError(f"{t.name}.{name}: a bool byte is not 0 or 1")
    limits = _range_of(f)
    if limits is not None and not limits[0] <= values[0] <= limits[1]:
        raise DecodeError(f"{t.name}.{name}: {values[0]} does not fit the bitfield's range [{limits[0]}, {limits[1]}]")
    out: dict[str, Any] = {}
    build(values, 0, out)
    return out[name]


def write_member(t: Type, name: str, buf: Any, offset: int, value: Any) -> None:
    """Packs `value` into member `name` of a packed image of `t` in `buf` (EncodeError if it does not fit)."""
    f = t.field(name)
    s, flatten, _ = t._members[name]
    leaves: list[Value] = []
    flatten({name: value}, leaves, t.name)
    try:
        s.pack_into(buf, offset + f.wire_offset, *leaves)
    except struct.error as exc:
        raise EncodeError(f"{t.name}.{name}: {exc} (check the value type)") from exc


def _range_of(f: Field) -> tuple[int, int] | None:
    """Integer range a member accepts: its bit width for a bitfield (C would truncate silently, so
    Python refuses instead), else None (struct checks the container)."""
    if f.bits is None or f.wire in ("bool", "f32", "f64"):
        return None
    if f.wire is not None and f.wire.startswith("i"):
        return -(1 << (f.bits - 1)), (1 << (f.bits - 1)) - 1
    return 0, (1 << f.bits) - 1


class _CheckedBool:
    """A bool member's fast path for Directory (the interface of struct.Struct("<?")): reading
    refuses a byte other than 0/1, as decoding does."""

    _B = struct.Struct("<B")
    size = 1

    def __init__(self, where: str) -> None:
        self.where = where

    def unpack_from(self, buf: Any, offset: int = 0) -> tuple[bool]:
        b = self._B.unpack_from(buf, offset)[0]
        if b > 1:
            raise DecodeError(f"{self.where}: bool byte {b} is not 0 or 1")
        return (b == 1,)

    def pack_into(self, buf: Any, offset: int, value: Any) -> None:
        self._B.pack_into(buf, offset, 1 if value else 0)


def _with_codec(t: Type, types: dict[str, Type]) -> Type:
    steps_flat: list[Callable[[dict, list, str], None]] = []
    steps_build: list[Callable[[tuple, int, dict], int]] = []
    for f in t.packed_fields:
        steps_flat.append(_field_flattener(f, types))
        steps_build.append(_field_builder(f, types))
        if f.text:
            code = f"{f.dims[-1]}s" * (f.count // f.dims[-1])
        else:
            code = (types[f.struct]._struct.format.lstrip("<") if f.struct else WIRE_TYPES[f.wire or ""][0]) * f.count
        t._members[f.name] = (struct.Struct("<" + code), steps_flat[-1], steps_build[-1])
        if not f.struct and not f.dims and _range_of(f) is None:
            scalar = _CheckedBool(f"{t.name}.{f.name}") if f.wire == "bool" else t._members[f.name][0]
            t._scalars[f.name] = (scalar, f.wire_offset)
        if f.struct:
            t._subtypes[f.struct] = types[f.struct]

    def flatten(d: Any, out: list, path: str) -> None:
        if not isinstance(d, dict):
            raise EncodeError(f"{t.name}{' at ' + path if path else ''}: expected a dict, got {type(d).__name__}")
        for step in steps_flat:
            step(d, out, path)

    def build(v: tuple, i: int) -> tuple[dict, int]:
        out: dict[str, Any] = {}
        for step in steps_build:
            i = step(v, i, out)
        return out, i

    object.__setattr__(t, "_flatten", flatten)
    object.__setattr__(t, "_build", build)
    return t


def _field_flattener(f: Field, types: dict[str, Type]) -> Callable[[dict, list, str], None]:
    name, dims = f.name, f.dims
    limits = _range_of(f)
    sub = types[f.struct] if f.struct else None

    def put_leaf(x: Any, out: list, where: str) -> None:
        if sub is not None:
            sub._flatten(x, out, where)
            return
        if f.text:
            if not isinstance(x, (bytes, bytearray)) or len(x) > dims[-1]:
                raise EncodeError(f"{where}: expected bytes of at most {dims[-1]}, got "
                                  f"{type(x).__name__}{' of ' + str(len(x)) if isinstance(x, (bytes, bytearray)) else ''}")
            out.append(bytes(x))
            return
        if limits is not None and not (isinstance(x, int) and limits[0] <= x <= limits[1]):
            raise EncodeError(f"{where}: {x!r} does not fit a {f.bits}-bit {f.wire} bitfield "
                              f"[{limits[0]}, {limits[1]}]")
        out.append(x)

    leaf_depth = len(dims) - 1 if f.text else len(dims)

    def put(x: Any, out: list, where: str, depth: int) -> None:
        if depth == leaf_depth:
            put_leaf(x, out, where)
            return
        n = dims[depth]
        if not isinstance(x, (list, tuple)) or len(x) != n:
            raise EncodeError(f"{where}: expected a list of {n}, got {type(x).__name__}"
                              f"{' of ' + str(len(x)) if isinstance(x, (list, tuple)) else ''}")
        for k, e in enumerate(x):
            put(e, out, f"{where}[{k}]", depth + 1)

    def flatten(d: dict, out: list, path: str) -> None:
        where = f"{path}.{name}" if path else name
        try:
            x = d[name]
        except KeyError:
            raise EncodeError(f"{where}: missing member (every packed member needs a value)") from None
        put(x, out, where, 0)

    return flatten


def _field_builder(f: Field, types: dict[str, Type]) -> Callable[[tuple, int, dict], int]:
    name, dims, count = f.name, f.dims, f.count
    sub = types[f.struct] if f.struct else None
    if f.text:  # one bytes per innermost row
        dims, count = dims[:-1], count // dims[-1]
        if not dims:
            def text(v: tuple, i: int, out: dict) -> int:
                out[name] = v[i]
                return i + 1
            return text
    if sub is None and not dims:
        def scalar(v: tuple, i: int, out: dict) -> int:
            out[name] = v[i]
            return i + 1
        return scalar
    if sub is None:
        def array(v: tuple, i: int, out: dict) -> int:
            out[name] = _nest(v[i:i + count], dims)
            return i + count
        return array

    def structs(v: tuple, i: int, out: dict) -> int:
        items = []
        for _ in range(count):
            d, i = sub._build(v, i)
            items.append(d)
        out[name] = _nest(items, dims) if dims else items[0]
        return i
    return structs


def _nest(flat: Any, dims: tuple[int, ...]) -> list:
    """A flat row-major sequence as nested lists of shape `dims`."""
    if len(dims) == 1:
        return list(flat)
    step = len(flat) // dims[0]
    return [_nest(flat[k * step:(k + 1) * step], dims[1:]) for k in range(dims[0])]


def leaf_paths(t: Type, types: Catalogue) -> Iterator[tuple[Union[str, int], ...]]:
    """Every packed scalar's path from the top of `t`, in wire order (names and indexes)."""
    for f in t.packed_fields:
        for index in product(*(range(d) for d in f.dims)):
            path = (f.name, *index)
            if f.struct:
                for rest in leaf_paths(types.type(f.struct), types):
                    yield path + rest
            else:
                yield path
