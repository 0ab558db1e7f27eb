"""Directory: a hosted instance's storage, as the C router sees it, with attribute access.

A node binds each hosted instance to a `uint8_t[packed_size]` cffi buffer: the C catalogue built
from the JSON has pack/unpack NULL, so the router copies that **wire image** in and out as is.
Reading `d.latitude` unpacks the member from the buffer; `d.latitude = 1.0` packs it in place, so
the next publication sends it. Everything nested writes through to the same buffer:

    d.velocityNed.x = 1.0           # a nested struct is a view
    d.motors[2].rpm = 5200          # an array is an ArrayView; an element struct is a view too
    d.motors[2]["rpm"] = 5200       # the same, by key
    d.cells[1][3] = 3.7             # multi-dimensional arrays index row by row
    d.cells = [[...], ...]          # or write a whole member at once
    d.mode = "MODE_AUTO"            # enum members read as IntEnum and accept a constant's name

What cannot write through refuses loudly (TypeError) instead of changing a copy: slices of an array
are read-only lists, and so is a text (char array) member. `to_dict()` is a plain, detached copy.
"""

from __future__ import annotations

import struct
from collections.abc import Iterator, Sequence
from typing import Any

from uavbus.catalogue import (
    WIRE_TYPES, EncodeError, Field, Instance, Type, decode_type, encode_type, read_member, write_member,
)


class Directory:
    """A view of one packed image of `type` at `offset` inside `storage` (a cffi buffer).

    Members are attributes (or keys: `d["latitude"]`). Reading unpacks from the buffer, writing packs
    into it: the next publication of the instance sends what was written."""

    __slots__ = ("_type", "_storage", "_buf", "_offset", "instance", "_enums")

    def __init__(self, type_: Type, storage: Any, offset: int = 0, instance: Instance | None = None,
                 enums: Any = None) -> None:
        from uavbus._bindings.ub_node import storage_buffer

        object.__setattr__(self, "_type", type_)
        object.__setattr__(self, "_storage", storage)  # keeps the C memory alive as long as any view
        object.__setattr__(self, "_buf", storage_buffer(storage))
        object.__setattr__(self, "_offset", offset)
        object.__setattr__(self, "instance", instance)
        object.__setattr__(self, "_enums", enums)  # uavbus.enums.CatalogueEnums, or None

    def _view(self, type_: Type, offset: int) -> Directory:
        sub = Directory.__new__(Directory)
        for slot, value in (("_type", type_), ("_storage", self._storage), ("_buf", self._buf),
                            ("_offset", offset), ("instance", None), ("_enums", self._enums)):
            object.__setattr__(sub, slot, value)
        return sub

    @property
    def type(self) -> Type:
        """The catalogue type of this image."""
        return self._type

    @property
    def fields(self) -> tuple[str, ...]:
        """Names of the packed members, in wire order."""
        return tuple(f.name for f in self._type.packed_fields)

    def __getattr__(self, name: str) -> Any:
        t = self._type
        scalar = t._scalars.get(name)
        if scalar is not None:  # the common case, one unpack_from
            value = scalar[0].unpack_from(self._buf, self._offset + scalar[1])[0]
            enums = self._enums
            if enums is not None and name in enums.members.get(t.name, ()):
                return enums.member(enums.members[t.name][name], value)
            return value
        if name not in t._members:
            raise AttributeError(f"{t.name} has no packed member {name!r} (members: {', '.join(self.fields)})")
        f = t.field(name)
        if f.struct is not None and not f.dims:
            return self._view(t._subtypes[f.struct], self._offset + f.wire_offset)
        if f.dims and not getattr(f, "text", False):
            return ArrayView(self, f, f.dims, self._offset + f.wire_offset)
        value = read_member(t, name, self._buf, self._offset)
        if isinstance(value, list):  # a text member's rows: read-only, so a changed copy cannot be mistaken
            return _frozen(value)
        enums = self._enums
        if enums is not None and name in enums.members.get(t.name, ()):
            return enums.member(enums.members[t.name][name], value)
        return value

    def __setattr__(self, name: str, value: Any) -> None:
        scalar = self._type._scalars.get(name)
        if scalar is not None and name not in _OWN_ATTRIBUTES:  # the common case, one pack_into
            if isinstance(value, str):
                value = self._enum_value(name, value)
            packer, at = scalar[0], self._offset + scalar[1]
            if isinstance(packer, struct.Struct):
                # pack() then copy, not pack_into(): pack_into zeroes the member before it fails, and a
                # refused write must leave the old value in place.
                try:
                    data = packer.pack(value)
                except struct.error as exc:
                    raise EncodeError(f"{self._type.name}.{name}: {exc} (check the value type)") from exc
                self._buf[at:at + packer.size] = data
            else:
                packer.pack_into(self._buf, at, value)
            return
        if isinstance(getattr(type(self), name, None), property):  # `raw`
            object.__setattr__(self, name, value)
            return
        t = self._type
        if name not in t._members:
            raise AttributeError(f"{t.name} has no packed member {name!r} (members: {', '.join(self.fields)})")
        f = t.field(name)
        start = self._offset + f.wire_offset
        before = bytes(self._buf[start:start + f.wire_size])
        try:
            write_member(t, name, self._buf, self._offset, _plain(self._enum_value(name, value)))
        except BaseException:
            self._buf[start:start + f.wire_size] = before  # a refused write leaves the member as it was
            raise

    def _enum_value(self, name: str, value: Any) -> Any:
        """A constant's name ("MODE_AUTO") for an enum member becomes its value; the rest is as given."""
        enums = self._enums
        enum_name = enums.members.get(self._type.name, {}).get(name) if enums is not None else None
        if enum_name is None:
            return value
        return _names_to_values(value, enums.constants[enum_name], f"{self._type.name}.{name}")

    def __getitem__(self, name: str) -> Any:
        return getattr(self, name)

    def __setitem__(self, name: str, value: Any) -> None:
        setattr(self, name, value)

    @property
    def raw(self) -> bytes:
        """A copy of the packed image (exactly what goes on the wire)."""
        return bytes(self._buf[self._offset:self._offset + self._type.packed_size])

    @raw.setter
    def raw(self, data: bytes) -> None:
        if len(data) != self._type.packed_size:
            raise ValueError(f"{self._type.name} is {self._type.packed_size} bytes, got {len(data)}")
        self._buf[self._offset:self._offset + len(data)] = data

    def to_dict(self) -> dict[str, Any]:
        """The whole value as a plain nested dict (a detached copy; enum members as IntEnum)."""
        value = decode_type(self._type, self.raw)
        return self._enums.apply(self._type, value) if self._enums is not None else value

    def from_dict(self, value: dict[str, Any]) -> "Directory":
        """Writes every packed member from `value` (all of them are needed); returns self."""
        self.raw = encode_type(self._type, value)
        return self

    def update(self, **members: Any) -> "Directory":
        """Writes the given members only."""
        for name, value in members.items():
            setattr(self, name, value)
        return self

    def to_object(self, cls: Any) -> Any:
        """The generated `<name>.py` class instance holding the same value (`cls.unpack(raw)`)."""
        return cls.unpack(self.raw)

    def from_object(self, obj: Any) -> "Directory":
        """Writes a generated-class object (`obj.pack()`) into the image; returns self."""
        self.raw = obj.pack()
        return self

    def __repr__(self) -> str:
        what = self.instance.name if self.instance is not None else self._type.name
        return f"<Directory {what} {self.to_dict()!r}>"


# Names a packed member must not shadow when set (properties and the view's own state).
_OWN_ATTRIBUTES = frozenset(n for n, v in vars(Directory).items() if isinstance(v, property)) | {
    "instance", "_type", "_storage", "_buf", "_offset", "_enums"}


class ArrayView(Sequence[Any]):
    """An array member of a Directory, read and written in place: `view[i]` is an element (a value, a
    Directory view for a struct element, or an ArrayView for the next dimension), `view[i] = x` writes
    it. Compares equal to a list with the same elements; `tolist()` is a detached copy."""

    __slots__ = ("_dir", "_field", "_dims", "_offset")

    def __init__(self, directory: Directory, field: Field, dims: tuple[int, ...], offset: int) -> None:
        self._dir, self._field, self._dims, self._offset = directory, field, dims, offset

    def _element_size(self) -> int:
        f = self._field
        return f.wire_size // f.count  # bytes of one innermost element

    def _stride(self) -> int:
        n = 1
        for d in self._dims[1:]:
            n *= d
        return n * self._element_size()

    def _at(self, index: int) -> int:
        n = self._dims[0]
        if not isinstance(index, int):
            raise TypeError(f"{self._where()}: array indices are integers, not {type(index).__name__}")
        if not -n <= index < n:
            raise IndexError(f"{self._where()}[{index}]: index out of range (length {n})")
        return self._offset + (index % n) * self._stride()

    def _where(self) -> str:
        return f"{self._dir._type.name}.{self._field.name}"

    def __len__(self) -> int:
        return self._dims[0]

    def __getitem__(self, index: Any) -> Any:
        if isinstance(index, slice):  # a read-only copy: a slice cannot write through
            return _frozen([self[k] for k in range(*index.indices(len(self)))])
        at = self._at(index)
        f, d = self._field, self._dir
        if len(self._dims) > 1:
            return ArrayView(d, f, self._dims[1:], at)
        if f.struct is not None:
            return d._view(d._type._subtypes[f.struct], at)
        value = struct.unpack_from("<" + WIRE_TYPES[f.wire or ""][0], d._buf, at)[0]
        enums = d._enums
        enum_name = enums.members.get(d._type.name, {}).get(f.name) if enums is not None else None
        return enums.member(enum_name, value) if enum_name is not None else value

    def __setitem__(self, index: Any, value: Any) -> None:
        if isinstance(index, slice):
            raise TypeError(f"{self._where()}: assign elements one at a time, or the whole member "
                            f"({self._field.name} = [...]); a slice cannot be written")
        at = self._at(index)
        f, d = self._field, self._dir
        if len(self._dims) > 1:
            row = ArrayView(d, f, self._dims[1:], at)
            if not isinstance(value, (list, tuple, ArrayView)) or len(value) != len(row):
                raise EncodeError(f"{self._where()}[{index}]: expected a list of {len(row)}")
            start, size = at, self._stride()
            before = bytes(d._buf[start:start + size])
            try:
                for k, v in enumerate(list(value)):
                    row[k] = v
            except BaseException:
                d._buf[start:start + size] = before  # all or nothing
                raise
            return
        if f.struct is not None:
            sub = d._type._subtypes[f.struct]
            image = encode_type(sub, _plain(value))
            d._buf[at:at + len(image)] = image
            return
        value = d._enum_value(f.name, value) if isinstance(value, str) else value
        try:
            data = struct.pack("<" + WIRE_TYPES[f.wire or ""][0], value)
        except struct.error as exc:
            raise EncodeError(f"{self._where()}[{index}]: {exc} (check the value type)") from exc
        d._buf[at:at + len(data)] = data

    def __iter__(self) -> Iterator[Any]:
        for k in range(len(self)):
            yield self[k]

    def tolist(self) -> list[Any]:
        """A detached copy as nested lists (struct elements as dicts)."""
        return [v.tolist() if isinstance(v, ArrayView) else v.to_dict() if isinstance(v, Directory) else v
                for v in self]

    def __eq__(self, other: object) -> bool:
        if isinstance(other, ArrayView):
            other = other.tolist()
        if isinstance(other, tuple):
            other = list(other)
        return isinstance(other, list) and self.tolist() == _plain(other)

    __hash__ = None  # type: ignore[assignment]  # mutable, like a list

    def __repr__(self) -> str:
        return f"ArrayView({self.tolist()!r})"


def _frozen(value: list[Any]) -> tuple[Any, ...]:
    return tuple(_frozen(v) if isinstance(v, list) else v for v in value)


def _plain(value: Any) -> Any:
    """Views and tuples as the plain dicts and lists the codec takes."""
    if isinstance(value, Directory):
        return value.to_dict()
    if isinstance(value, ArrayView):
        return value.tolist()
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    return value


def _names_to_values(value: Any, constants: dict[str, int], where: str) -> Any:
    if isinstance(value, str):
        if value not in constants:
            raise EncodeError(f"{where}: {value!r} is not a constant of its enum (one of: {', '.join(constants)})")
        return constants[value]
    if isinstance(value, (list, tuple)):
        return [_names_to_values(v, constants, where) for v in value]
    return value
