"""Scenario files (docs/scenarios.md): the shipped examples validate, and bad files fail with file:line and
what to do; the flight model Python samples is the C one (ub_motion), so C and Python vehicles agree."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from uavbus.cli import main as cli_main
from uavbus.sim.flight import FlightModel
from uavbus.sim.scenario import ScenarioError, load_scenario, parse_scenario

REPO = Path(__file__).resolve().parents[2]

GOOD = """\
duration_s: 10
routing: {hello_ms: 100, parallel: best}
radio: {range_m: 500, loss: 0.1}
ground_stations:
  - {name: gcs1, position: {n: 0, e: 0}}
vehicles:
  - {name: a, motion: "orbit:r=50,v=5"}
  - {name: b, run: python, motion: "waypoints:v=10,pts=0/0;100/0"}
  - {name: c, motion: "static:n=5"}
links:
  - {between: [gcs1, a]}
  - {between: [a, b], transport: tcp, model: wire}
  - {mesh: [b, c], transport: serial, loss: 0.2}
flows:
  - {content: gpsOut, source: a, destination: gcs1, period_ms: 100}
events:
  - {t: 2, kill: a}
  - {t: 3, restart: a}
  - {t: 1, add: c}
  - {t: 4, fail_link: [a, b]}
"""


def test_examples_validate() -> None:
    for path in sorted((REPO / "examples" / "scenarios").glob("*.yaml")):
        sc = load_scenario(path)
        assert sc.vehicles and sc.duration_s > 0, path


def test_a_good_file_becomes_the_model() -> None:
    sc = parse_scenario(GOOD, "good.yaml")
    assert [s.name for s in sc.stations] == ["gcs1", "a", "b", "c"]
    assert sc.station("gcs1").run == "python" and sc.station("a").run == "process"
    assert sc.station("gcs1").motion == "static:n=0,e=0,alt=0"
    assert sc.routing.route_arg() == "hello=100,dead=2,parallel=best"
    radio, wire, mesh = sc.links
    assert radio.range_m == 500 and radio.loss == 0.1 and radio.transport == "udp"
    assert math.isinf(wire.range_m) and wire.transport == "tcp"
    assert (mesh.a, mesh.b, mesh.loss, mesh.transport) == ("b", "c", 0.2, "serial")
    assert [e.kind for e in sc.events] == ["add", "kill", "restart", "fail_link"]  # sorted by time
    assert sc.joins() == {"c": 1.0}
    assert sc.flows[0].name == "gpsOut:a>gcs1" and sc.flows[0].gap_ms == 300


def test_bandwidth_and_encoding_of_a_radio_link() -> None:
    text = GOOD.replace("radio: {range_m: 500, loss: 0.1}", "radio: {range_m: 500, loss: 0.1, bandwidth_bps: 46080}")
    text = text.replace("- {between: [gcs1, a]}", "- {between: [gcs1, a], transport: serial, encoding: compact}")
    radio, wire, mesh = parse_scenario(text, "radio.yaml").links
    assert (radio.bandwidth_bps, radio.encoding, radio.transport) == (46080, "compact", "serial")
    assert (wire.bandwidth_bps, wire.encoding) == (46080, "full")  # the radio default applies to every link
    with pytest.raises(ScenarioError, match="memory links have neither"):
        parse_scenario(text.replace("transport: tcp, model: wire", "transport: memory, model: wire")
                       .replace("name: a, motion", "name: a, run: python, motion"), "m.yaml")


@pytest.mark.parametrize("old, new, line, message", [
    ("duration_s: 10\n", "seed: 3\n", 1, "'duration_s' is required"),
    ("duration_s: 10", "duration_s: ten", 1, "duration_s: 'ten' is not a number"),
    ("name: b, run: python", "name: a, run: python", 8, "'a' is already used on line 7"),
    ('"static:n=5"', '"static:n=5,q=1"', 9, "c.motion: motion: 'q=1': unknown key"),
    ("[gcs1, a]", "[gcs1, zz]", 11, "'zz' is not a vehicle or ground station of this scenario (known:"),
    ("transport: tcp, model: wire", "transport: memory", 12, "transport memory joins two run: python entities"),
    ("loss: 0.1}", "loss: 0.1, bandwidth_bps: 9}", 3, "radio.bandwidth_bps: 9 is out of range (80 .. 8000000000)"),
    ("source: a, destination: gcs1", "source: gcs1, destination: a", 15, "'gcs1' is a ground station"),
    ("period_ms: 100", "period_ms: 0", 15, "flow.period_ms: 0 is out of range"),
    ("{t: 2, kill: a}", "{t: 3.5, kill: a}", 18, "restart a: it is running at t=3; kill it first"),
    ("{t: 2, kill: a}", "{t: 2, kill: b}", 17, "kill: 'b' runs in the launcher (run: python)"),
    ("fail_link: [a, b]", "fail_link: [a, c]", 20, "no link between a and c"),
    ("hello_ms: 100", "helo_ms: 100", 2, "unknown key 'helo_ms'"),
    ("position: {n: 0, e: 0}}", 'position: {n: 0, e: 0}, motion: "static"}', 5, "give motion or position, not both"),
    (', motion: "waypoints:v=10,pts=0/0;100/0"', "", 8, "vehicle b: 'motion' is required"),
    ("{t: 1, add: c}", "{t: 1, add: gcs1}", 19, "add: only vehicles join during a run"),
    ("period_ms: 100}", "period_ms: 100, admin: a}", 15, "flow.admin: 'a' must be a ground station with run: python"),
    ("period_ms: 100}", "period_ms: 100, kind: publication}", 15, "flow.kind: only with 'admin'"),
    ("period_ms: 100}", "period_ms: 100, admin: gcs1, kind: push}", 15, "flow.kind: 'push' is not one of"),
    ("{t: 4, fail_link: [a, b]}", "{t: 4, move: gcs1}", 20, "move: give the new motion"),
    ("{t: 4, fail_link: [a, b]}", '{t: 4, move: a, motion: "static:n=9"}', 20, "move: 'a' is a vehicle"),
    ("{t: 4, fail_link: [a, b]}", '{t: 4, kill: a, motion: "static:n=9"}', 20, "event.motion: only with move"),
    ("duration_s: 10\n", "duration_s: 10\nsigned: maybe\n", 2, "signed: 'maybe' is not one of true, false"),
])
def test_errors_name_the_line(old: str, new: str, line: int, message: str) -> None:
    assert old in GOOD
    with pytest.raises(ScenarioError) as exc:
        parse_scenario(GOOD.replace(old, new, 1), "bad.yaml")
    assert str(exc.value).startswith(f"bad.yaml:{line}: "), str(exc.value)
    assert message in str(exc.value), str(exc.value)


def test_administered_flows_moves_and_signing() -> None:
    text = GOOD.replace("period_ms: 100}", "period_ms: 100, admin: gcs1, kind: publication}").replace(
        "{t: 4, fail_link: [a, b]}", '{t: 4, move: gcs1, motion: "waypoints:v=50,loop=0,pts=0/0;-900/0"}')
    sc = parse_scenario("signed: true\n" + text, "good.yaml")
    f = sc.flows[0]
    assert (f.admin, f.kind) == ("gcs1", "publication") and sc.admin_flows == [f]
    move = sc.events[-1]
    assert move.kind == "move" and move.target == ("gcs1",) and move.motion.startswith("waypoints:v=50")
    assert sc.signed and not parse_scenario(GOOD, "good.yaml").signed
    assert sc.signed_mode == "identity"   # `true`: each station its own identity; `group`: the fleet key alone
    group = parse_scenario("signed: group\n" + text, "good.yaml")
    assert group.signed and group.signed_mode == "group"
    # A flow listed twice (even under another name) would be two administrators of one flow in one table.
    twice = GOOD.replace("flows:\n", "flows:\n  - {name: x, content: gpsOut, source: a, destination: gcs1, "
                                      "period_ms: 200}\n")
    with pytest.raises(ScenarioError, match="gpsOut from a to gcs1 is listed twice"):
        parse_scenario(twice, "bad.yaml")


def test_yaml_syntax_and_limits() -> None:
    with pytest.raises(ScenarioError, match=r"^bad.yaml:[34]: not valid YAML"):
        parse_scenario("duration_s: 5\nvehicles:\n  - {name: [\n", "bad.yaml")
    with pytest.raises(ScenarioError, match=r"^bad.yaml:1: empty file"):
        parse_scenario("", "bad.yaml")
    many = "duration_s: 5\nvehicles:\n" + "".join(f"  - {{name: v{i}, motion: orbit}}\n" for i in range(10))
    with pytest.raises(ScenarioError, match=r"'v0' has more than 8 links"):
        parse_scenario(many + "links:\n  - {mesh: all}\n", "bad.yaml")


def test_cli_check(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    good = tmp_path / "good.yaml"
    good.write_text(GOOD)
    assert cli_main(["sim", str(good), "--check"]) == 0
    assert "ok (3 vehicles, 1 ground stations" in capsys.readouterr().out
    bad = tmp_path / "bad.yaml"
    bad.write_text(GOOD.replace("period_ms: 100", "period_ms: 0"))
    assert cli_main(["sim", str(bad), "--check"]) == 2
    assert f"{bad}:15: flow.period_ms: 0 is out of range" in capsys.readouterr().err


def test_python_samples_the_c_flight_model() -> None:
    # The default orbit of uavbus_node (node_motion.c maps the same ub_motion samples into its structs).
    s = FlightModel("orbit").sample(0.0)
    assert (s.north_m, s.east_m, s.vel_ned[1]) == pytest.approx((200.0, 0.0, 10.0))
    assert s.rates[2] == pytest.approx(0.05) and s.specific_force[2] == pytest.approx(-9.80665)
    path = FlightModel("waypoints:v=10,pts=0/0;0/300")
    assert path.sample(15.0).east_m == pytest.approx(150.0)
    assert path.sample(15.0).distance(FlightModel("static:n=40,e=150").sample(0.0)) == pytest.approx(40.0)
    from uavbus._bindings.ub_error import InvalidArgumentError

    with pytest.raises(InvalidArgumentError, match="motion: 'orbit:r=-1': r must be > 0 m"):
        FlightModel("orbit:r=-1")
