"""Wrappers for ub_nmea.h, ub_ubx.h and ub_gps_fields.h: the GPS parsers and their directory mapping (#24).

The parsers are C state machines (one implementation for uavbus_node and Python); these wrappers feed them
bytes and read back counters and the (member, value) pairs ub_gps_fields.h maps their state to. No
callback crosses into Python: a parser merges what it decodes into its own state (the NMEA fix, the last
NAV-PVT and ACK), and the caller reads that state once per fed run."""

from __future__ import annotations

from typing import Any

from uavbus._bindings.ub_error import ensure
from uavbus._ub import ffi, lib

NMEA_STATS = ("bytes_in", "noise_bytes", "bytes_in_sentences", "sentences_ok", "bad_checksum", "no_checksum",
              "malformed", "overlong", "unsupported")
NMEA_KINDS = ("gga", "rmc", "vtg", "gsa")
UBX_STATS = ("bytes_in", "noise_bytes", "bytes_in_messages", "nav_pvt", "bad_checksum", "bad_length", "ack",
             "nak", "too_long", "unsupported")


def ub_nmea_new() -> Any:
    """A fresh NMEA parser (caller-owned cdata, freed with it)."""
    nmea = ffi.new("ub_nmea_t *")
    lib.ub_nmea_init(nmea)
    return nmea


def ub_nmea_feed(nmea: Any, data: bytes) -> int:
    """Feeds `data` (any cut). Returns the good sentences merged into the fix by this call."""
    return ensure(lib.ub_nmea_feed(nmea, data, len(data), ffi.NULL, ffi.NULL), "ub_nmea_feed")


def nmea_stats(nmea: Any) -> dict[str, int]:
    s = nmea.stats
    out = {k: int(getattr(s, k)) for k in NMEA_STATS}
    out.update({k: int(s.by_kind[i]) for i, k in enumerate(NMEA_KINDS)})
    return out


def ub_ubx_new() -> Any:
    """A fresh UBX parser (caller-owned cdata, freed with it)."""
    ubx = ffi.new("ub_ubx_t *")
    lib.ub_ubx_init(ubx)
    return ubx


def ub_ubx_feed(ubx: Any, data: bytes) -> int:
    """Feeds `data` (any cut). Returns the good NAV-PVT decoded by this call."""
    return ensure(lib.ub_ubx_feed(ubx, data, len(data), ffi.NULL, ffi.NULL), "ub_ubx_feed")


def ubx_stats(ubx: Any) -> dict[str, int]:
    return {k: int(getattr(ubx.stats, k)) for k in UBX_STATS}


def ub_ubx_cfg_new() -> Any:
    """A fresh CFG-RATE exchange (ub_ubx_cfg_t: what to send, the answer awaited, its counters)."""
    cfg = ffi.new("ub_ubx_cfg_t *")
    lib.ub_ubx_cfg_init(cfg)
    return cfg


class CfgRate:
    """One turn of the CFG-RATE exchange: poll() builds what to write for the wanted rate (b"" if nothing),
    sent() records that it was written whole, answer() gives it the parser's last ACK-ACK/ACK-NAK."""

    def __init__(self) -> None:
        self.c = ub_ubx_cfg_new()
        self._want = ffi.new("ub_ubx_rate_t *")
        self._out = ffi.new("uint8_t[]", 8 + int(lib.UB_UBX_CFG_RATE_LEN))

    def poll(self, meas_rate_ms: int, nav_rate: int, time_ref: int, now_ms: int) -> bytes:
        w = self._want
        w.meas_rate_ms, w.nav_rate, w.time_ref = meas_rate_ms, nav_rate, time_ref
        n = ensure(lib.ub_ubx_cfg_poll(self.c, w, now_ms, self._out, len(self._out)), "ub_ubx_cfg_poll")
        return bytes(ffi.buffer(self._out, n))

    def sent(self, now_ms: int) -> None:
        lib.ub_ubx_cfg_sent(self.c, self._want, now_ms)

    def answer(self, ubx: Any) -> bool:
        return bool(lib.ub_ubx_cfg_answer(self.c, ffi.addressof(ubx, "ack")))


def ub_ubx_build(cls: int, msg_id: int, payload: bytes) -> bytes:
    """One UBX message (sync, class, id, length, payload, Fletcher checksum)."""
    out = ffi.new("uint8_t[]", 8 + len(payload))
    n = ensure(lib.ub_ubx_build(cls, msg_id, payload, len(payload), out, len(out)), "ub_ubx_build")
    return bytes(ffi.buffer(out, n))


def values_buffer() -> Any:
    """Room for any of the value lists (UB_DIR_VALUES_MAX), to pass to the *_dir_values() calls again."""
    return ffi.new("ub_dir_value_t[]", int(lib.UB_DIR_VALUES_MAX))


def _values(fn: Any, parser: Any, out: Any = None) -> list[tuple[str, float, bool]]:
    out = values_buffer() if out is None else out
    n = int(fn(parser, out, len(out)))
    if n > len(out):
        raise RuntimeError(f"ub_gps_fields.h maps {n} members, more than UB_DIR_VALUES_MAX ({len(out)})")
    return [(ffi.string(out[i].member).decode("ascii"), float(out[i].value), bool(out[i].counter)) for i in range(n)]


def ubx_cfg_dir_values(cfg: Any, out: Any = None) -> list[tuple[str, float, bool]]:
    """gpsUbx's cfgSent/cfgAcked/cfgNaked/cfgTimeouts/cfgMeasRateMs from the CFG-RATE exchange."""
    return _values(lib.ub_ubx_cfg_dir_values, cfg, out)


def nmea_dir_values(nmea: Any, out: Any = None) -> list[tuple[str, float, bool]]:
    """gpsNmea's (member, value, is_counter) from the parser's state (ub_gps_fields.h's lists)."""
    return _values(lib.ub_nmea_dir_values, nmea, out)


def ubx_dir_values(ubx: Any, out: Any = None) -> list[tuple[str, float, bool]]:
    """gpsUbx's (member, value, is_counter) from the parser's last NAV-PVT and counters."""
    return _values(lib.ub_ubx_dir_values, ubx, out)
