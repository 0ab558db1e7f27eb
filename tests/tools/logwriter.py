"""Test-only log writer: Contract 3 / docs/log-format.md byte for byte, in plain Python.

The product writes logs with the C writer (ub_log.h); this small writer lets the reader and the
tools be tested on files whose every byte the test controls (cut points, damaged records). Its CRC
is an independent bitwise CRC-32C, so a reader bug cannot be hidden by sharing the C checksum.
"""

from __future__ import annotations

import json
import struct
from pathlib import Path
from typing import Any

MAGIC = b"UBLOG1\r\n"


def crc32c(data: bytes, crc: int = 0) -> int:
    crc ^= 0xFFFFFFFF
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = (crc >> 1) ^ (0x82F63B78 if crc & 1 else 0)
    return crc ^ 0xFFFFFFFF


def file_header(node: str, links: dict[int, str], catalogue_json: str, start_unix_ms: int = 1_700_000_000_000) -> bytes:
    meta = json.dumps({"format": 1, "node": node, "links": {str(k): v for k, v in links.items()},
                       "start_unix_ms": start_unix_ms, "start_t_ms": 1000, "record_tx": True}, separators=(",", ":")).encode()
    cat = catalogue_json.encode()
    return MAGIC + struct.pack("<III", len(meta), len(cat), crc32c(meta + cat)) + meta + cat


def record(frame: bytes, t_ms: int, link_id: int, direction: int = 0) -> bytes:
    head = struct.pack("<HHQBBH", 0xB10C, len(frame), t_ms, link_id, direction, 0)
    return head + struct.pack("<I", crc32c(head + frame)) + frame


def write_log(path: Path, node: str, links: dict[int, str], catalogue_json: str,
              records: list[tuple[bytes, int, int, int]], **kw: Any) -> bytes:
    """Writes header + records [(frame, t_ms, link_id, dir)]; returns the file's bytes."""
    data = file_header(node, links, catalogue_json, **kw) + b"".join(record(*r) for r in records)
    path.write_bytes(data)
    return data
