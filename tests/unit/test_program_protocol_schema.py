"""One protocol, written once: schemas/program-events.schema.json against the C programs that speak it and
the Python supervisor that reads it (docs/program-protocol.md). No process runs here; the real programs'
lines are checked against the same file in tests/system/test_program_protocol.py."""

from __future__ import annotations

import json
import re
from pathlib import Path

import jsonschema
import pytest

from uavbus.sim import protocol

REPO = Path(__file__).resolve().parents[2]
SHELL = [REPO / "runtime_c" / "app" / "ub_app.c"]
SOURCES = {
    protocol.NODE: SHELL + sorted((REPO / "programs" / "node").glob("*.c")),
    protocol.MAVBRIDGE: SHELL + [REPO / "bridges" / "mavlink" / "uavbus_mavbridge.c"],
}
# {"event":"NAME" as the C source spells it: {\"event\":\"NAME\"
C_EVENT = re.compile(r'\{\\"event\\":\\"([a-z_]+)\\"')
# a stdin command's first word, as the shell and the programs compare it
C_COMMAND = re.compile(r'strcmp\(verb, "([a-z_]+)"\)')


def c_names(program: str, pattern: re.Pattern[str]) -> set[str]:
    return {m for f in SOURCES[program] for m in pattern.findall(f.read_text())}


@pytest.mark.parametrize("program", protocol.PROGRAMS)
def test_the_schema_lists_exactly_the_events_the_c_program_writes(program: str) -> None:
    assert set(protocol.events(program)) == c_names(program, C_EVENT)


@pytest.mark.parametrize("program", protocol.PROGRAMS)
def test_the_schema_lists_exactly_the_commands_the_c_program_takes(program: str) -> None:
    assert set(protocol.commands(program)) == c_names(program, C_COMMAND)


def test_the_schema_is_a_valid_json_schema_with_a_definition_per_event() -> None:
    doc = protocol.schema()
    jsonschema.Draft202012Validator.check_schema(doc)
    for program in protocol.PROGRAMS:
        for name, ref in doc["x-programs"][program]["events"].items():
            assert doc["$defs"][ref]["properties"]["event"] == {"const": name}, (program, name)
        jsonschema.Draft202012Validator.check_schema(protocol.event_schema(program))
    # "text" is the supervisor's own pseudo-event for a line that is not JSON (uavbus.sim.process).
    assert all("text" not in protocol.events(p) for p in protocol.PROGRAMS)


def test_the_schema_refuses_what_a_supervisor_could_not_use() -> None:
    v = jsonschema.Draft202012Validator(protocol.event_schema(protocol.NODE))
    assert v.is_valid({"event": "error", "message": "x"})
    assert not v.is_valid({"event": "error"})                              # no message
    assert not v.is_valid({"event": "autopilot", "state": "lost", "sysid": 1, "compid": 1})  # the bridge's
    assert not v.is_valid({"event": "rebound", "port": "p", "transport": "udp", "spec": "s", "local_port": 1})


def python_sources() -> list[Path]:
    return sorted((REPO / "runtime_py" / "uavbus" / "sim").glob("*.py"))


def test_the_supervisor_waits_only_for_events_of_the_schema() -> None:
    """Event names the supervisor compares with, written out as strings, are the schema's (or its own
    "text"); the usual spelling is the constant of uavbus.sim.protocol, looked up in the schema at import."""
    known = set().union(*(protocol.events(p) for p in protocol.PROGRAMS)) | {"text"}
    literal = re.compile(r'get\("event"\)\s*(?:==|!=|in)\s*\(?"([a-z_]+)"')
    used = {name for f in python_sources() for name in literal.findall(f.read_text())}
    assert used <= known, used - known


def test_the_supervisor_sends_only_commands_the_node_takes() -> None:
    sent = re.compile(r'\.send\(f?"([a-z_]+)')
    words = {w for f in python_sources() for w in sent.findall(f.read_text())}
    assert words and words <= set(protocol.commands(protocol.NODE)), words - set(protocol.commands(protocol.NODE))


def doc_examples() -> list[tuple[str, dict]]:
    """The one-line JSON examples of docs/program-protocol.md, with the program whose section holds them."""
    out, program = [], protocol.NODE
    for line in (REPO / "docs" / "program-protocol.md").read_text().splitlines():
        if line.startswith("## ") and "uavbus_mavbridge" in line:
            program = protocol.MAVBRIDGE
        elif line.startswith("## ") and "uavbus_node" in line:
            program = protocol.NODE
        elif line.startswith('{"event"'):
            out.append((program, json.loads(line)))
    return out


def test_the_documented_examples_satisfy_the_schema() -> None:
    examples = doc_examples()
    assert {ev["event"] for _, ev in examples} >= {"ready", "stats", "error", "warning", "autopilot"}
    for program, ev in examples:
        errors = list(jsonschema.Draft202012Validator(protocol.event_schema(program)).iter_errors(ev))
        assert not errors, f"docs/program-protocol.md ({program}): {ev}: {errors[0].message}"
