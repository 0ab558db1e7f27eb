"""Content and entity IDs (paper III.C); must agree byte for byte with runtime_c/src/codec/ub_catalogue.c.

Names are treated as their UTF-8 bytes (C identifiers plus `[i]` element suffixes are ASCII).
"""

from __future__ import annotations

from typing import Final

DIR_ID_LEN: Final = 16
ENTITY_ID_LEN: Final = 12
ID_SCHEMES: Final = ("paper", "hashed")


class IdError(ValueError):
    """A name that cannot be turned into an ID under the requested rule."""


def _head_tail(name: bytes, half: int) -> bytes:
    """First `half` and last `half` bytes; a name shorter than 2*half overlaps, one shorter than
    `half` fills both halves with itself, right-padded with 0x00."""
    head = name[:half].ljust(half, b"\0")
    tail = name[-half:] if len(name) >= half else name.ljust(half, b"\0")
    return head + tail


def crc16_ccitt_false(data: bytes) -> int:
    """CRC-16/CCITT-FALSE: poly 0x1021, init 0xFFFF, not reflected, no final xor ("123456789" -> 0x29B1)."""
    crc = 0xFFFF
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else (crc << 1)
            crc &= 0xFFFF
    return crc


def dir_id_paper(name: str) -> bytes:
    """Paper rule: first 8 + last 8 characters (`onboardSet` -> b"onboardSboardSet")."""
    raw = _require_name(name)
    return _head_tail(raw, 8)


def dir_id_hashed(name: str) -> bytes:
    """Opt-in rule: first 7 + last 7 characters (same overlap/padding rule as the paper's), then the
    CRC-16/CCITT-FALSE of the whole name, little-endian, in the last two bytes."""
    raw = _require_name(name)
    crc = crc16_ccitt_false(raw)
    return _head_tail(raw, 7) + bytes((crc & 0xFF, crc >> 8))


def dir_id(name: str, scheme: str) -> bytes:
    """The content ID of `name` under `scheme` ("paper" or "hashed")."""
    if scheme == "paper":
        return dir_id_paper(name)
    if scheme == "hashed":
        return dir_id_hashed(name)
    raise IdError(f"unknown ID scheme '{scheme}' (expected one of: {', '.join(ID_SCHEMES)})")


def entity_id(name: str) -> bytes:
    """Entity ID: the name itself, NUL-padded to 12 bytes. Longer (or empty) names are an error."""
    raw = _require_name(name)
    if len(raw) > ENTITY_ID_LEN:
        raise IdError(f"entity name '{name}' is {len(raw)} bytes; entity IDs hold at most {ENTITY_ID_LEN}")
    return raw.ljust(ENTITY_ID_LEN, b"\0")


def _require_name(name: str) -> bytes:
    if not name:
        raise IdError("an ID needs a non-empty name")
    return name.encode("utf-8")
