"""PyLink: a transport written in Python behind a C link slot (the Zenoh bridge's), with the same
router on both sides: frames the router sends are queued in order, received ones are verified and
routed, and every refusal is counted where the C counters say it is."""

from __future__ import annotations

from binding_testutil import TABLE2, FakeClock, Generated
from binding_testutil import run_nodes as run
from uavbus import Node
from uavbus.pylink import PyLink


def carry(src: PyLink, dst: PyLink) -> int:
    frames = src.drain()
    for f in frames:
        dst.receive(f)
    return len(frames)


def test_subscription_across_two_python_transports(flightsw: Generated) -> None:
    clock = FakeClock()
    gcs = Node(flightsw.catalogue, config=TABLE2, node="gcs", clock=clock)
    air = Node(flightsw.catalogue, config=TABLE2, node="primary", clock=clock)
    a, b = PyLink(air, "onboardPortDatalink1"), PyLink(gcs, "gcsPortDatalink1")
    air.bind("gpsOut")
    gcs.subscribe("gcs1", "gpsOut", source="rmax1ob1", period_ms=50)
    got = []
    gcs.on_data(got.append)
    for _ in range(200):  # 1 s
        run([gcs, air], clock, 5)
        carry(a, b)
        carry(b, a)
    assert 18 <= len(got) <= 20, len(got)  # 20 Hz after the request's round trip
    assert gcs.link_counters()["gcsPortDatalink1"]["transport"] == "py"
    # Every frame one router sent reached the other: requests and ACKs one way, DATA the other.
    assert air.link_counters()["onboardPortDatalink1"]["frames_out"] == gcs.link_counters()["gcsPortDatalink1"]["frames_in"]
    assert gcs.link_counters()["gcsPortDatalink1"]["frames_out"] == air.link_counters()["onboardPortDatalink1"]["frames_in"]
    gcs.close()
    air.close()


def test_full_outbox_is_backpressure_and_bad_frames_are_counted(flightsw: Generated) -> None:
    clock = FakeClock()
    air = Node(flightsw.catalogue, config=TABLE2, node="primary", clock=clock)
    a = PyLink(air, "onboardPortDatalink1", capacity=3)
    air.publish("rmax1ob1", "gpsOut", to="gcs1", period_ms=10)
    run([air], clock, 100)
    assert len(a.drain()) == 3 and a.refused > 0
    c = air.link_counters()["onboardPortDatalink1"]
    assert c["drops"]["backpressure"] == a.refused and c["frames_out"] == 3
    assert not a.receive(b"\x00" * 70)
    assert a.rejected == 1 and sum(air.link_counters()["onboardPortDatalink1"]["bad_frames"].values()) == 1


def test_an_exception_in_send_is_a_counted_tx_error(flightsw: Generated) -> None:
    clock = FakeClock()
    air = Node(flightsw.catalogue, config=TABLE2, node="primary", clock=clock)

    class Broken(PyLink):
        def send(self, frame: bytes, now_ms: int) -> int:
            raise RuntimeError("transport down")

    link = Broken(air, "onboardPortDatalink1")
    air.publish("rmax1ob1", "gpsOut", to="gcs1", period_ms=10)
    run([air], clock, 50)
    assert air.link_counters()["onboardPortDatalink1"]["drops"]["tx_error"] == link.send_errors >= 4
    assert isinstance(link.last_error, RuntimeError)
