"""Every exception uavbus raises on purpose, in one public place.

The C runtime's negative error codes become `UbError` subclasses, each also inheriting from the closest
builtin, so ``except ValueError`` and ``except uavbus.errors.ChecksumError`` both work::

    from uavbus.errors import ConfigError, UbError
    try:
        node = Node(cat, config="table2.json", node="gcs")
    except ConfigError as exc:          # one line: file:line: entity '...', field '...': what to do
        sys.exit(str(exc))

| exception | raised when |
|---|---|
| `UbError` | any C runtime function failed (`code`, `name`: the C error code and its name) |
| `ConfigError` | the C configuration loader refused a file (`path`, `line`) |
| `CatalogueError` | a catalogue document cannot be used |
| `EncodeError` | a value does not fit its field (the message names the field) |
| `LogFormatError` | a file is not a uavbus log, or its header is damaged |
"""

from __future__ import annotations

from uavbus._bindings.ub_error import (
    ChecksumError, ClosedError, ConfigError, ExistsError, FullError, InvalidArgumentError, IoError, LayoutError,
    NoAnswerError, NoRouteError, NoSpaceError, NotFoundError, RangeError, RefusedError, TruncatedError, UbError,
    WouldBlockError,
)
from uavbus.catalogue import CatalogueError, EncodeError
from uavbus.logfile import LogFormatError

__all__ = [
    "CatalogueError", "ChecksumError", "ClosedError", "ConfigError", "EncodeError", "ExistsError", "FullError",
    "InvalidArgumentError", "IoError", "LayoutError", "LogFormatError", "NoRouteError", "NoSpaceError",
    "NoAnswerError", "NotFoundError", "RangeError", "RefusedError", "TruncatedError", "UbError", "WouldBlockError",
]
