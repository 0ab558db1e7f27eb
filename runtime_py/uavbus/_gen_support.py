"""Helpers shared by every generated `<name>.py` (templates/py): nested-list shaping for array
members. Generated modules import them from here instead of repeating them; keep the names and
behaviour stable (generated code in the field depends on them), add rather than change.
"""

from __future__ import annotations

import math
from typing import Any, Callable, Iterator

SUPPORT_VERSION = 1  # generated modules check this at import
SUPPORT_LEVEL = 2  # 2: fit, text, check_wire (bitfield widths, text members, refused wire values)


def flatten(seq: Any, depth: int) -> Iterator[Any]:
    """Elements of a nested list `depth` levels deep, row-major."""
    if depth == 1:
        yield from seq
    else:
        for sub in seq:
            yield from flatten(sub, depth - 1)


def nest(flat: Any, dims: tuple[int, ...]) -> list:
    """A flat row-major sequence as nested lists of shape `dims`."""
    if len(dims) == 1:
        return list(flat)
    step = len(flat) // dims[0]
    return [nest(flat[k * step:(k + 1) * step], dims[1:]) for k in range(dims[0])]


def map_nested(fn: Callable[[Any], Any], seq: Any, depth: int) -> list:
    """`fn` applied to every element of a nested list `depth` levels deep, keeping the shape."""
    if depth == 1:
        return [fn(x) for x in seq]
    return [map_nested(fn, sub, depth - 1) for sub in seq]


def same(x: Any) -> Any:
    return x


def take_structs(cls: Any, v: tuple, i: int, dims: tuple[int, ...]) -> list:
    """Nested lists of `cls` objects read from the flat values `v` starting at `i`."""
    if len(dims) == 1:
        return [cls._take(v, i + k * cls._NLEAVES) for k in range(dims[0])]
    step = cls._NLEAVES * math.prod(dims[1:])
    return [take_structs(cls, v, i + k * step, dims[1:]) for k in range(dims[0])]


def build(fn: Callable[[], Any], dims: tuple[int, ...]) -> list:
    """Nested lists of shape `dims` of fresh `fn()` values."""
    if len(dims) == 1:
        return [fn() for _ in range(dims[0])]
    return [build(fn, dims[1:]) for _ in range(dims[0])]


def fit(value: Any, lo: int, hi: int, where: str) -> Any:
    """`value` if it is an int in [lo, hi] (a bitfield's range), else ValueError: C cannot hold it,
    so Python refuses to send it rather than truncate it silently."""
    if not isinstance(value, int) or not lo <= value <= hi:
        raise ValueError(f"{where}: {value!r} does not fit the bitfield's range [{lo}, {hi}]")
    return value


def text(value: Any, size: int, where: str) -> bytes:
    """A text member's bytes: at most `size` (shorter ones are NUL-padded on the wire)."""
    if not isinstance(value, (bytes, bytearray)):
        raise ValueError(f"{where}: expected bytes of at most {size}, got {type(value).__name__}")
    if len(value) > size:
        raise ValueError(f"{where}: {len(value)} bytes do not fit {size}")
    return bytes(value)


def check_wire(name: str, data: Any, values: tuple, bool_at: tuple, ranges: tuple) -> None:
    """ValueError if a packed image holds what pack never writes: a bool byte other than 0/1
    (`bool_at`: byte offsets) or a bitfield value outside its width (`ranges`: (index in
    `values`, lowest, highest, member)). Unpack refuses these, as the generated C does."""
    for off in bool_at:
        if data[off] > 1:
            raise ValueError(f"{name}: bool byte {data[off]} at offset {off} is not 0 or 1")
    for k, lo, hi, member in ranges:
        if not lo <= values[k] <= hi:
            raise ValueError(f"{name}.{member}: {values[k]} does not fit the bitfield's range [{lo}, {hi}]")
