"""Membership at run time and automatic routes from Python (the same C router, through cffi): in-process
nodes over memlinks on an injected clock."""

from __future__ import annotations

import math

import pytest

from binding_testutil import FakeClock as Clock
from binding_testutil import Generated, run_nodes
from uavbus import MemLink, Node
from uavbus._bindings.ub_error import InvalidArgumentError, NotFoundError


def run(nodes: list[Node], clock: Clock, ms: int) -> None:
    run_nodes(nodes, clock, ms, step=2)


def vehicle(cat, clock: Clock, name: str, links: int) -> Node:
    n = Node(cat, node=name, clock=clock)
    n.add_entity(name, local=True)
    for i in range(links):
        n.add_link(name, i, f"{name}L{i}")
    return n


@pytest.fixture()
def line(flightsw: Generated):
    """u0 - u1 - u2 - u3, each told only about its own links."""
    clock = Clock()
    nodes = [vehicle(flightsw.catalogue, clock, f"u{i}", 2) for i in range(4)]
    links = [MemLink(nodes[i], f"u{i}L1", nodes[i + 1], f"u{i + 1}L0", seed=i + 1) for i in range(3)]
    yield nodes, links, clock
    for n in nodes:
        n.close()


def test_routes_build_themselves_and_carry_data(line) -> None:
    nodes, links, clock = line
    for n in nodes:
        n.routing.enable(hello_ms=100)
    run(nodes, clock, 400)
    r = nodes[0].routing.table()
    assert r["u3"]["reachable"] and r["u3"]["next_hop"] == "u1" and r["u3"]["link"] == "u0L1"
    assert r["u3"]["metric"] == 3 * 256 and r["u3"]["learned"] and not r["u3"]["pinned"]
    assert nodes[0].mask("u0", "u3") == 0b10
    # A subscription across three hops, set up by name only: nobody was told about anybody.
    nodes[3].bind("gpsOut").latitudeDeg = 32.5
    got = []
    nodes[0].on_data(got.append)
    nodes[0].subscribe("u0", "gpsOut", source="u3", period_ms=50)
    run(nodes, clock, 500)
    assert len(got) >= 6 and got[-1].source == "u3" and got[-1].value["latitudeDeg"] == 32.5
    assert got[-1].hops == 3  # from the hop limit on arrival
    links_info = nodes[1].routing.links()
    assert links_info["u1L0"]["neighbour"] == "u0" and links_info["u1L1"]["neighbour"] == "u2"
    assert links_info["u1L0"]["cost"] == 256 and links_info["u1L0"]["frames_out"] >= 5
    assert nodes[1].routing.counters()["learned"] == 3


def test_max_dests_bounds_what_one_neighbour_teaches(line) -> None:
    """Issue 23 item 6: u1 advertises three destinations (u1, u2, u3) to u0, whose bound is 2: the third gets no
    route and is not learned, counted on the engine and on the link."""
    nodes, links, clock = line
    with pytest.raises(InvalidArgumentError):
        nodes[0].routing.enable(hello_ms=100, max_dests=10_000)
    nodes[0].routing.enable(hello_ms=100, max_dests=2)
    for n in nodes[1:]:
        n.routing.enable(hello_ms=100)
    run(nodes, clock, 600)
    reachable = sorted(d for d, r in nodes[0].routing.table().items() if r["reachable"] and not r["local"])
    assert len(reachable) == 2 and "u1" in reachable  # the neighbour itself came first
    c = nodes[0].routing.counters()
    assert c["neighbour_limit"] > 0 and c["learn_full"] == 0
    assert nodes[0].routing.links()["u0L1"]["over_limit_in"] == c["neighbour_limit"]
    assert nodes[1].routing.counters()["neighbour_limit"] == 0  # the default bound (12) holds a line of four


def test_link_failure_reroutes_and_manual_mask_pins(flightsw: Generated) -> None:
    clock = Clock()
    a, b, c = (vehicle(flightsw.catalogue, clock, n, 3) for n in ("ra", "rb", "rc"))
    ab = MemLink(a, "raL0", b, "rbL0", seed=1)
    MemLink(b, "rbL1", c, "rcL0", seed=2)
    MemLink(a, "raL1", c, "rcL1", seed=3)
    nodes = [a, b, c]
    for n in nodes:
        n.routing.enable(hello_ms=100, parallel="best")
    run(nodes, clock, 400)
    assert a.routing.table()["rb"]["next_hop"] == "rb"
    ab.set_faults({"loss_ppm": 1_000_000})
    run(nodes, clock, 400)  # down after ~2.5 hellos, then via rc
    assert a.routing.table()["rb"]["next_hop"] == "rc" and a.routing.table()["rb"]["metric"] == 512
    # A hand-set mask pins the entry: routing leaves it; 0 unpins.
    a.set_mask("ra", "rb", "0x00000001")
    assert a.mask_pinned("ra", "rb") and a.routing.table()["rb"]["pinned"]
    run(nodes, clock, 200)
    assert a.mask("ra", "rb") == 0b001
    a.set_mask("ra", "rb", 0)
    run(nodes, clock, 200)
    assert not a.mask_pinned("ra", "rb") and a.mask("ra", "rb") == 0b010
    a.routing.disable()
    assert a.mask("ra", "rb") == 0
    with pytest.raises(InvalidArgumentError):
        a.routing.table()
    for n in nodes:
        n.close()


def test_remove_entity_and_link_at_run_time(line) -> None:
    nodes, links, clock = line
    u0, u1 = nodes[0], nodes[1]
    u0.add_entity("u1")
    u0.set_mask("u0", "u1", 0b10)
    u1.add_entity("u0")
    u1.set_mask("u1", "u0", 0b01)
    u1.bind("gpsOut")
    u0.subscribe("u0", "gpsOut", source="u1", period_ms=20)
    run([u0, u1], clock, 200)
    assert u0.counters()["delivered"] > 5
    u0.remove_entity("u1")
    c = u0.counters()
    assert c["entities_removed"] == 1 and c["rows_stopped"] == 1 and c["dedup_cleared"] == 1
    assert "u1" not in [e["name"] for e in u0.entities()]
    with pytest.raises(NotFoundError):
        u0.mask("u0", "u1")
    with pytest.raises(InvalidArgumentError):
        u0.remove_entity("u0")  # local entities stay
    # The link: its memlink is disconnected first, then the slot goes; the name is free again.
    u0.remove_link("u0L1")
    assert links[0].pending() == 0 and "u0L1" not in u0.entities()[0]["links"]
    assert u0.counters()["links_removed"] == 1
    u0.add_link("u0", 1, "u0L1")
    with pytest.raises(NotFoundError):
        u0.remove_link("nolink")


def test_membership_over_the_bus(line) -> None:
    nodes, links, clock = line
    for n in nodes:
        n.routing.enable(hello_ms=100)
    run(nodes, clock, 400)
    m = nodes[0].membership(retry_ms=50, max_retries=10)
    # The announcement three hops away, then a pinned mask, then the removal.
    rows = m.announce("ghost9", ["u3", "u2"])
    run(nodes, clock, 100)
    assert [m.status(r)["status"] for r in rows] == ["done", "done"]
    assert m.status(rows[0])["changed"] and "ghost9" in [e["name"] for e in nodes[3].entities()]
    row = m.request("set_mask", "u3", "ghost9", mask="0x00000001")
    run(nodes, clock, 100)
    assert m.status(row)["status"] == "done" and nodes[3].mask_pinned("u3", "ghost9")
    row = m.request("remove_entity", "u3", "ghost9")
    run(nodes, clock, 100)
    assert m.status(row)["changed"] and "ghost9" not in [e["name"] for e in nodes[3].entities()]
    # Refusals come back with their reason: a node's own entity, a link op without a link handler.
    row = m.request("remove_entity", "u3", "u3")
    row2 = m.request("add_link", "u3", link_index=5, link_name="extra", port_spec="udp:bind=127.0.0.1:0,peer=127.0.0.1:9")
    run(nodes, clock, 100)
    assert m.status(row)["status"] == "failed" and m.status(row)["reason"] == "invalid"
    assert m.status(row2)["reason"] == "unsupported"
    assert nodes[3].counters()["membership_refused"] == 2
    with pytest.raises(InvalidArgumentError):
        m.request("teleport", "u3", "u1")


def test_python_vehicle_writes_the_flight_model(flightsw: Generated) -> None:
    from uavbus.sim.flight import FlightModel, VehicleDirectories

    n = vehicle(flightsw.catalogue, Clock(), "pv", 0)
    dirs = VehicleDirectories(n, FlightModel("orbit:r=150,v=12,n=300"))
    s = dirs.update(12.5, 0.02)
    gps, imu, nav = (n.directory(x).to_dict() for x in ("gpsOut", "imuOut", "navFilterState"))
    assert gps["latitudeDeg"] == s.lat_deg and gps["longitudeDeg"] == s.lon_deg and gps["solutionCount"] == 1
    assert gps["velocityNed"]["x"] == pytest.approx(s.vel_ned[0], rel=1e-6)  # float32 on the wire
    assert (imu["p"], imu["q"], imu["r"]) == s.rates and imu["specificForce"]["y"] == s.specific_force[1]
    assert imu["deltaAngle"]["z"] == pytest.approx(s.rates[2] * 0.02)
    assert nav["positionNed"] == {"x": s.north_m, "y": s.east_m, "z": -s.up_m} and nav["aligned"] == 1
    assert math.hypot(s.north_m - 300, s.east_m) == pytest.approx(150.0)
    n.close()
