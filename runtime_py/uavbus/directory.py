"""Directory: a hosted instance's storage, as the C router sees it, with attribute access.

A node binds each hosted instance to a `uint8_t[packed_size]` cffi buffer: the C catalogue built
from the JSON has pack/unpack NULL, so the router copies that **wire image** in and out as is.
Reading `d.latitude` unpacks the member from the buffer; `d.latitude = 1.0` packs it in place, so
the next publication sends it. Nested structs are views on the same buffer (`d.pos.x = 1`); arrays
are read as (nested) lists and written whole.
"""

from __future__ import annotations

import struct
from typing import Any

from uavbus.catalogue import EncodeError, Instance, Type, decode_type, encode_type, read_member, write_member


class Directory:
    """A view of one packed image of `type` at `offset` inside `storage` (a cffi buffer)."""

    __slots__ = ("_type", "_storage", "_buf", "_offset", "instance")

    def __init__(self, type_: Type, storage: Any, offset: int = 0, instance: Instance | None = None) -> None:
        from uavbus._ub import ffi

        object.__setattr__(self, "_type", type_)
        object.__setattr__(self, "_storage", storage)  # keeps the C memory alive as long as any view
        object.__setattr__(self, "_buf", ffi.buffer(storage))
        object.__setattr__(self, "_offset", offset)
        object.__setattr__(self, "instance", instance)

    @property
    def type(self) -> Type:
        return self._type

    @property
    def fields(self) -> tuple[str, ...]:
        return tuple(f.name for f in self._type.packed_fields)

    def __getattr__(self, name: str) -> Any:
        t = self._type
        scalar = t._scalars.get(name)
        if scalar is not None:  # the common case, one unpack_from
            return scalar[0].unpack_from(self._buf, self._offset + scalar[1])[0]
        if name not in t._members:
            raise AttributeError(f"{t.name} has no packed member {name!r} (members: {', '.join(self.fields)})")
        f = t.field(name)
        if f.struct is not None and not f.dims:
            sub = Directory.__new__(Directory)
            for slot, value in (("_type", t._subtypes[f.struct]), ("_storage", self._storage), ("_buf", self._buf),
                                ("_offset", self._offset + f.wire_offset), ("instance", None)):
                object.__setattr__(sub, slot, value)
            return sub
        return read_member(t, name, self._buf, self._offset)

    def __setattr__(self, name: str, value: Any) -> None:
        scalar = self._type._scalars.get(name)
        if scalar is not None and name not in _OWN_ATTRIBUTES:  # the common case, one pack_into
            try:
                scalar[0].pack_into(self._buf, self._offset + scalar[1], value)
            except struct.error as exc:
                raise EncodeError(f"{self._type.name}.{name}: {exc} (check the value type)") from exc
            return
        if isinstance(getattr(type(self), name, None), property):  # `raw`
            object.__setattr__(self, name, value)
            return
        t = self._type
        if name not in t._members:
            raise AttributeError(f"{t.name} has no packed member {name!r} (members: {', '.join(self.fields)})")
        if isinstance(value, Directory):
            value = value.to_dict()
        write_member(t, name, self._buf, self._offset, value)

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
        return decode_type(self._type, self.raw)

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
    "instance", "_type", "_storage", "_buf", "_offset"}
