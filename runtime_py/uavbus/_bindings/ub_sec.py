"""Wrappers for ub_sec.h and ub_secfile.h: the keyring, signing / AEAD and verification of whole
frames, and key files. All cryptography is the C runtime's (libsodium); Python only moves bytes."""

from __future__ import annotations

from typing import Any

from uavbus._bindings.ub_error import InvalidArgumentError, ensure
from uavbus._bindings.ub_frame import FrameHeader, _header_from_c, _header_to_c
from uavbus._ub import ffi, lib

KEY_LEN: int = lib.UB_SEC_KEY_LEN
ERR_LEN: int = lib.UB_SECFILE_ERR_LEN
FRAME_MAX: int = lib.UB_FRAME_MAX
MAX_PAYLOAD: int = lib.UB_MAX_PAYLOAD
STATS_FIELDS = ("signed_out", "encrypted_out", "verified_in", "decrypted_in", "auth_failures", "unknown_keys",
                "challenges_sent", "challenges_completed", "replies_sent", "replies_suppressed", "reservations",
                "reserve_failures", "tx_refused", "rechallenges", "window_resets")


def available() -> bool:
    """Whether this build has cryptography (libsodium)."""
    return bool(lib.ub_sec_available())


def _text(err: Any) -> str:
    return ffi.string(err).decode("utf-8", "replace")


def _path(path: str) -> bytes:
    raw = str(path).encode("utf-8")
    if b"\0" in raw:
        raise InvalidArgumentError(f"path {path!r} contains a NUL byte")
    return raw


def ub_sec_new(keys: dict[int, bytes] | None = None, tx_key: int = 0, counter: int = 1) -> Any:
    """A started context (counters not persisted) holding `keys` (id -> 32 bytes): for tests and tools.
    Nodes that sign get theirs from the config (ub_nodecfg_apply_security), with a counter file."""
    sec = ffi.new("ub_sec_t *")
    ensure(lib.ub_sec_init(sec, ffi.NULL), "ub_sec_init")
    for key_id, key in (keys or {}).items():
        ub_sec_add_key(sec, key_id, key)
    if tx_key:
        ensure(lib.ub_sec_set_tx_key(sec, tx_key), f"tx key {tx_key}")
    ensure(lib.ub_sec_start(sec, counter, 0), "ub_sec_start")
    return sec


def ub_sec_add_key(sec: Any, key_id: int, key: bytes) -> None:
    if len(key) != KEY_LEN:
        raise InvalidArgumentError(f"a key is {KEY_LEN} bytes, got {len(key)}")
    ensure(lib.ub_sec_add_key(sec, key_id, key), f"add key {key_id}")


def ub_sec_remove_key(sec: Any, key_id: int) -> None:
    ensure(lib.ub_sec_remove_key(sec, key_id), f"remove key {key_id} (the signing key cannot be removed)")


def ub_sec_set_tx_key(sec: Any, key_id: int) -> None:
    ensure(lib.ub_sec_set_tx_key(sec, key_id), f"use key {key_id}")


def ub_sec_tx_key(sec: Any) -> int:
    return int(lib.ub_sec_tx_key(sec))


def ub_sec_key_ids(sec: Any) -> list[int]:
    ids = ffi.new("uint8_t[]", 256)
    n = lib.ub_sec_key_ids(sec, ids, 256)
    return [int(ids[i]) for i in range(n)]


def ub_sec_stats(sec: Any) -> dict[str, int]:
    s = lib.ub_sec_stats(sec)
    return {name: int(getattr(s, name)) for name in STATS_FIELDS}


def ub_sec_protect(sec: Any, header: FrameHeader, payload: bytes) -> bytes:
    """The SIGNED or ENCRYPTED frame (header.flags) for `header` (key_id, seq, counter_hi set) and the
    plaintext `payload`, made by the C runtime."""
    c = _header_to_c(header)
    c.payload_size = len(payload)
    frame = ffi.new("uint8_t[]", FRAME_MAX)
    n = ensure(lib.ub_sec_protect(sec, c, payload, frame, FRAME_MAX), "ub_sec_protect")
    return bytes(ffi.buffer(frame, n))


def ub_sec_verify(sec: Any, frame: bytes) -> tuple[FrameHeader, bytes]:
    """Parses and verifies a flagged frame; returns its header and plaintext payload. Raises
    AuthError (bad tag), NotFoundError (unknown key), or the parse errors."""
    c = ffi.new("ub_frame_header_t *")
    ensure(lib.ub_frame_parse(frame, len(frame), c), "ub_frame_parse")
    plain = ffi.new("uint8_t[]", MAX_PAYLOAD)
    ensure(lib.ub_sec_verify(sec, c, frame, len(frame), plain, MAX_PAYLOAD), "ub_sec_verify")
    header = _header_from_c(c)
    if header.flags & lib.UB_FRAME_FLAG_ENCRYPTED:
        return header, bytes(ffi.buffer(plain, header.payload_size))
    return header, bytes(frame[64:64 + header.payload_size])


def ub_sec_wall_counter(unix_us: int) -> int:
    return int(lib.ub_sec_wall_counter(unix_us))


def ub_keyfile_new(path: str, key_id: int = 0) -> int:
    """Writes a new random key to `path` (mode 0600, never overwriting); returns its id."""
    if not 0 <= key_id <= 255:
        raise InvalidArgumentError(f"key id {key_id}: use 1..255 (or 0 for a random one)")
    out = ffi.new("uint8_t *")
    err = ffi.new("char[]", ERR_LEN)
    ensure(lib.ub_keyfile_new(_path(path), key_id, out, err, ERR_LEN), _text(err) or str(path))
    return int(out[0])


def ub_keyfile_load(path: str) -> tuple[int, bytes]:
    """Reads a key file (refused when group/other-accessible): (id, key)."""
    out = ffi.new("uint8_t *")
    key = ffi.new("uint8_t[]", KEY_LEN)
    err = ffi.new("char[]", ERR_LEN)
    ensure(lib.ub_keyfile_load(_path(path), out, key, err, ERR_LEN), _text(err) or str(path))
    return int(out[0]), bytes(key)
