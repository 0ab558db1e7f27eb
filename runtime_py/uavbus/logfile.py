"""Reader for uavbus binary logs (docs/log-format.md): header, embedded catalogue, records.

A log is written by the C writer (ub_log.h) from any node. This module reads it through the C reader
(ub_log_header_parse, ub_log_reader_*), so C and Python find the same records in a damaged file and
count the same damage; every frame's header is then parsed and verified by the C frame codec
(ub_frame_parse), never in Python.

Layout (little-endian), format 3:

    header copy: "UBLOG3\\r\\n" | u32 meta_len | u32 catalogue_len | u32 crc32c(meta | catalogue)
                 | u32 crc32c(copy[0:20]) | meta (JSON) | catalogue (compact catalogue JSON)
    header:      header copy | the same copy again (the spare)
    record: u16 0xB10C | u16 frame_len | u32 seq | u64 t_ms | u8 link_id | u8 dir (0 rx, 1 tx)
            | u16 reserved | u32 crc32c(record[0:20]) | u32 crc32c continued over the frame | frame

Damage costs only the records it touches: the reader skips a record whose frame fails its check, and
after bytes were lost or inserted it searches for the next record. `ReadStats` counts what was skipped
(`ignored_bytes`, `damaged_records`, `resyncs`, a cut tail in `truncated_bytes`) and, from the records'
sequence numbers, how many are missing (`missing_records`: not written, e.g. on a full disk, or lost
to damage). The header is kept twice: one damaged region leaves a whole copy (or two halves the reader
joins), and `LogHeader.damaged` says which copy failed. When no copy is left the records are still read,
given the catalogue they were recorded with (`catalogue_json`, the tools' `--catalogue FILE`). Format 1
and 2 files ("UBLOG1", "UBLOG2": one header copy) are still read.
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

from uavbus._bindings import ub_log
from uavbus._bindings.ub_error import InvalidArgumentError, TruncatedError, UbError
from uavbus._bindings.ub_frame import FrameHeader, ub_frame_parse

MAGIC = b"UBLOG3\r\n"
MAGIC_V2 = b"UBLOG2\r\n"
MAGIC_V1 = b"UBLOG1\r\n"
FORMAT = ub_log.FORMAT
FILE_HEADER = struct.Struct("<8sIIII")  # magic, meta_len, catalogue_len, crc32c(meta | catalogue), crc32c(copy[0:20])
FILE_HEADER_V2 = struct.Struct("<8sIII")  # formats 1 and 2: no check of its own on the fixed part
RECORD_HEADER_LEN = ub_log.RECORD_HEADER_LEN  # format 2; format 1 records have ub_log.V1_RECORD_HEADER_LEN
RECORD_HEAD_SPAN = 20  # head_crc covers record[0:20]; it sits at 20, the frame's crc (continued from it) at 24
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
    size: int  # bytes of the file header (both copies), i.e. the offset of the first record (0: unknown)
    version: int = FORMAT  # 1, 2 or 3
    file_index: int = 0  # which file of a rotated set (ub_log_open_path)
    first_seq: int | None = None  # sequence number of the file's first record (format 2)
    damaged: int = 0  # copies of the header that failed their checks: 1 the primary, 2 the spare (format 3)
    repaired: bool = False  # neither copy was whole: the header was joined from the sound parts of both
    lost: bool = False  # no copy is left: no meta (node, links, times); records read with an external catalogue
    catalogue_origin: str = "embedded catalogue"  # or the --catalogue file the records are decoded with
    max_files: int = 0  # the writer's max_files (format 3): older files of the set are deleted by design
    deleted_file: int | None = None  # the file of the set whose deletion the start of this one caused

    def header_note(self) -> str:
        """One line on the header's state: "" when both copies are whole."""
        if self.lost:
            return ("both copies of the header are lost (no node, links or start time); records read and "
                    f"decoded with {self.catalogue_origin}")
        if self.repaired:
            return "both copies of the header damaged in different places: joined from the sound parts of both"
        which = {1: "primary copy damaged, spare used", 2: "spare copy damaged (the primary is whole)",
                 3: "both copies damaged"}
        return f"header {which[self.damaged]}" if self.damaged else ""

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
    seq: int = 0  # the writer's record number (format 1: numbered by the reader)

    @property
    def payload(self) -> bytes:
        # after the 64-byte header; a signed or encrypted frame's trailer follows it (docs/wire-format.md)
        return self.frame[64:64 + self.header.payload_size]


@dataclass
class ReadStats:
    """What the reader saw. Every byte of the file is either in a record, the header, or ignored."""

    records: int = 0
    record_bytes: int = 0
    ignored_bytes: int = 0  # bytes in no good record: damaged records, garbage, a cut tail
    ignored_reason: str = ""  # "" when nothing was ignored, else what: "2 damaged records skipped; ..."
    damaged_records: int = 0  # records whose header held and whose frame failed its check
    resyncs: int = 0  # times the record boundary was lost (bytes lost or inserted) and found again
    truncated_bytes: int = 0  # an incomplete record at the end (a crash or a copy cut it)
    missing_records: int = 0  # absent by the sequence numbers: not written (disk full...) or lost to damage
    seq_restarts: int = 0  # the sequence went backwards: files of two runs joined
    bad_frames: int = 0  # records whose CRC held but whose frame the C codec rejected (skipped)
    by_reason: dict[str, int] = field(default_factory=dict)

    def update(self, c: dict[str, int]) -> None:
        """Takes the C reader's counters (ub_log_reader_stats) and describes them."""
        self.ignored_bytes = c["skipped_bytes"]
        for name in ("damaged_records", "resyncs", "truncated_bytes", "missing_records", "seq_restarts"):
            setattr(self, name, c[name])
        parts = []
        if self.damaged_records:
            parts.append(f"{self.damaged_records} damaged record{'s' if self.damaged_records != 1 else ''} skipped")
        if self.resyncs:
            parts.append(f"{self.resyncs} damaged region{'s' if self.resyncs != 1 else ''} skipped "
                         "(record boundary lost and found again)")
        if self.truncated_bytes:
            parts.append(f"partial record at the end (truncated tail, {self.truncated_bytes} bytes)")
        self.ignored_reason = "; ".join(parts) if self.ignored_bytes else ""


def _entity_text(raw: bytes) -> str:
    return raw.rstrip(b"\0").decode("ascii", "replace")


def _lost_header(version: int, size: int, damaged: int, catalogue_json: str, origin: str) -> LogHeader:
    return LogHeader(node="", links={}, start_unix_ms=0, start_t_ms=0, record_tx=False, meta={},
                     catalogue_json=catalogue_json, size=size, version=version, damaged=damaged, lost=True,
                     catalogue_origin=origin)


def parse_header(data: bytes | bytearray | memoryview, path: str = "<log>", catalogue_json: str | None = None,
                 catalogue_origin: str = "--catalogue") -> LogHeader | None:
    """The file header from the start of `data`; None when `data` is still too short to hold it.

    `catalogue_json` (a catalogue from elsewhere, e.g. `--catalogue FILE`) replaces the embedded one, and
    lets the records of a log whose header is lost be read (the header then has no meta: `lost`).
    Raises LogFormatError (message `path: ...`) when the bytes are not a valid log header and no
    catalogue was given."""
    try:
        raw = ub_log.ub_log_header_parse(data)
    except TruncatedError:
        return None
    except InvalidArgumentError:
        if catalogue_json is not None and len(data) >= FILE_HEADER.size:
            # No magic left at all: records of this writer's format are searched for from the start.
            return _lost_header(FORMAT, 0, ub_log.COPY_PRIMARY | ub_log.COPY_SPARE, catalogue_json, catalogue_origin)
        raise LogFormatError(f"{path}: not a uavbus log (no UBLOG1/UBLOG2/UBLOG3 magic)") from None
    except ub_log.HeaderLostError as lost:
        if catalogue_json is not None:
            return _lost_header(lost.version, lost.size, lost.damaged, catalogue_json, catalogue_origin)
        copies = "both copies of the log's metadata and catalogue are" if lost.version >= 3 else \
            "the log's metadata or catalogue is"
        raise LogFormatError(f"{path}: header CRC mismatch: {copies} damaged; its records can still be read "
                             "with --catalogue FILE (the catalogue it was recorded with)") from None
    try:
        meta = json.loads(raw.meta.decode("utf-8"))
        catalogue_json = catalogue_json if catalogue_json is not None else raw.catalogue.decode("utf-8")
        if not isinstance(meta, dict):
            raise ValueError("not an object")
        links = {int(k): str(v) for k, v in dict(meta.get("links", {})).items()}
        first_seq = meta.get("first_seq")
        deleted = meta.get("deleted_file")
        return LogHeader(node=str(meta.get("node", "")), links=links,
                         start_unix_ms=int(meta.get("start_unix_ms", 0)), start_t_ms=int(meta.get("start_t_ms", 0)),
                         record_tx=bool(meta.get("record_tx", False)), meta=meta,
                         catalogue_json=catalogue_json, size=raw.size, version=raw.version,
                         file_index=int(meta.get("file_index", 0)),
                         first_seq=int(first_seq) if isinstance(first_seq, int) else None,
                         damaged=raw.damaged, repaired=raw.repaired,
                         catalogue_origin=catalogue_origin if raw.catalogue != catalogue_json.encode() else
                         "embedded catalogue",
                         max_files=int(meta.get("max_files", 0)),
                         deleted_file=int(deleted) if isinstance(deleted, int) else None)
    except (UnicodeDecodeError, ValueError, TypeError, AttributeError) as exc:
        raise LogFormatError(f"{path}: header metadata is not valid JSON meta: {exc}") from exc


_COUNTERS = ("records", "record_bytes", "skipped_bytes", "damaged_records", "resyncs", "truncated_bytes",
             "missing_records", "seq_restarts")


class _RecordScanner:
    """Splits a growing byte buffer into records. Used by the one-shot reader and by follow mode, which
    moves it on to the next file of a rotated set (next_file) with the counters carried over."""

    def __init__(self, header: LogHeader, stats: ReadStats) -> None:
        self.stats = stats
        self._done = dict.fromkeys(_COUNTERS, 0)  # counters of the files already finished
        self.last_seq: int | None = None
        self._start(header)

    def _start(self, header: LogHeader) -> None:
        self.header = header
        self._reader = ub_log.LogRecordReader(header.version)
        if header.first_seq is not None:
            self._reader.expect_seq(header.first_seq)

    def next_file(self, header: LogHeader) -> None:
        """Goes on with the next file of a rotated set; records the writer lost between the two files
        (a file it could not open) count as missing."""
        for k, v in self._reader.stats().items():
            self._done[k] += v
        if self.last_seq is not None and header.first_seq is not None:
            gap = (header.first_seq - self.last_seq - 1) & 0xFFFFFFFF
            self._done["missing_records" if gap < 0x80000000 else "seq_restarts"] += gap if gap < 0x80000000 else 1
        self._start(header)

    def scan(self, buf: bytearray | bytes | memoryview, base: int,
             final: bool = False) -> tuple[list[LogRecord], int]:
        """Records in `buf` (file offset `base`) and the bytes decided; the rest waits for more (not final)."""
        raw, used = self._reader.scan(buf, final)
        out: list[LogRecord] = []
        for offset, seq, t_ms, link_id, direction, frame in raw:
            self.last_seq = seq
            try:
                h = ub_frame_parse(frame)
            except UbError as exc:
                # The writer logs only verified frames, so this is a damaged file; count, skip.
                self.stats.bad_frames += 1
                self.stats.by_reason[exc.name] = self.stats.by_reason.get(exc.name, 0) + 1
                continue
            out.append(LogRecord(offset=base + offset, t_ms=t_ms, link_id=link_id,
                                 link=self.header.link_name(link_id),
                                 dir=DIR_NAMES[direction] if direction < 2 else f"dir{direction}",
                                 frame=frame, header=h, seq=seq))
        c = {k: v + self._done[k] for k, v in self._reader.stats().items()}
        self.stats.records = c["records"]
        self.stats.record_bytes = c["record_bytes"]
        self.stats.update(c)
        return out, used


class LogReader:
    """Reads a whole log file. Iterate for records; `stats` and `ignored_bytes` after iterating.

        log = LogReader("gcs.ublog")
        for rec in log: print(rec.t_ms, rec.link, rec.header.seq)
        if log.ignored_bytes: print(log.stats.ignored_reason)
    """

    def __init__(self, path: str | os.PathLike[str], catalogue_json: str | None = None,
                 catalogue_origin: str = "--catalogue") -> None:
        """`catalogue_json`: a catalogue from elsewhere (`--catalogue FILE`), used instead of the embedded one
        and needed when the header is lost."""
        self.path = str(path)
        self._data = Path(path).read_bytes()
        header = parse_header(self._data, self.path, catalogue_json, catalogue_origin)
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
            body = memoryview(self._data)[self.header.size:]
            try:
                self._records, _ = scanner.scan(body, self.header.size, final=True)
            finally:
                body.release()
        return self._records

    def __iter__(self) -> Iterator[LogRecord]:
        return iter(self.records())

    def catalogue(self) -> Any:
        """The embedded catalogue as a uavbus.Catalogue (decode/encode with no generated code)."""
        return load_catalogue(self.header.catalogue_json)


def load_catalogue(catalogue_json: str) -> Any:
    from uavbus.catalogue import Catalogue  # room B's module; imported late so reading works without it

    return Catalogue.from_json_text(catalogue_json)


def _wait_header(f: BinaryIO, path: str, buf: bytearray, stop: Callable[[], bool] | None,
                 sleep: Callable[[float], None], poll_s: float, catalogue_json: str | None = None,
                 catalogue_origin: str = "--catalogue") -> LogHeader | None:
    """Reads from `f` into `buf` until the file header is whole; None when `stop()` says so first.

    A damaged primary copy hides where the spare copy starts until the spare's bytes are there, so a header
    that does not parse yet is only final once the file stops growing (the writer writes its header in one
    go) or `stop()` says no more will come: until then the bytes still to come may complete it."""
    while True:
        chunk = f.read()
        buf += chunk
        try:
            header = parse_header(buf, path, catalogue_json, catalogue_origin)
        except LogFormatError:
            if not chunk or (stop is not None and stop()):
                raise
            sleep(poll_s)
            continue
        if header is not None:
            return header
        if stop is not None and stop():
            return None
        sleep(poll_s)


def follow(path: str | os.PathLike[str], *, poll_s: float = 0.05, stop: Callable[[], bool] | None = None,
           from_start: bool = True, sleep: Callable[[float], None] = time.sleep,
           on_header: Callable[[LogHeader], None] | None = None,
           stats: ReadStats | None = None, rotation: bool = True, catalogue_json: str | None = None,
           catalogue_origin: str = "--catalogue") -> Iterator[LogRecord]:
    """Yields records of a log that is still being written, as they are appended (like tail -f).

    Waits for the file and its header to appear. A partial record at the end is waited for, not
    reported: the writer appends one record per write(). Damage is skipped and counted in `stats`
    (pass a ReadStats to see it), exactly as LogReader does. With `rotation` (the default), following
    the first file of a rotated set (ub_log_open_path, docs/log-format.md "Rotation") moves on to the
    next file once the writer has started it, with the counters carried over. `stop()` is checked
    between polls; `from_start=False` skips existing records. `catalogue_json`: as for LogReader."""
    path = str(path)
    stats = stats if stats is not None else ReadStats()
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
        header = _wait_header(f, path, buf, stop, sleep, poll_s, catalogue_json, catalogue_origin)
        if header is None:
            return
        if on_header is not None:
            on_header(header)
        scanner = _RecordScanner(header, stats)
        base = header.size
        del buf[: header.size]
        skip = not from_start
        index = 0
        rotation = rotation and header.version >= 2 and header.file_index == 0  # next files are named after `path`
        while True:
            records, used = scanner.scan(buf, base)
            del buf[:used]
            base += used
            if not skip:
                yield from records
            chunk = f.read()
            if chunk:
                buf += chunk
                continue
            skip = False
            nxt = ub_log.ub_log_file_name(path, index + 1) if rotation else ""
            if nxt and os.path.exists(nxt):
                # The writer has moved on: what is left of this file is all there will be.
                records, _ = scanner.scan(buf, base, final=True)
                yield from records
                f.close()
                f = open(nxt, "rb")  # noqa: SIM115
                buf = bytearray()
                nh = _wait_header(f, nxt, buf, stop, sleep, poll_s, catalogue_json, catalogue_origin)
                if nh is None:
                    return
                header, index, base = nh, index + 1, nh.size
                del buf[: nh.size]
                scanner.next_file(nh)
                continue
            if stop is not None and stop():
                return
            sleep(poll_s)
    finally:
        if f is not None:
            f.close()
