"""A process restarted as the same entity is not taken for duplicates of the one before (ub_node_seq_seed()).

CI (test_rates_observed: `uavbus list fcs20` run twice): the first tool process, hosting gcs1, sent ~755
requests within its first second; the next, seeded from the millisecond clock ~700 ms later, began up to 63
numbers below the first one's last, and the forwarder's duplicate window dropped every retry of its first
request (30 in 6 s). Here the same: a GCS process sends 755 frames to rmax1ob1 and a second GCS process,
started 700 ms (wall clock) after the first, sends 64; every one of the 64 must be delivered."""

from __future__ import annotations

import time

import pytest
from binding_testutil import TABLE2, FakeClock, Generated, run_nodes

from uavbus import MemLink, Node

T0_NS = 1_795_766_400_123_456_789  # 2026-11-27 08:00:00.123 UTC


def gcs_process(flightsw: Generated, clock: FakeClock, air: Node, wall_ns: int,
                monkeypatch: pytest.MonkeyPatch) -> tuple[Node, MemLink]:
    """A new GCS "process" started at wall-clock time `wall_ns` (its default sequence seed reads the clock),
    linked to `air` where the previous one was."""
    with monkeypatch.context() as m:
        m.setattr(time, "time_ns", lambda: wall_ns)
        gcs = Node(flightsw.catalogue, config=TABLE2, node="gcs", clock=clock)
    return gcs, MemLink(air, "onboardPortDatalink1", gcs, "gcsPortDatalink1", seed=1)


@pytest.mark.parametrize("restart_ms", [700, 730, 754])
def test_a_restarted_gcs_is_not_dropped_as_its_predecessors_duplicates(
        flightsw: Generated, monkeypatch: pytest.MonkeyPatch, restart_ms: int) -> None:
    clock = FakeClock()
    air = Node(flightsw.catalogue, config=TABLE2, node="primary", clock=clock)
    air.bind("gpsOut")
    first, link = gcs_process(flightsw, clock, air, T0_NS, monkeypatch)
    try:
        for k in range(755):  # `uavbus list`: one request per catalogued directory, 4 in flight
            first.send("gcs1", "gpsOut", to="rmax1ob1")
            if k % 4 == 3:
                run_nodes([first, air], clock, 1, step=1)
        run_nodes([first, air], clock, 20)
        assert air.counters()["delivered"] == 755
        link.disconnect()
        first.close()
        second, _ = gcs_process(flightsw, clock, air, T0_NS + restart_ms * 1_000_000, monkeypatch)
        try:
            for _ in range(64):  # its first request and every retry of it
                second.send("gcs1", "gpsOut", to="rmax1ob1")
                run_nodes([second, air], clock, 5)
            c = air.counters()
            assert (c["delivered"] - 755, c["drops"]["duplicate"]) == (64, 0), c["drops"]
        finally:
            second.close()
    finally:
        first.close()
        air.close()
