"""Shared pieces of the tools: naming and decoding frames through a catalogue, flattening values.

Every tool decodes from the catalogue JSON (uavbus.catalogue), never from generated code, so a log
or a live network is readable without the build that produced it.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

from uavbus._bindings.ub_frame import FrameHeader
from uavbus._ub import lib

ADMIN_NAMES = {
    lib.UB_ADMIN_DATA: "data", lib.UB_ADMIN_PUB_REQUEST: "pub_request",
    lib.UB_ADMIN_SUB_REQUEST: "sub_request", lib.UB_ADMIN_PUB_STOP: "pub_stop",
    lib.UB_ADMIN_SUB_STOP: "sub_stop", lib.UB_ADMIN_ACK: "ack", lib.UB_ADMIN_NACK: "nack",
}


def entity_name(raw: bytes) -> str:
    """A 12-byte entity ID as its name (the ID is the name, NUL-padded)."""
    return raw.rstrip(b"\0").decode("ascii", "replace")


def admin_name(code: int) -> str:
    return ADMIN_NAMES.get(code, f"admin{code}")


@dataclass(frozen=True)
class Seen:
    """One frame as the tools see it, whatever its source (a log record or a live tap)."""

    t_ms: int
    link: str
    dir: str
    header: FrameHeader
    frame: bytes

    @property
    def payload(self) -> bytes:
        # after the 64-byte header; a signed or encrypted frame's trailer follows it (docs/wire-format.md)
        return self.frame[64:64 + self.header.payload_size]

    @property
    def source(self) -> str:
        return entity_name(self.header.src_id)

    @property
    def dest(self) -> str:
        return entity_name(self.header.dest_id)

    @property
    def is_data(self) -> bool:
        return self.header.admin == lib.UB_ADMIN_DATA


class Contents:
    """Names and decodes frame contents with a catalogue (uavbus.catalogue.Catalogue).

    Unknown content IDs and layout mismatches are counted in `unknown` and `layout_mismatch`
    and shown by their hex ID: a tool never drops a frame without saying so."""

    def __init__(self, catalogue: Any) -> None:
        self.catalogue = catalogue
        self.unknown = 0
        self.layout_mismatch = 0
        self.encrypted = 0  # ENCRYPTED frames: their payload is ciphertext to anyone without the key

    def name(self, h: FrameHeader) -> str:
        inst = self.catalogue.find(bytes(h.dir_id))
        return inst.name if inst is not None else "?" + bytes(h.dir_id).hex()

    def known(self, name: str) -> bool:
        return self.catalogue.find(name) is not None

    def decode(self, seen: Seen) -> dict[str, Any] | None:
        """The decoded value of a DATA frame, or None (counted) when the catalogue cannot decode it."""
        if not seen.is_data:
            return None
        if seen.header.flags & 0x20:
            self.encrypted += 1
            return None
        inst = self.catalogue.find(bytes(seen.header.dir_id))
        if inst is None:
            self.unknown += 1
            return None
        fp = getattr(inst.type, "fingerprint", None)
        if isinstance(fp, str):
            fp = int(fp, 16)
        if fp is not None and seen.header.fingerprint != fp:
            self.layout_mismatch += 1
            return None
        return dict(self.catalogue.decode(inst, seen.payload))


def flatten(value: Any, prefix: str = "") -> Iterator[tuple[str, Any]]:
    """Leaves of a decoded value as (path, leaf): nested structs as `a.b`, arrays as `m[1][2]`."""
    if isinstance(value, dict):
        for k, v in value.items():
            yield from flatten(v, f"{prefix}.{k}" if prefix else str(k))
    elif isinstance(value, (list, tuple)):
        for i, v in enumerate(value):
            yield from flatten(v, f"{prefix}[{i}]")
    else:
        yield prefix, value


def jsonable(value: Any) -> Any:
    """`value` with bytes as hex and non-finite floats as strings, so json.dumps never fails."""
    if isinstance(value, dict):
        return {k: jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, (bytes, bytearray, memoryview)):
        return bytes(value).hex()
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    return value


def short_value(value: Any, limit: int = 100) -> str:
    """A one-line rendering of a decoded value for tables (`a=1 b.c=2.5 ...`), cut at `limit`."""
    parts = []
    for path, leaf in flatten(value):
        text = f"{leaf:.6g}" if isinstance(leaf, float) else str(jsonable(leaf))
        parts.append(f"{path}={text}")
    line = " ".join(parts)
    return line if len(line) <= limit else line[: limit - 3] + "..."
