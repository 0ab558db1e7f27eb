"""Wrappers for ub_motion.h: the simulated vehicles' flight model (the one uavbus_node flies)."""

from __future__ import annotations

from typing import Any

from uavbus._bindings.ub_error import InvalidArgumentError
from uavbus._ub import ffi, lib


class MotionError(InvalidArgumentError):
    """A motion text the C parser refused; `detail` is its message ("motion: 'r=0': r must be > 0 m")."""

    def __init__(self, detail: str) -> None:
        super().__init__(detail)
        self.detail = detail


def ub_motion_parse(text: str) -> Any:
    """The model for `text` ("orbit:r=200,v=10", "waypoints:v=12,pts=0/0;800/0", "static:n=5")."""
    m = ffi.new("ub_motion_t *")
    err = ffi.new("char[]", 200)
    if lib.ub_motion_parse(text.encode("utf-8"), m, err, len(err)) != 0:
        raise MotionError(ffi.string(err).decode("utf-8"))
    return m


def ub_motion_sample(m: Any, t_s: float, out: Any | None = None) -> Any:
    """A ub_motion_state_t * at `t_s` (reuses `out` when given)."""
    s = out if out is not None else ffi.new("ub_motion_state_t *")
    lib.ub_motion_sample(m, t_s, s)
    return s
