"""A Python node stores received images as they are (wire-image storage, no C codec): an image the
generated C unpack would refuse (a bool byte other than 0/1, a bitfield wider than its field) is
not delivered, and is counted, as a C node counts it as a `bad_payload` drop (docs/catalogue.md)."""

from __future__ import annotations

from binding_testutil import TABLE2, FakeClock, Generated
from test_node_memlink import run

from uavbus import MemLink, Node


def test_refused_image_is_counted_not_delivered(flightsw: Generated) -> None:
    clock = FakeClock()
    gcs = Node(flightsw.catalogue, config=TABLE2, node="gcs", clock=clock)
    air = Node(flightsw.catalogue, config=TABLE2, node="primary", clock=clock)
    MemLink(air, "onboardPortDatalink1", gcs, "gcsPortDatalink1", seed=1)
    try:
        gps = air.bind("gpsOut")
        gcs.subscribe("gcs1", "gpsOut", source="rmax1ob1", period_ms=50)
        got = []
        gcs.on_data(got.append)
        run([gcs, air], clock, 300)
        assert got and gcs.counters()["python"]["refused_payloads"] == 0
        offset, size = gps.type.refusable[0]  # a one-bit bitfield's container (status.antennaOk)
        image = bytearray(gps.raw)
        image[offset:offset + size] = b"\x07" * size
        gps.raw = bytes(image)  # what a foreign or hostile sender could put on the wire
        before = len(got)
        run([gcs, air], clock, 300)
        assert len(got) == before, "a refused image was delivered"
        assert gcs.counters()["python"]["refused_payloads"] > 0
    finally:
        gcs.close()
        air.close()
