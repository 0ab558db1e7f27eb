"""Wrappers for ub_error.h: the exception hierarchy for the runtime's negative error codes.

Every code maps to one `UbError` subclass that also inherits from the closest builtin, so callers can
catch either (`except ValueError` or `except ChecksumError`). Code values are read from C.
"""

from __future__ import annotations

import builtins

from uavbus._ub import ffi, lib


class UbError(Exception):
    """A uavbus runtime function returned a negative error code (`code`, named by `name`)."""

    code: int = 0

    def __init__(self, message: str = "") -> None:
        super().__init__(f"{self.name}: {message}" if message else self.name)
        self.detail = message or self.name  # the message without the code name

    @property
    def name(self) -> str:
        return ub_strerror(self.code)


class InvalidArgumentError(UbError, builtins.ValueError):
    code = lib.UB_ERR_INVAL


class NoSpaceError(UbError, builtins.BufferError):
    code = lib.UB_ERR_NOSPACE


class TruncatedError(UbError, builtins.ValueError):
    code = lib.UB_ERR_TRUNCATED


class FullError(UbError):
    code = lib.UB_ERR_FULL


class NotFoundError(UbError, builtins.LookupError):
    code = lib.UB_ERR_NOTFOUND


class ExistsError(UbError):
    code = lib.UB_ERR_EXISTS


class ChecksumError(UbError, builtins.ValueError):
    code = lib.UB_ERR_CHECKSUM


class LayoutError(UbError, builtins.ValueError):
    code = lib.UB_ERR_LAYOUT


class NoRouteError(UbError):
    code = lib.UB_ERR_NOROUTE


class IoError(UbError, builtins.OSError):
    code = lib.UB_ERR_IO


class WouldBlockError(UbError, builtins.BlockingIOError):
    code = lib.UB_ERR_AGAIN


class ConfigError(UbError, builtins.ValueError):
    """A configuration the C loader refused. str() is its one-line message, ``file:line: ...`` (no code
    name: the message is complete); `path` and `line` say where (line 0 when no line applies)."""

    code = lib.UB_ERR_CONFIG

    def __init__(self, message: str = "", path: str = "", line: int = 0) -> None:
        Exception.__init__(self, message or self.name)
        self.detail = message or self.name
        self.path = path
        self.line = line


class ClosedError(UbError, builtins.ConnectionError):
    code = lib.UB_ERR_CLOSED


class RangeError(UbError, builtins.OverflowError):
    code = lib.UB_ERR_RANGE


class AuthError(UbError, builtins.ValueError):
    """A frame's tag does not verify (forged, damaged after its CRC was made, or a wrong key)."""
    code = lib.UB_ERR_AUTH


class UnsupportedError(UbError, builtins.NotImplementedError):
    """Not in this build (e.g. security in a build without libsodium)."""
    code = lib.UB_ERR_UNSUPPORTED


class RefusedError(UbError, builtins.PermissionError):
    """The remote target answered with a NACK; `reason` names it ("not_authorized", "unbound", ...)."""
    code = lib.UB_ERR_REFUSED

    def __init__(self, message: str = "", reason: str = "") -> None:
        super().__init__(message)
        self.reason = reason


class NoAnswerError(UbError, builtins.TimeoutError):
    """The remote target did not answer within the retries (no route, down, or frames lost)."""
    code = lib.UB_ERR_NOANSWER


ERRORS_BY_CODE: dict[int, type[UbError]] = {
    cls.code: cls
    for cls in (
        InvalidArgumentError, NoSpaceError, TruncatedError, FullError, NotFoundError, ExistsError,
        ChecksumError, LayoutError, NoRouteError, IoError, WouldBlockError, ConfigError, ClosedError,
        RangeError, AuthError, UnsupportedError, RefusedError, NoAnswerError,
    )
}


def ub_strerror(err: int) -> str:
    """The C name of an error code ("UB_ERR_INVAL", ...), as the runtime reports it."""
    return ffi.string(lib.ub_strerror(err)).decode("ascii")


def error_for(code: int, message: str = "") -> UbError:
    """The exception for a negative `code`; an unknown code gives a bare `UbError` that keeps it."""
    cls = ERRORS_BY_CODE.get(code)
    if cls is not None:
        return cls(message)
    unknown = UbError(f"unknown error code {code}: {message}")
    unknown.code = code
    return unknown


def ensure(rc: int, message: str) -> int:
    """Returns `rc` when it is not negative; raises the matching `UbError` otherwise."""
    if rc < 0:
        raise error_for(rc, message)
    return rc
