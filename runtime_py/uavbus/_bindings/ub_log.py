"""Wrappers for ub_log.h: the C binary-log writer, installed as the node's C tap (no Python per frame),
and the C log reader, which finds records again after damage and counts what it skipped."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from uavbus._bindings.ub_catalogue import _c_name
from uavbus._bindings.ub_error import ChecksumError, RangeError, ensure
from uavbus._ub import ffi, lib

FILE_HEADER_LEN: int = lib.UB_LOG_FILE_HEADER_LEN
RECORD_HEADER_LEN: int = lib.UB_LOG_RECORD_HEADER_LEN
V1_RECORD_HEADER_LEN: int = lib.UB_LOG_V1_RECORD_HEADER_LEN
FORMAT: int = lib.UB_LOG_FORMAT
COPY_PRIMARY: int = lib.UB_LOG_COPY_PRIMARY
COPY_SPARE: int = lib.UB_LOG_COPY_SPARE


def ub_log_open(fd: int, node: Any, node_name: str, record_tx: bool, start_unix_ms: int, start_t_ms: int) -> Any:
    log = ffi.new("ub_log_t *")
    ensure(lib.ub_log_open(log, fd, node, _c_name(node_name), record_tx, start_unix_ms, start_t_ms),
           f"log for node {node_name!r}")
    return log


def ub_log_open_path(path: str, node: Any, node_name: str, record_tx: bool, start_unix_ms: int, start_t_ms: int,
                     max_bytes: int = 0, max_ms: int = 0, max_files: int = 0) -> Any:
    """A log the C writer opens and owns at `path`, rotated by size/time, keeping `max_files` (0 = no limit).
    A `max_bytes` below ub_log_rotation_floor() is refused (RangeError, saying the floor)."""
    log = ffi.new("ub_log_t *")
    rot = ffi.new("ub_log_rotation_t *", {"max_bytes": max_bytes, "max_ms": max_ms, "max_files": max_files})
    rc = lib.ub_log_open_path(log, path.encode(), rot, node, _c_name(node_name), record_tx, start_unix_ms, start_t_ms)
    if rc == lib.UB_ERR_RANGE and max_bytes:
        floor = ub_log_rotation_floor(node, node_name)
        raise RangeError(f"log {path!r}: max_bytes {max_bytes} is below {floor}, the smallest file that holds "
                             "the log header (meta and catalogue, twice) and one largest record: raise it")
    ensure(rc, f"log {path!r}")
    return log


def ub_log_rotation_floor(node: Any, node_name: str) -> int:
    """The smallest max_bytes a rotating log of `node` accepts (its header twice and one largest record)."""
    out = ffi.new("uint64_t *")
    ensure(lib.ub_log_rotation_floor(node, _c_name(node_name), out), f"log rotation floor of {node_name!r}")
    return int(out[0])


def ub_log_install(node: Any, log: Any) -> None:
    """Makes `log` the node's frame tap (`log` must stay alive until removed)."""
    lib.ub_node_set_tap(node, lib.ub_log_tap, log)


def ub_log_write(log: Any, link_id: int, direction: int, frame: bytes, now_ms: int) -> int:
    """Writes one frame record. Never raises (it runs in the node's frame tap): a failure is counted in the
    writer's stats (ub_log_stats()) and its code returned."""
    return int(lib.ub_log_write(log, link_id, direction, frame, len(frame), now_ms))


def ub_log_stats(log: Any) -> dict[str, int]:
    s = lib.ub_log_stats(log)
    return {"records": int(s.records), "bytes": int(s.bytes), "write_errors": int(s.write_errors),
            "skipped_tx": int(s.skipped_tx), "last_errno": int(s.last_errno), "torn_writes": int(s.torn_writes),
            "torn_bytes": int(s.torn_bytes), "recoveries": int(s.recoveries), "files": int(s.files),
            "files_deleted": int(s.files_deleted), "open_errors": int(s.open_errors),
            "limit_rotations": int(s.limit_rotations), "delete_errors": int(s.delete_errors)}


def ub_log_close(log: Any) -> None:
    lib.ub_log_close(log)


def ub_log_file_name(path: str, index: int) -> str:
    """Name of file `index` of a rotated set opened at `path` (index 0 is `path` itself)."""
    out = ffi.new("char[]", len(path.encode()) + 16)
    ensure(lib.ub_log_file_name(path.encode(), index, out, len(out)), f"log file name for {path!r}")
    return ffi.string(out).decode()


@dataclass(frozen=True)
class RawHeader:
    """ub_log_header_t: the format version, the header's size, its meta and catalogue bytes, and which copies
    of the header failed their checks (COPY_PRIMARY / COPY_SPARE; `repaired`: rebuilt from both)."""

    version: int
    size: int
    meta: bytes
    catalogue: bytes
    damaged: int = 0
    repaired: bool = False


class HeaderLostError(ChecksumError):
    """No copy of the header is whole: `version` and `size` (where the records start; 0 when unknown) say
    where to read the records from, with a catalogue from elsewhere."""

    def __init__(self, message: str, version: int, size: int, damaged: int) -> None:
        super().__init__(message)
        self.version, self.size, self.damaged = version, size, damaged


def ub_log_header_parse(data: bytes | bytearray | memoryview) -> RawHeader:
    """Parses the file header at the start of `data`; raises the UbError of ub_log_header_parse()
    (InvalidArgumentError: not a log; TruncatedError: read more; HeaderLostError, a ChecksumError: no copy
    whole). A version 3 header whose two copies are each damaged in a different part is rebuilt from both
    (ub_log_header_repair() on a copy of the header bytes; `data` is not changed)."""
    buf = ffi.from_buffer("uint8_t[]", data)
    hdr = ffi.new("ub_log_header_t *")
    rc = lib.ub_log_header_parse(buf, len(buf), hdr)
    repaired = False
    if rc == lib.UB_ERR_CHECKSUM and hdr.size:
        fixed = bytearray(memoryview(data)[:hdr.size])
        fbuf = ffi.from_buffer("uint8_t[]", fixed)
        damaged = int(hdr.damaged)
        if lib.ub_log_header_repair(fbuf, len(fbuf)) == 0:
            rc = lib.ub_log_header_parse(fbuf, len(fbuf), hdr)
            repaired, buf = rc == 0, fbuf
            hdr.damaged = damaged
    if rc == lib.UB_ERR_CHECKSUM:
        raise HeaderLostError("log header: no copy whole", int(hdr.version), int(hdr.size), int(hdr.damaged))
    ensure(rc, "log header")
    meta = ffi.buffer(hdr.meta, hdr.meta_len)[:]
    cat = ffi.buffer(hdr.catalogue, hdr.catalogue_len)[:]
    return RawHeader(version=int(hdr.version), size=int(hdr.size), meta=meta, catalogue=cat,
                     damaged=int(hdr.damaged), repaired=repaired)


# One record: offset in the window, seq, t_ms, link_id, dir, frame bytes.
RawRecord = tuple[int, int, int, int, int, bytes]


class LogRecordReader:
    """ub_log_reader_t over successive windows of a file's body (everything after the header)."""

    def __init__(self, version: int) -> None:
        self._rd = ffi.new("ub_log_reader_t *")
        self._rec = ffi.new("ub_log_record_t *")
        lib.ub_log_reader_begin(self._rd, version)

    def expect_seq(self, seq: int) -> None:
        lib.ub_log_reader_expect_seq(self._rd, seq & 0xFFFFFFFF)

    def scan(self, window: bytes | bytearray | memoryview, final: bool) -> tuple[list[RawRecord], int]:
        """The good records of `window` and how many of its bytes were decided; the rest must be
        passed again, followed by more bytes (unless `final`)."""
        buf = ffi.from_buffer("uint8_t[]", window)
        lib.ub_log_reader_data(self._rd, buf, len(buf), final)
        out: list[RawRecord] = []
        rec = self._rec
        while lib.ub_log_reader_next(self._rd, rec) == 1:
            out.append((int(rec.offset), int(rec.seq), int(rec.t_ms), int(rec.link_id), int(rec.dir),
                        ffi.buffer(rec.frame, rec.len)[:]))
        consumed = int(lib.ub_log_reader_consumed(self._rd))
        lib.ub_log_reader_data(self._rd, ffi.NULL, 0, final)  # no pointer into `window` outlives this call
        return out, consumed

    def stats(self) -> dict[str, int]:
        s = lib.ub_log_reader_stats(self._rd)
        return {"records": int(s.records), "record_bytes": int(s.record_bytes),
                "skipped_bytes": int(s.skipped_bytes), "damaged_records": int(s.damaged_records),
                "resyncs": int(s.resyncs), "truncated_bytes": int(s.truncated_bytes),
                "missing_records": int(s.missing_records), "seq_restarts": int(s.seq_restarts)}
