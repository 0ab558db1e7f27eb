"""A scenario member the launcher did not start (issue 25, item 3): a `uavbus_node` vehicle started here, outside
`uavbus sim`, with automatic routes, on a UDP port the scenario names. The launcher faces that port (UDP
mirrored), learns routes to it through a simulated relay like to any member, and reports its flow, which
crosses two hops (ext1 -> uav1 -> gcs1), through a cut of its link (fail_link / restore_link). The member is
not stopped by the run: it is still running after it.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from uavbus.sim.fleet import FleetRun
from uavbus.sim.portalloc import PortAllocator
from uavbus.sim.process import NodeProcess
from uavbus.sim.scenario import parse_scenario

pytestmark = pytest.mark.timeout(120)

SCENARIO = """\
name: ext-node
duration_s: 9
routing: {{hello_ms: 200, dead_misses: 3}}
ground_stations:
  - {{name: gcs1, run: python}}
vehicles:
  - {{name: ext1, run: external, port: "udp:bind={mine},peer={theirs}"}}
  - {{name: uav1, motion: "orbit:r=100,v=10"}}
links:
  - {{between: [uav1, ext1], model: wire}}
  - {{between: [gcs1, uav1], model: wire}}
flows:
  - {{name: gpsx, content: gpsOut, source: ext1, destination: gcs1, period_ms: 100}}
events:
  - {{t: 3, fail_link: [uav1, ext1]}}
  - {{t: 5, restore_link: [uav1, ext1]}}
"""


def test_an_external_node_with_routes_in_a_scenario(program: Path, tmp_path: Path) -> None:
    alloc = PortAllocator()
    mine, theirs = alloc.addr(), alloc.addr()
    cfg = tmp_path / "ext1.json"
    cfg.write_text(json.dumps({"system": "elsewhere", "nodes": {"ext1": ["ext1"]},
                               "entities": [{"name": "ext1", "links": ["radio"]}, {"name": "gcs1"}]}))
    ext = NodeProcess([str(program), "--config", str(cfg), "--node", "ext1",
                       "--port", f"radio=udp:bind={mine},peer={theirs}", "--route", "hello=200,dead=3",
                       "--produce", "ext1", "--motion", "orbit:r=50,v=5"], "ext1")
    ext.start()
    try:
        ext.wait_ready(8.0)
        sc = parse_scenario(SCENARIO.format(mine=mine, theirs=theirs), "ext-node.yaml")
        summary = FleetRun(sc, tmp_path / "out", program=program, log=lambda s: None).run()
        assert ext.running, "the launcher stopped a member it did not start"
    finally:
        ext.stop()
    (flow,) = summary["flows"]
    assert flow["external"] == ["ext1"] and summary["external"]["ext1"]["routing"] is True
    assert flow["hops"] == 2, flow                                  # learned: ext1 -> uav1 -> gcs1
    assert flow["delivered"] > 20 and flow["status"] == "flowing", flow
    # Its link cut is an event like any other: the outage is the cut's (no path meanwhile), and the restore
    # that gave the path back is charged the time to recover.
    cut = [o for o in flow["outages_explained"] if o["cause"].startswith("no path since fail_link uav1 ext1")]
    assert len(cut) == 1 and cut[0]["to"] >= 5.0 and not cut[0]["open"], flow["outages_explained"]
    restore = next(e for e in summary["events"] if e["event"] == "restore_link")
    assert "gpsx" in restore["affected"] and restore["reconverged_s"] is not None, restore
    assert "ext1" not in summary["processes"], summary["processes"]  # never started by the launcher
