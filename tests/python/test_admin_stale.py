"""Issue 23 item 5: a status that depends on data turns stale visibly. The GCS administers a gpsOut publication
to itself; the source acknowledges every renewal (FLOWING: it sends), but the data does not land at gcs1 (it
hosts no gpsOut yet: dropped `unbound`). After 3 periods + 500 ms the row reads "stale" -- in the C status,
in Python and in `uavbus tables`' text -- and it returns to "active" once the data lands."""

from __future__ import annotations

import pytest

from binding_testutil import TABLE2, FakeClock, Generated
from binding_testutil import run_nodes as run
from uavbus import MemLink, Node
from uavbus.tools.tables import render_admin


@pytest.fixture()
def pair(flightsw: Generated):
    clock = FakeClock()
    gcs = Node(flightsw.catalogue, config=TABLE2, node="gcs", clock=clock)
    air = Node(flightsw.catalogue, config=TABLE2, node="primary", clock=clock)
    link = MemLink(air, "onboardPortDatalink1", gcs, "gcsPortDatalink1", seed=1)
    yield gcs, air, link, clock
    gcs.close()
    air.close()


def test_acknowledged_row_without_data_reads_stale_then_active(pair) -> None:
    gcs, air, _link, clock = pair
    air.bind("gpsOut")
    adm = gcs.admin("gcs1")
    r = adm.add(content="gpsOut", source="rmax1ob1", destination="gcs1", period_ms=50, kind="publication")
    adm.activate(r)
    run([gcs, air], clock, 300)
    s = adm.status(r)
    assert s["status"] == "active" and s["last_data_ms"] == 0     # the source says it sends; nothing landed
    run([gcs, air], clock, 500)                                    # 800 ms after the first ACK: 3 x 50 + 500 passed
    s = adm.status(r)
    assert s["status"] == "stale", s
    assert gcs.counters()["drops"]["unbound"] >= 10
    assert s["last_ack_ms"] >= clock.t - 1100                      # renewals still acknowledged
    text = "\n".join(render_admin("gcs1", adm.rows()))
    assert "stale" in text and "gpsOut" in text
    gcs.bind("gpsOut")                                             # the data lands again
    run([gcs, air], clock, 200)
    s = adm.status(r)
    assert s["status"] == "active" and s["last_data_ms"] > 0
    assert "stale" not in "\n".join(render_admin("gcs1", adm.rows()))
