"""Test-only log writer: docs/log-format.md byte for byte, in plain Python.

The product writes logs with the C writer (ub_log.h); this small writer lets the reader and the
tools be tested on files whose every byte the test controls (cut points, damaged records). Its CRC
is an independent bitwise CRC-32C, so a reader bug cannot be hidden by sharing the C checksum.
Format 3 by default (the header twice); `version=2` (one header copy) and `version=1` (the first writer's
layout) write the older formats, which are still read.
"""

from __future__ import annotations

import json
import struct
from pathlib import Path
from typing import Any

MAGIC = b"UBLOG3\r\n"
MAGIC_V2 = b"UBLOG2\r\n"
MAGIC_V1 = b"UBLOG1\r\n"


def crc32c(data: bytes, crc: int = 0) -> int:
    crc ^= 0xFFFFFFFF
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = (crc >> 1) ^ (0x82F63B78 if crc & 1 else 0)
    return crc ^ 0xFFFFFFFF


def file_header(node: str, links: dict[int, str], catalogue_json: str, start_unix_ms: int = 1_700_000_000_000,
                version: int = 3, first_seq: int = 0, file_index: int = 0) -> bytes:
    meta_obj: dict[str, Any] = {"format": version, "node": node, "links": {str(k): v for k, v in links.items()},
                                "start_unix_ms": start_unix_ms, "start_t_ms": 1000, "record_tx": True}
    if version >= 2:
        meta_obj.update(file_index=file_index, first_seq=first_seq)
    if version >= 3:
        meta_obj.update(max_files=0)
    meta = json.dumps(meta_obj, separators=(",", ":")).encode()
    cat = catalogue_json.encode()
    if version >= 3:  # magic, lengths, crc, head_crc over the 20 bytes before it; the copy twice
        fixed = MAGIC + struct.pack("<III", len(meta), len(cat), crc32c(meta + cat))
        copy = fixed + struct.pack("<I", crc32c(fixed)) + meta + cat
        return copy + copy
    magic = MAGIC_V2 if version == 2 else MAGIC_V1
    return magic + struct.pack("<III", len(meta), len(cat), crc32c(meta + cat)) + meta + cat


def record(frame: bytes, t_ms: int, link_id: int, direction: int = 0, *, seq: int = 0, version: int = 3) -> bytes:
    if version == 1:
        head = struct.pack("<HHQBBH", 0xB10C, len(frame), t_ms, link_id, direction, 0)
        return head + struct.pack("<I", crc32c(head + frame)) + frame
    head = struct.pack("<HHIQBBH", 0xB10C, len(frame), seq, t_ms, link_id, direction, 0)
    head_crc = crc32c(head)
    return head + struct.pack("<II", head_crc, crc32c(frame, head_crc)) + frame


def write_log(path: Path, node: str, links: dict[int, str], catalogue_json: str,
              records: list[tuple[bytes, int, int, int]], version: int = 3, **kw: Any) -> bytes:
    """Writes header + records [(frame, t_ms, link_id, dir)], numbered from 0; returns the file's bytes."""
    data = file_header(node, links, catalogue_json, version=version, **kw) + b"".join(
        record(*r, seq=i, version=version) for i, r in enumerate(records))
    path.write_bytes(data)
    return data
