"""The protocol of the uavbus programs, as the supervisor reads it: JSON lines on stdout, commands on stdin.

`uavbus_node` and `uavbus_mavbridge` speak it through one program shell (runtime_c/app/ub_app.h); it is
written down once, in ``schemas/program-events.schema.json`` (shipped as package data), and explained in
docs/program-protocol.md. This module is how the Python side uses that file: the event names the
supervisor waits for (`READY`, `STATS`, ...) are looked up in it at import, so a name the programs no
longer emit fails here, at import, rather than as a wait that times out; `events()` and `commands()` say
what one program emits and takes; `event_schema()` is the JSON Schema one program's lines satisfy (the
tests validate real output with it; the supervisor itself needs no validator).

tests/unit/test_program_protocol_schema.py checks the file against the C sources (every event and command they
name, no other), tests/system/test_program_protocol.py the real programs' lines against the schema.
"""

from __future__ import annotations

import json
from functools import cache
from typing import Any

from uavbus._paths import SCHEMAS_DIR

__all__ = ["SCHEMA_PATH", "PROGRAMS", "NODE", "MAVBRIDGE", "READY", "STATS", "ERROR", "WARNING", "REBOUND", "KEY",
           "DUMP", "FLOWS", "ROUTES", "AUTOPILOT", "events", "commands", "event_schema", "schema"]

SCHEMA_PATH = SCHEMAS_DIR / "program-events.schema.json"
NODE = "uavbus_node"
MAVBRIDGE = "uavbus_mavbridge"


@cache
def schema() -> dict[str, Any]:
    """The whole schema document."""
    return json.loads(SCHEMA_PATH.read_text())


PROGRAMS: tuple[str, ...] = tuple(schema()["x-programs"])


def events(program: str = NODE) -> tuple[str, ...]:
    """The events `program` writes on stdout."""
    return tuple(_program(program)["events"])


def commands(program: str = NODE) -> tuple[str, ...]:
    """The first words of the stdin commands `program` takes."""
    return tuple(_program(program)["commands"])


def event_schema(program: str = NODE) -> dict[str, Any]:
    """A JSON Schema every stdout line of `program` satisfies: one of its events, each as its $defs entry."""
    doc = schema()
    return {"$schema": doc["$schema"], "$defs": doc["$defs"],
            "oneOf": [{"$ref": f"#/$defs/{ref}"} for ref in _program(program)["events"].values()]}


def _program(program: str) -> dict[str, Any]:
    try:
        return schema()["x-programs"][program]
    except KeyError:
        raise ValueError(f"{program!r}: not a program of {SCHEMA_PATH.name} (known: {', '.join(PROGRAMS)})") from None


def _event(name: str, *programs: str) -> str:
    for p in programs or (NODE,):
        if name not in events(p):
            raise ImportError(f"{SCHEMA_PATH}: {p} has no '{name}' event, which uavbus.sim relies on")
    return name


# The events the supervisor (uavbus.sim.process, uavbus.sim.hitl, the tests) waits for.
READY = _event("ready", NODE, MAVBRIDGE)
STATS = _event("stats", NODE, MAVBRIDGE)
ERROR = _event("error", NODE, MAVBRIDGE)
WARNING = _event("warning", NODE, MAVBRIDGE)
REBOUND = _event("rebound")
KEY = _event("key")
DUMP = _event("dump")
FLOWS = _event("flows")
ROUTES = _event("routes")
AUTOPILOT = _event("autopilot", MAVBRIDGE)
