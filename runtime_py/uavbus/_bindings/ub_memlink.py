"""Wrappers for ub_memlink.h: the in-process link between two node slots."""

from __future__ import annotations

from typing import Any

from uavbus._bindings.ub_error import InvalidArgumentError, ensure
from uavbus._ub import ffi, lib

FAULT_FIELDS = ("loss_ppm", "duplicate_ppm", "reorder_ppm", "corrupt_ppm", "delay_ms", "jitter_ms",
                "reorder_delay_ms")
_STAT_FIELDS = ("sent", "delivered", "lost", "duplicated", "reordered", "corrupted", "overflow", "rejected")


def _faults(faults: dict[str, int] | None) -> Any:
    c = ffi.new("ub_memlink_faults_t *")
    for key, value in (faults or {}).items():
        if key not in FAULT_FIELDS:
            raise InvalidArgumentError(f"unknown memlink fault {key!r} (one of {', '.join(FAULT_FIELDS)})")
        setattr(c, key, value)
    return c


def ub_memlink_new(faults: dict[str, int] | None, seed: int) -> Any:
    ml = ffi.new("ub_memlink_t *")
    lib.ub_memlink_init(ml, _faults(faults), seed)
    return ml


def ub_memlink_set_faults(ml: Any, faults: dict[str, int] | None) -> None:
    lib.ub_memlink_set_faults(ml, _faults(faults))


def ub_memlink_connect(ml: Any, a: Any, link_a: int, b: Any, link_b: int) -> None:
    ensure(lib.ub_memlink_connect(ml, a, link_a, b, link_b), "ub_memlink_connect")


def ub_memlink_disconnect(ml: Any) -> None:
    lib.ub_memlink_disconnect(ml)


def ub_memlink_pump(ml: Any, now_ms: int) -> int:
    return int(lib.ub_memlink_pump(ml, now_ms))


def ub_memlink_pending(ml: Any) -> int:
    return int(lib.ub_memlink_pending(ml))


def ub_memlink_stats(ml: Any, side: int) -> dict[str, int]:
    s = lib.ub_memlink_stats(ml, side)
    return {k: int(getattr(s, k)) for k in _STAT_FIELDS}
