"""Reader for uavbus binary logs (docs/log-format.md): header, embedded catalogue, records.

A log is written by the C writer (ub_log.h) from any node. This module only reads it: the file
header and the record framing are parsed here, every checksum is the C runtime's CRC-32C, and every
frame's header is parsed and verified by the C frame codec (ub_frame_parse), never in Python.

Layout (little-endian):

    header: "UBLOG1\\r\\n" | u32 meta_len | u32 catalogue_len | u32 crc32c(meta | catalogue)
            | meta (JSON) | catalogue (compact catalogue JSON)
    record: u16 0xB10C | u16 frame_len | u64 t_ms | u8 link_id | u8 dir (0 rx, 1 tx)
            | u16 reserved | u32 crc32c(record[0:16] | frame) | frame

A crash can leave a partial record at the end. Reading stops at the last whole record whose CRC
holds; `LogReader.ignored_bytes` says how many bytes after it were not read, and why.
"""

from __future__ import annotations

import json
import os
import struct
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, BinaryIO

from uavbus._bindings.ub_error import UbError
from uavbus._bindings.ub_frame import FrameHeader, ub_crc32c, ub_crc32c_update, ub_frame_parse

MAGIC = b"UBLOG1\r\n"
FILE_HEADER = struct.Struct("<8sIII")
RECORD_MARKER = 0xB10C
RECORD_HEADER = struct.Struct("<HHQBBHI")  # marker, frame_len, t_ms, link_id, dir, reserved, crc
RECORD_CRC_SPAN = 16  # the CRC covers the record header up to (not including) itself, then the frame
DIR_NAMES = ("rx", "tx")


class LogFormatError(ValueError):
    """The file is not a uavbus log, or its header is damaged; the message says which and where."""


@dataclass(frozen=True)
class LogHeader:
    """The file header: who wrote the log, its links and the catalogue to decode it with."""

    node: str
    links: dict[int, str]
    start_unix_ms: int
    start_t_ms: int  # the writer's clock at start_unix_ms: unix ms of a record = start_unix_ms + t_ms - start_t_ms
    record_tx: bool
    meta: dict[str, Any]
    catalogue_json: str
    size: int  # bytes of the file header, i.e. the offset of the first record

    def link_name(self, link_id: int) -> str:
        return self.links.get(link_id, f"link{link_id}")


@dataclass(frozen=True)
class LogRecord:
    """One logged frame: when (`t_ms`, the writer's clock), on which link, in which direction."""

    offset: int
    t_ms: int
    link_id: int
    link: str
    dir: str  # "rx" or "tx"
    frame: bytes
    header: FrameHeader

    @property
    def payload(self) -> bytes:
        # after the 64-byte header; a signed or encrypted frame's trailer follows it (docs/wire-format.md)
        return self.frame[64:64 + self.header.payload_size]


@dataclass
class ReadStats:
    """What the reader saw. Every byte of the file is either in a record, the header, or ignored."""

    records: int = 0
    record_bytes: int = 0
    ignored_bytes: int = 0
    ignored_reason: str = ""  # "", "partial record", "bad record CRC at offset N", ...
    bad_frames: int = 0  # records whose CRC held but whose frame the C codec rejected (skipped)
    by_reason: dict[str, int] = field(default_factory=dict)


def _entity_text(raw: bytes) -> str:
    return raw.rstrip(b"\0").decode("ascii", "replace")


def parse_header(data: bytes | memoryview, path: str = "<log>") -> LogHeader | None:
    """The file header from the start of `data`; None when `data` is still too short to hold it.

    Raises LogFormatError (message `path: ...`) when the bytes are not a valid log header."""
    if len(data) < len(MAGIC):
        if bytes(data) != MAGIC[: len(data)]:
            raise LogFormatError(f"{path}: not a uavbus log (no UBLOG1 magic)")
        return None
    if bytes(data[: len(MAGIC)]) != MAGIC:
        raise LogFormatError(f"{path}: not a uavbus log (no UBLOG1 magic)")
    if len(data) < FILE_HEADER.size:
        return None
    _, meta_len, cat_len, crc = FILE_HEADER.unpack_from(data, 0)
    end = FILE_HEADER.size + meta_len + cat_len
    if len(data) < end:
        return None
    body = bytes(data[FILE_HEADER.size:end])
    if ub_crc32c(body) != crc:
        raise LogFormatError(f"{path}: header CRC mismatch: the log's metadata or catalogue is damaged")
    try:
        meta = json.loads(body[:meta_len].decode("utf-8"))
        catalogue_json = body[meta_len:].decode("utf-8")
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise LogFormatError(f"{path}: header metadata is not JSON: {exc}") from exc
    links = {int(k): str(v) for k, v in dict(meta.get("links", {})).items()}
    return LogHeader(node=str(meta.get("node", "")), links=links,
                     start_unix_ms=int(meta.get("start_unix_ms", 0)), start_t_ms=int(meta.get("start_t_ms", 0)),
                     record_tx=bool(meta.get("record_tx", False)), meta=meta,
                     catalogue_json=catalogue_json, size=end)


class _RecordScanner:
    """Splits a growing byte buffer into records. Used by the one-shot reader and by follow mode."""

    def __init__(self, header: LogHeader, stats: ReadStats) -> None:
        self.header = header
        self.stats = stats
        self.stopped = ""  # non-empty once a damaged record ended the log

    def scan(self, buf: bytearray, base: int) -> tuple[list[LogRecord], int]:
        """Whole records at the start of `buf` (file offset `base`) and the bytes they used."""
        out: list[LogRecord] = []
        view = memoryview(buf)
        pos = 0
        try:
            while not self.stopped and len(buf) - pos >= RECORD_HEADER.size:
                marker, frame_len, t_ms, link_id, direction, _reserved, crc = RECORD_HEADER.unpack_from(view, pos)
                if marker != RECORD_MARKER:
                    self.stopped = f"no record marker at offset {base + pos}"
                    break
                end = pos + RECORD_HEADER.size + frame_len
                if end > len(buf):
                    break  # partial record: wait for more (follow) or report it (end of file)
                frame = bytes(view[pos + RECORD_HEADER.size:end])
                head_crc = ub_crc32c(bytes(view[pos:pos + RECORD_CRC_SPAN]))
                if ub_crc32c_update(head_crc, frame) != crc:
                    self.stopped = f"bad record CRC at offset {base + pos}"
                    break
                pos = end
                self.stats.records += 1
                self.stats.record_bytes += RECORD_HEADER.size + frame_len
                try:
                    h = ub_frame_parse(frame)
                except UbError as exc:
                    # The writer logs only verified frames, so this is a damaged file; count, skip.
                    self.stats.bad_frames += 1
                    self.stats.by_reason[exc.name] = self.stats.by_reason.get(exc.name, 0) + 1
                    continue
                out.append(LogRecord(offset=base + pos - (RECORD_HEADER.size + frame_len), t_ms=t_ms,
                                     link_id=link_id, link=self.header.link_name(link_id),
                                     dir=DIR_NAMES[direction] if direction < 2 else f"dir{direction}",
                                     frame=frame, header=h))
        finally:
            view.release()
        return out, pos


class LogReader:
    """Reads a whole log file. Iterate for records; `stats` and `ignored_bytes` after iterating.

        log = LogReader("gcs.ublog")
        for rec in log: print(rec.t_ms, rec.link, rec.header.seq)
        if log.ignored_bytes: print(log.stats.ignored_reason)
    """

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = str(path)
        self._data = Path(path).read_bytes()
        header = parse_header(self._data, self.path)
        if header is None:
            raise LogFormatError(f"{self.path}: file ends inside the log header ({len(self._data)} bytes): "
                                 "nothing was recorded")
        self.header = header
        self.stats = ReadStats()
        self._records: list[LogRecord] | None = None

    @property
    def ignored_bytes(self) -> int:
        self.records()
        return self.stats.ignored_bytes

    def records(self) -> list[LogRecord]:
        if self._records is None:
            scanner = _RecordScanner(self.header, self.stats)
            body = bytearray(self._data[self.header.size:])
            self._records, used = scanner.scan(body, self.header.size)
            self.stats.ignored_bytes = len(body) - used
            if self.stats.ignored_bytes:
                self.stats.ignored_reason = scanner.stopped or "partial record at the end (truncated tail)"
        return self._records

    def __iter__(self) -> Iterator[LogRecord]:
        return iter(self.records())

    def catalogue(self) -> Any:
        """The embedded catalogue as a uavbus.Catalogue (decode/encode with no generated code)."""
        return load_catalogue(self.header.catalogue_json)


def load_catalogue(catalogue_json: str) -> Any:
    from uavbus.catalogue import Catalogue  # room B's module; imported late so reading works without it

    return Catalogue.from_json_text(catalogue_json)


def follow(path: str | os.PathLike[str], *, poll_s: float = 0.05, stop: Callable[[], bool] | None = None,
           from_start: bool = True, sleep: Callable[[float], None] = time.sleep,
           on_header: Callable[[LogHeader], None] | None = None) -> Iterator[LogRecord]:
    """Yields records of a log that is still being written, as they are appended (like tail -f).

    Waits for the file and its header to appear. A partial record at the end is waited for, not
    reported: the writer appends one record per write(). A damaged record ends the iteration with
    LogFormatError. `stop()` is checked between polls; `from_start=False` skips existing records."""
    path = str(path)
    stats = ReadStats()
    f: BinaryIO | None = None
    try:
        while f is None:
            try:
                f = open(path, "rb")  # noqa: SIM115 (kept open across yields; closed in finally)
            except FileNotFoundError:
                if stop is not None and stop():
                    return
                sleep(poll_s)
        buf = bytearray()
        header: LogHeader | None = None
        while header is None:
            buf += f.read()
            header = parse_header(buf, path)
            if header is None:
                if stop is not None and stop():
                    return
                sleep(poll_s)
        if on_header is not None:
            on_header(header)
        scanner = _RecordScanner(header, stats)
        base = header.size
        del buf[: header.size]
        skip = not from_start
        while True:
            records, used = scanner.scan(buf, base)
            del buf[:used]
            base += used
            if not skip:
                yield from records
            if scanner.stopped:
                raise LogFormatError(f"{path}: {scanner.stopped}: stopped following")
            chunk = f.read()
            if chunk:
                buf += chunk
                continue
            skip = False
            if stop is not None and stop():
                return
            sleep(poll_s)
    finally:
        if f is not None:
            f.close()
