"""Scenario reporting you can trust (issue 25, item 5), on a hand-built run: outages are charged to the event
that began them or gave the flow its path back, never to an unrelated event that happened during them; every
outage is listed with its cause; a flow whose source is gone for good is `stale`."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import pytest

from uavbus.sim.fleet import FlowTrack
from uavbus.sim.fleet_report import _reconvergence, _routing_rates, explained_outages, radio_share, source_gone
from uavbus.sim.scenario import FlowSpec, Station, load_scenario

PERIOD_MS = 100


def track(name: str, source: str, times: list[float]) -> FlowTrack:
    tr = FlowTrack(FlowSpec(name, "gpsOut", source, "gcs1", PERIOD_MS, 1))
    for t in times:
        tr.add(t)
        tr.times.append(t)
    tr.first, tr.last = (times[0], times[-1]) if times else (None, None)
    return tr


def steady(t0: float, t1: float) -> list[float]:
    return [round(t0 + k * PERIOD_MS / 1000.0, 3) for k in range(int((t1 - t0) * 1000 / PERIOD_MS) + 1)]


def event(t: float, kind: str, target: list[str], conn: dict[str, bool]) -> dict:
    return {"t": t, "event": kind, "target": target, "text": f"{kind} {' '.join(target)}", "connectivity": conn}


def fake_run(flows: dict[str, FlowTrack], timeline: list[dict], up: dict[str, bool]) -> SimpleNamespace:
    members = {n: SimpleNamespace(up=u, starting=False, station=Station(n, "vehicle", "process", "static:", 1))
               for n, u in up.items()}
    sc = SimpleNamespace(duration_s=10.0, joins=lambda: {})
    return SimpleNamespace(flows=flows, timeline=timeline, members=members, sc=sc,
                           connectivity0={name: True for name in flows})


def test_an_outage_that_began_before_an_event_is_not_charged_to_it() -> None:
    # gps1 goes silent at t=2.0 with nothing the launcher did (loss, load); at t=3 an unrelated link fails
    # (gps1 keeps its path); gps1 comes back at t=5. The old rule charged 2 s of "reconvergence" to fail_link.
    flows = {"gps1": track("gps1", "uav1", steady(0.0, 2.0) + steady(5.0, 10.0))}
    timeline = [event(3.0, "fail_link", ["uav2", "uav3"], {"gps1": True})]
    run = fake_run(flows, timeline, {"uav1": True, "uav2": True, "uav3": True, "gcs1": True})
    (fail,) = _reconvergence(run, 10.0)
    assert fail["affected"] == {} and fail["reconverged_s"] == 0.0, fail
    (outage,) = explained_outages(run, 10.0)["gps1"]
    assert (outage["from"], outage["to"]) == (2.0, 5.0) and outage["event"] is None
    assert outage["cause"] == "no event: loss or load (a path existed)", outage


def test_outages_go_to_the_event_that_began_them_or_gave_the_path_back() -> None:
    # gps1's relay is killed at t=4.05 (another path: rerouted by t=4.8); gps2's source is killed at t=4.05
    # too and restarted at t=6 (back at t=6.7): the kill is not charged gps2's outage (no path after it), the
    # restart is, with the time from the restart.
    flows = {"gps1": track("gps1", "uav1", steady(0.0, 4.0) + steady(4.8, 10.0)),
             "gps2": track("gps2", "uav2", steady(0.0, 4.0) + steady(6.7, 10.0))}
    timeline = [event(4.05, "kill", ["uav2"], {"gps1": True, "gps2": False}),
                event(6.0, "restart", ["uav2"], {"gps1": True, "gps2": True})]
    timeline[0]["text"] = "kill uav2"
    run = fake_run(flows, timeline, {"uav1": True, "uav2": True, "gcs1": True})
    kill, restart = _reconvergence(run, 10.0)
    assert kill["affected"] == {"gps1": 0.75} and "gps2" not in kill["affected"], kill
    assert restart["affected"] == {"gps2": 0.7}, restart
    why = explained_outages(run, 10.0)
    assert why["gps1"][0]["cause"].startswith("member gone: kill uav2"), why["gps1"]
    assert why["gps2"][0]["cause"].startswith("source gone: kill uav2"), why["gps2"]


def test_a_source_killed_for_good_makes_its_flow_stale() -> None:
    flows = {"gps2": track("gps2", "uav2", steady(0.0, 4.0)), "gps1": track("gps1", "uav1", steady(0.0, 10.0))}
    timeline = [event(4.05, "kill", ["uav2"], {"gps1": True, "gps2": False})]
    run = fake_run(flows, timeline, {"uav1": True, "uav2": False, "gcs1": True})
    assert source_gone(run, flows["gps2"].spec, 10.0) and not source_gone(run, flows["gps1"].spec, 10.0)
    (kill,) = _reconvergence(run, 10.0)
    assert kill["unrecovered"] == [] and kill["reconverged_s"] == 0.0   # no path after it: not its to fix


def test_delivery_is_counted_over_the_span_the_expectation_covers() -> None:
    # Expectations run over [0, duration); a flow set up while the processes start delivers before t = 0, and the
    # processes go on delivering while the run's last stats are collected. Those deliveries are `delivered` but
    # not part of the ratios (counted, they made multi-hop flows of the demo fleet look 4-6 points better).
    tr = FlowTrack(FlowSpec("gps", "gpsOut", "uav1", "gcs1", PERIOD_MS, 1), run_s=30.0)
    for t in (-1.2, -0.1, 0.0, 12.0, 29.95, 30.0, 30.4):
        tr.add(t)
    assert tr.count == 7
    assert tr.in_run == 3


def test_radio_share_is_what_the_links_loss_leaves_over_the_hops() -> None:
    # The demo's own scenario: its links take the radio's 2 % loss.
    run = SimpleNamespace(sc=load_scenario(Path(__file__).resolve().parents[2] / "examples/scenarios/fleet12.yaml"))
    losses = sorted(link.loss for link in run.sc.links)
    loss = losses[len(losses) // 2]
    assert loss > 0.0                                   # the scenario's radio loses frames: the share must show it
    assert radio_share(run, 5) == pytest.approx((1.0 - loss) ** 5)
    assert radio_share(run, 1) > radio_share(run, 5)
    assert radio_share(run, None) == radio_share(run, 1)  # a flow that never delivered counts as one hop


def test_routing_budget_allows_a_window_its_phase_not_an_extra_frame() -> None:
    # Hellos every 200 ms, sampled every ~1.96 s: a window can hold 11 hellos (10 intervals + the phase), which
    # counted raw is 1.12 per hello with no frame but hellos; an extra triggered update is over the budget.
    def rates(per_window: list[int]) -> dict:
        t, n, seen = 0.0, 0, [(0.0, 1, {"l": 0})]
        for k in per_window:
            t, n = t + 1.96, n + k
            seen.append((t, 1, {"l": n}))
        m = SimpleNamespace(name="uav1", routes_seen=seen)
        sc = SimpleNamespace(routing=SimpleNamespace(hello_ms=200))
        return _routing_rates(SimpleNamespace(members={"uav1": m}, timeline=[], sc=sc))

    hellos = rates([10, 10, 11, 10, 11])
    assert hellos["steady_max"] * 0.2 > 1.1                   # raw: the phase alone looks over budget
    assert hellos["steady_per_hello_max"] <= 1.1
    extra = rates([10, 10, 11, 13, 11])                       # two triggered frames in one window
    assert extra["steady_per_hello_max"] > 1.1
