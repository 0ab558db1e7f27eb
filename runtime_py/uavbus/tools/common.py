"""Shared pieces of the tools: naming and decoding frames through a catalogue, flattening values.

Every tool decodes from the catalogue JSON (uavbus.catalogue), never from generated code, so a log
or a live network is readable without the build that produced it.
"""

from __future__ import annotations

import argparse
import datetime
import math
import re
from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any, NoReturn

from uavbus._bindings.ub_frame import FrameHeader
from uavbus._ub import lib

class ArgumentParser(argparse.ArgumentParser):
    """argparse with the tools' error style: one line, `prog: what is wrong (see prog --help)`, status 2."""

    def error(self, message: str) -> NoReturn:  # type: ignore[override]
        self.exit(2, f"{self.prog}: {message} (see {self.prog} --help)\n")


def positive(kind: type[Any]) -> Any:
    """An argparse type: a number of `kind` above 0 (an error names the value otherwise)."""
    def parse(text: str) -> Any:
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        if not value > 0 or (isinstance(value, float) and not math.isfinite(value)):
            raise argparse.ArgumentTypeError(f"{text!r}: give a number above 0")
        return value
    parse.__name__ = f"positive {kind.__name__}"
    return parse


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
    """One frame as the tools see it, whatever its source (a log record or a live tap). `t_ms` is
    the node's clock; `unix_ms` the wall-clock time it stands for (None when unknown)."""

    t_ms: int
    link: str
    dir: str
    header: FrameHeader
    frame: bytes
    unix_ms: float | None = None

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
        try:
            return dict(self.catalogue.decode(inst, seen.payload))
        except ValueError:  # an image no encoder writes (a damaged log): counted, shown undecodable
            self.layout_mismatch += 1
            return None

    def labelled(self, seen: Seen, value: dict[str, Any] | None) -> dict[str, Any] | None:
        """`value` with enum members as their constants' names (when the catalogue records enums)."""
        if value is None:
            return None
        from uavbus.enums import catalogue_enums

        inst = self.catalogue.find(bytes(seen.header.dir_id))
        enums = catalogue_enums(self.catalogue)
        return enums.labels(inst.type, value) if inst is not None and enums else value


def load_catalogue(text: str | bytes | None = None, origin: str = "<catalogue>", path: str | None = None) -> Any:
    """A Catalogue from JSON text (a log's embedded copy) or a file, or a CatalogueError saying which and
    why: a damaged catalogue is bad input, whatever exception its parser met."""
    from uavbus.catalogue import Catalogue

    if path is not None:
        return Catalogue.load(path)
    return Catalogue.from_json_text(text or "", origin=origin)


SEQ_WINDOW = 4096  # sequence numbers remembered per stream to recognise copies


@dataclass
class Stream:
    """What spy, hz, bw and log info keep per (content, source). A message is a (source, sequence):
    the copy of one that arrives again (over a redundant link: a 0x11 mask sends every frame on two
    links) is counted apart as a duplicate and left out of the rate."""

    name: str
    source: str
    unique: int = 0
    duplicates: int = 0
    bytes: int = 0  # every frame, copies included: what the links carried
    times: deque[int] = field(default_factory=lambda: deque(maxlen=100))  # arrival of unique messages
    last: dict[str, Any] | None = None
    last_seq: int = 0
    last_unix_ms: float | None = None
    _recent: deque[int] = field(default_factory=lambda: deque(maxlen=SEQ_WINDOW), repr=False)
    _recent_set: set[int] = field(default_factory=set, repr=False)

    def add(self, t_ms: int, seq: int, value: dict[str, Any] | None, size: int = 0,
            unix_ms: float | None = None) -> bool:
        """Counts one frame; returns False (and counts a duplicate) when its sequence was seen already."""
        self.bytes += size
        if seq in self._recent_set:
            self.duplicates += 1
            return False
        if len(self._recent) == self._recent.maxlen:
            self._recent_set.discard(self._recent[0])
        self._recent.append(seq)
        self._recent_set.add(seq)
        self.unique += 1
        self.times.append(t_ms)
        self.last_seq = seq
        self.last_unix_ms = unix_ms
        if value is not None:
            self.last = value
        return True

    @property
    def count(self) -> int:
        """Unique messages (duplicates apart)."""
        return self.unique

    def rate(self) -> float | None:
        """Unique messages per second over the kept window (None with fewer than 2 or no time span)."""
        if len(self.times) < 2 or self.times[-1] == self.times[0]:
            return None
        return (len(self.times) - 1) * 1000.0 / (self.times[-1] - self.times[0])

    def gaps(self) -> tuple[int, int] | None:
        """(shortest, longest) interval between unique messages in the window, ms."""
        if len(self.times) < 2:
            return None
        d = [b - a for a, b in zip(self.times, list(self.times)[1:])]
        return min(d), max(d)


def _utc(unix_ms: float) -> datetime.datetime | None:
    """The UTC time of `unix_ms`, or None when no calendar holds it (a damaged log's clock can say anything)."""
    try:
        return datetime.datetime.fromtimestamp(unix_ms / 1000.0, tz=datetime.timezone.utc)
    except (OverflowError, ValueError, OSError):
        return None


def human_time(unix_ms: float | None) -> str:
    """Wall-clock time, readable and unambiguous: "2025-11-23 19:37:01.123 UTC" ("-" when unknown)."""
    if unix_ms is None:
        return "-"
    t = _utc(unix_ms)
    if t is None:
        return f"unix ms {unix_ms:.0f} (not a date)"
    return t.strftime("%Y-%m-%d %H:%M:%S.") + f"{t.microsecond // 1000:03d} UTC"


def iso_time(unix_ms: float | None) -> str | None:
    """ISO 8601 UTC with ms, for CSV and JSON lines: "2025-11-23T19:37:01.123Z" (None when unknown, or when
    the recorded clock names no date)."""
    t = _utc(unix_ms) if unix_ms is not None else None
    if t is None:
        return None
    return t.strftime("%Y-%m-%dT%H:%M:%S.") + f"{t.microsecond // 1000:03d}Z"


def human_duration(ms: float) -> str:
    """A span for people: "850 ms", "12.4 s", "3 min 05 s", "2 h 01 min"."""
    if ms < 1000:
        return f"{ms:.0f} ms"
    s = ms / 1000.0
    if s < 60:
        return f"{s:.1f} s"
    if s < 3600:
        return f"{int(s // 60)} min {int(s % 60):02d} s"
    return f"{int(s // 3600)} h {int(s % 3600 // 60):02d} min"


class FieldPathError(ValueError):
    """`--field` names no member; the message lists what there is."""


def select_field(value: Any, path: str) -> Any:
    """The member at `path` of a decoded value: "velocityNed.x", "motors[2].rpm", "cells[1][0]"."""
    current: Any = value
    done = ""
    for part in _path_parts(path):
        if isinstance(part, int):
            if not isinstance(current, list) or not -len(current) <= part < len(current):
                size = len(current) if isinstance(current, list) else None
                raise FieldPathError(f"--field {path}: {done or 'the value'} "
                                     + (f"has {size} elements" if size is not None else "is not an array")
                                     + f" ([{part}] is out of range)" * (size is not None))
            current = current[part]
            done += f"[{part}]"
        else:
            if not isinstance(current, dict) or part not in current:
                members = ", ".join(current) if isinstance(current, dict) else "none (not a struct)"
                raise FieldPathError(f"--field {path}: {done or 'the value'} has no member {part!r} "
                                     f"(members: {members})")
            current = current[part]
            done += f".{part}" if done else part
    return current


_PATH_TOKEN = re.compile(r"\[(-?\d+)\]|(?:^|\.)([A-Za-z_][A-Za-z0-9_]*)")


def _path_parts(path: str) -> list[str | int]:
    parts: list[str | int] = []
    pos = 0
    while pos < len(path):
        m = _PATH_TOKEN.match(path, pos)
        if m is None or (m.group(2) is not None and pos > 0 and path[pos] != "."):
            raise FieldPathError(f"--field {path}: cannot read it from character {pos + 1} "
                                 "(write members and indices as in velocityNed.x or motors[2].rpm)")
        parts.append(int(m.group(1)) if m.group(1) is not None else m.group(2))
        pos = m.end()
    if not parts:
        raise FieldPathError(f"--field {path!r}: empty (write e.g. velocityNed.x)")
    return parts


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
