"""External scenario members and ground-station kills in scenario files (issue 25, items 3 and 5): what the
loader accepts, and every refusal at its line with what to do."""

from __future__ import annotations

import pytest

from uavbus.sim.scenario import ScenarioError, parse_scenario, peer_port

BASE = """\
duration_s: 10
ground_stations:
  - {name: gcs1, run: python}
vehicles:
  - {name: uav1, motion: "orbit:r=100,v=10"}
  - {name: fcs20, run: external, port: "PORT", routing: false}
links:
  - {between: [gcs1, uav1]}
  - {between: [gcs1, fcs20], model: wire}
flows:
  - {name: imu, content: imuOut, source: fcs20, destination: gcs1, period_ms: 20}
events:
  - {t: 3, kill: gcs1}
  - {t: 4, restart: gcs1}
"""


def load(port: str = "serial:device=/dev/pts/7", **replace: str) -> object:
    text = BASE.replace("PORT", port)
    for old, new in replace.items():
        text = text.replace(old.replace("_", " "), new)
    return parse_scenario(text, "ext.yaml")


def test_an_external_member_and_a_ground_station_kill_load() -> None:
    sc = load()
    fcs = sc.station("fcs20")
    assert fcs.external and not fcs.routing and fcs.port == "serial:device=/dev/pts/7"
    (link,) = [x for x in sc.links if "fcs20" in (x.a, x.b)]
    assert link.transport == "serial"   # from the member's port
    assert [e.kind for e in sc.events] == ["kill", "restart"] and sc.events[0].target == ("gcs1",)


@pytest.mark.parametrize("port, launcher_end", [
    ("serial:device=/dev/pts/7", "serial:device=/dev/pts/7,baud=115200"),
    ("serial:device=/dev/ttyUSB0,baud=57600", "serial:device=/dev/ttyUSB0,baud=57600"),
    ("tcp:listen=127.0.0.1:5001", "tcp:connect=127.0.0.1:5001"),
    ("tcp:connect=10.0.0.2:5001", "tcp:listen=10.0.0.2:5001"),
    ("udp:bind=127.0.0.1:6001,peer=127.0.0.1:6002", "udp:bind=127.0.0.1:6002,peer=127.0.0.1:6001"),
])
def test_the_launcher_faces_the_members_own_port(port: str, launcher_end: str) -> None:
    assert peer_port(port) == launcher_end


@pytest.mark.parametrize("text, line, message", [
    (BASE.replace(', port: "PORT"', ""), 6, "run: external needs 'port'"),
    (BASE.replace("PORT", "udp:bind=1.2.3.4:5"), 6, "is not a port the launcher can face"),
    (BASE.replace("PORT", "serial:device=/dev/pts/7").replace("{t: 3, kill: gcs1}", "{t: 3, kill: fcs20}")
     .replace("  - {t: 4, restart: gcs1}\n", ""), 13, "'fcs20' is external (not started by the launcher)"),
    (BASE.replace("PORT", "serial:device=/dev/pts/7").replace("destination: gcs1", "destination: uav1"), 11,
     "reached only through gcs1"),
    (BASE.replace("PORT", "serial:device=/dev/pts/7").replace("{between: [gcs1, uav1]}",
                                                              "{between: [uav1, fcs20]}"), 9, "one link to it"),
    (BASE.replace("PORT", "serial:device=/dev/pts/7").replace("model: wire}", "model: wire, transport: udp}"), 9,
     "is external on a serial port"),
    (BASE.replace(', port: "PORT", routing: false', ", routing: false").replace("run: external", "run: process"),
     6, "only for run: external"),
])
def test_refusals_name_the_line(text: str, line: int, message: str) -> None:
    with pytest.raises(ScenarioError) as e:
        parse_scenario(text, "ext.yaml")
    assert str(e.value).startswith(f"ext.yaml:{line}: ") and message in str(e.value), str(e.value)
