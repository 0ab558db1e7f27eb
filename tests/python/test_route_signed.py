"""Automatic routes with signing required (issue 12: "routing frames are signed like any other"): a line of
four nodes, each told only its own links, every one signing and refusing unsigned frames. Hellos and route
updates are ordinary frames to the node, so they are signed, verified and replay-checked; a new neighbour is
challenged before its hellos count, over the very link the hello came in on (no route back exists yet).
An unsigned node on a link is refused and never becomes a neighbour or a route."""

from __future__ import annotations

import json
from pathlib import Path

from binding_testutil import FakeClock, Generated, run_nodes
from uavbus import MemLink, Node
from uavbus.sim.secure import signed_config

HELLO_MS = 100


def node_config(tmp: Path, name: str, links: list[str], signed: bool) -> Path:
    doc = {"system": "line", "entities": [{"name": name, "links": links}], "nodes": {name: [name]}}
    plain = tmp / f"{name}.json"
    plain.write_text(json.dumps(doc))
    # One fleet key for everyone (keys_dir shared); counter files per entity under tmp/state.
    return signed_config(plain, tmp, keys_dir=tmp / "keys", name=f"{name}.signed.json") if signed else plain


def test_routes_converge_with_signing_required(flightsw: Generated, tmp_path: Path) -> None:
    clock = FakeClock()
    names = [f"u{i}" for i in range(4)]
    nodes = [Node(flightsw.catalogue, config=node_config(tmp_path, n, [f"{n}L0", f"{n}L1"], True), node=n,
                  clock=clock) for n in names]
    rogue = Node(flightsw.catalogue, config=node_config(tmp_path, "rogue", ["rL0"], False), node="rogue",
                 clock=clock)
    try:
        for i in range(3):
            MemLink(nodes[i], f"u{i}L1", nodes[i + 1], f"u{i + 1}L0", seed=i + 1)
        MemLink(rogue, "rL0", nodes[0], "u0L0", seed=9)   # an unsigned router next to u0
        for n in nodes + [rogue]:
            n.routing.enable(hello_ms=HELLO_MS)
        run_nodes(nodes + [rogue], clock, 6 * HELLO_MS, step=2)
        routes = nodes[0].routing.table()
        # Three hops learned from signed updates, within a few hello intervals (challenges included).
        assert routes["u3"]["reachable"] and routes["u3"]["next_hop"] == "u1", routes
        assert routes["u3"]["metric"] == 3 * 256 and routes["u3"]["learned"]
        assert nodes[3].routing.table()["u0"]["reachable"]
        for n in nodes:
            sec = n.security.status()
            assert sec is not None and sec["signed_out"] > 0 and sec["verified_in"] > 0
            assert sec["challenges_completed"] >= 1
            assert n.counters()["drops"]["bad_tag"] == 0
        # The routing frames themselves went out signed: every frame u1 sent was a signed one.
        assert nodes[1].routing.links()["u1L1"]["frames_out"] >= 5
        assert nodes[1].security.status()["signed_out"] >= nodes[1].routing.links()["u1L1"]["frames_out"]
        # The unsigned router is refused: dropped `unsigned`, never a neighbour, never a route.
        assert nodes[0].counters()["drops"]["unsigned"] > 0
        assert not nodes[0].routing.links()["u0L0"]["neighbour"]
        assert "rogue" not in nodes[0].routing.table() or not nodes[0].routing.table()["rogue"]["reachable"]
        # Data across three signed hops, set up by name only. End to end, u3 and u0 never met: each challenges
        # the other once (a request, then the data, wait one round trip), then the flow runs at its rate.
        nodes[3].bind("gpsOut").latitudeDeg = 32.5
        got = []
        nodes[0].on_data(got.append)
        nodes[0].subscribe("u0", "gpsOut", source="u3", period_ms=50)
        run_nodes(nodes + [rogue], clock, 1000, step=2)
        assert got and got[-1].hops == 3 and got[-1].value["latitudeDeg"] == 32.5
        before = len(got)
        run_nodes(nodes + [rogue], clock, 500, step=2)
        assert len(got) - before >= 9   # 20 Hz once verified
    finally:
        for n in nodes + [rogue]:
            n.close()
