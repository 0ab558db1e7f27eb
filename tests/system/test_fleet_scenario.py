"""Issue 12 acceptance: a fleet scenario with automatic routes, six C vehicle processes, a Python vehicle
and a Python ground station (examples/scenarios/fleet6.yaml): a vehicle joins (its links are created on the
running peers, the ground station announces it), one flies out of radio range and back, a relay is killed
and restarted, a link fails and comes back. Every flow recovers; the report says how fast.

One run (~28 s) serves all the checks below. The bounds are deliberately wider than what an idle machine
shows (reconvergence ~0.8 s = 4 hello intervals at 200 ms): the machine is shared, and the measured
figures are in the summary, not asserted to the millisecond.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from uavbus.sim.build import REPO
from uavbus.sim.fleet import FleetRun
from uavbus.sim.fleet_report import radio_share, window_delivery
from uavbus.sim.run_scenario import render
from uavbus.sim.scenario import load_scenario

pytestmark = pytest.mark.timeout(180)

SCENARIO = REPO / "examples" / "scenarios" / "fleet6.yaml"


@pytest.fixture(scope="module")
def fleet(program: Path, tmp_path_factory: pytest.TempPathFactory):
    out = tmp_path_factory.mktemp("fleet6")
    run = FleetRun(load_scenario(SCENARIO), out, program=program, log=lambda s: None)
    summary = run.run()
    return run, summary, out


def test_every_event_happened_and_every_flow_recovered(fleet) -> None:
    run, summary, _ = fleet
    events = summary["events"]
    kinds = {e["event"] for e in events}
    assert {"add", "kill", "restart", "fail_link", "restore_link", "out_of_range", "in_range"} <= kinds, kinds
    for e in events:
        assert e["reconverged_s"] is not None, f"{e['text']}: {e['unrecovered']} never delivered again"
        assert e["reconverged_s"] <= 2.5, f"{e['text']}: reconverged in {e['reconverged_s']} s"
    # The disruptive events did cut flows that had another path, and routing found it.
    kill = next(e for e in events if e["event"] == "kill")
    # gps3 and gps5 are relayed through uav1 and rerouted through uav7. A relay's link in doubt (docs/routing.md,
    # "Transport evidence": a gap in uav1's fast hellos) shares the data with every feasible successor within a
    # fraction of a second, so a flow may show no silence at all and is then not counted as affected. What was
    # affected recovered (above) and is among the flows through uav1: the kill disturbed nothing else.
    assert set(kill["affected"]) <= {"gps3", "gps5"}, kill
    fail = next(e for e in events if e["event"] == "fail_link")
    # imu5to2 went uav5 -> uav3 -> uav2 and is rerouted through uav4 and uav1. uav3's link in doubt hands the data
    # to its other neighbours, and one that routed through uav3 sends it on over its bounce mask (docs/routing.md,
    # "Transport evidence"), often before the flow falls silent: then it is not `affected` (no silence longer than
    # its gap, 300 ms, where a hello timeout alone leaves 400-600 ms: 3 missed hellos of 200 ms after the last one
    # heard), and it must still have carried most of its rate: at least what 600 ms of silence in these 2 s would
    # leave (0.7 of what the radio lets through). 0.85 was tried: a clean-clone run read 0.8 (16 of 20 frames,
    # no silence over 300 ms), i.e. scattered losses while the link was in doubt, not a timeout.
    kept = window_delivery(run.flows["imu5to2"], fail["t"], fail["t"] + 2.0)
    share = radio_share(run, run.flows["imu5to2"].hops)
    assert "imu5to2" in fail["affected"] or (kept is not None and kept >= 0.7 * share), (fail, kept, share)
    back = [e for e in events if e["event"] == "in_range" and "uav6" in e["target"]]
    assert back and any("nav6" in e["affected"] for e in back), back  # uav6 out of everyone's range, and back
    assert summary["processes"]["uav1"]["starts"] == 2 and summary["processes"]["uav1"]["running"]


def test_flows_deliver_where_a_path_exists(fleet) -> None:
    _, summary, _ = fleet
    flows = {f["name"]: f for f in summary["flows"]}
    # 85 % of what the radio's 2 % loss a hop leaves ((1 - loss)^hops: telemetry is not resent), so the bound is
    # on routing and not on the radio's dice (docs/scenarios.md).
    for f in flows.values():
        assert f["delivery_ratio_connected"] is not None and f["delivery_ratio_connected"] >= 0.85 * f["radio_share"], f
    # Multi-hop through relays nobody was told about (learned), C and Python alike.
    assert flows["gps3"]["hops"] >= 2 and flows["gps5"]["hops"] >= 3 and flows["imu5to2"]["hops"] >= 2
    # uav6 was out of everyone's range for seconds: delivery over the whole run is lower than where a path exists.
    assert flows["nav6"]["delivery_ratio"] < flows["nav6"]["delivery_ratio_connected"]


def test_routing_frame_budget_in_steady_state(fleet) -> None:
    _, summary, _ = fleet
    r = summary["routing_frames_per_link_s"]
    # One frame per link per hello interval; a 2 s sampling window holds 10 +- 1 of them.
    assert r["steady_per_hello_max"] is not None and r["steady_per_hello_max"] <= 1.1, r
    assert len(r["per_link"]) == 2 * len(load_scenario(SCENARIO).links)


def test_the_joined_vehicle_was_linked_and_announced(fleet) -> None:
    run, summary, _ = fleet
    assert summary["announcements"], "the ground station announced nobody"
    assert all(a["status"] == "done" and a["subject"] == "uav7" for a in summary["announcements"]), \
        summary["announcements"]
    # Its peers got their end of the links at run time, through uavbus_node's stdin membership commands.
    answers = [e for e in run.members["uav2"].proc.events if e.get("event") == "membership"]
    assert any(e["command"] == "link add" and e["ok"] and e["changed"] for e in answers), answers
    gps7 = next(f for f in summary["flows"] if f["name"] == "gps7")
    assert gps7["delivered"] > 50


def test_report_files(fleet) -> None:
    _, summary, out = fleet
    assert json.loads((out / "summary.json").read_text())["scenario"] == "fleet6"
    assert (out / "timeline.png").stat().st_size > 10000
    assert (out / "configs" / "uav1.json").exists()
    text = render(summary)
    assert "kill uav1" in text and "gps3" in text
