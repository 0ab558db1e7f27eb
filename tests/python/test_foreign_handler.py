"""Python registers a foreign-traffic handler on a link (issue #24 item 4): the C runtime splits the traffic
(one implementation, reached through cffi), the handler sees what is not uavbus, frames are routed as before.
Over a real UDP socket (the datagram path) and a real pty (the stream path, where pynmea2 is the device)."""

from __future__ import annotations

import os
import socket
import time
import tty

import pynmea2
import pytest

from binding_testutil import TABLE2, Generated
from uavbus import Node
from uavbus._bindings.ub_frame import FrameHeader, ub_frame_finish
from uavbus._bindings.ub_node import entity_id

pytestmark = pytest.mark.timeout(30)


def wait_for(node: Node, cond, seconds: float = 5.0) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        node.poll(0.005)
        if cond():
            return
    raise AssertionError("condition not met within the time limit")


def _frame(node: Node, seq: int) -> bytes:
    inst = node.catalogue.instance("gpsOut")
    return ub_frame_finish(FrameHeader(dir_id=inst.id, dest_id=entity_id("gcs1"), src_id=entity_id("rmax1ob1"),
                                       admin=0, seq=seq, fingerprint=inst.type.fingerprint),
                           bytes(inst.type.packed_size))


def test_udp_datagrams_that_are_not_uavbus_reach_the_python_handler(flightsw: Generated) -> None:
    gcs = Node(flightsw.catalogue, config=TABLE2, node="gcs")
    peer = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    peer.bind(("127.0.0.1", 0))
    try:
        gcs.open_port("gcsPortDatalink1", f"udp:bind=127.0.0.1:0,peer=127.0.0.1:{peer.getsockname()[1]}")
        port = gcs.local_port("gcsPortDatalink1")
        seen: list[bytes] = []
        gcs.set_foreign_handler("gcsPortDatalink1", lambda data: seen.append(data))
        gcs.bind("gpsOut")  # the frames below carry it: bound storage gets them delivered
        got = []
        gcs.on_data(got.append)
        gga = str(pynmea2.GGA("GP", "GGA", ("123519", "4807.038", "N", "01131.000", "E", "1", "08", "0.9",
                                            "545.4", "M", "46.9", "M", "", ""))).encode()
        peer.sendto(gga, ("127.0.0.1", port))
        peer.sendto(_frame(gcs, 1), ("127.0.0.1", port))
        peer.sendto(b"legacy datalink message", ("127.0.0.1", port))
        wait_for(gcs, lambda: len(seen) == 2 and len(got) == 1)
        assert seen == [gga, b"legacy datalink message"]  # whole datagrams, in order, never the frame
        assert got[0].source == "rmax1ob1"
        counters = gcs.port_info("gcsPortDatalink1")
        assert counters["udp"]["foreign_datagrams"] == 2, counters
        gcs.set_foreign_handler("gcsPortDatalink1", None)
        peer.sendto(b"after removal", ("127.0.0.1", port))
        time.sleep(0.05)
        for _ in range(10):
            gcs.poll(0.005)
        assert len(seen) == 2
    finally:
        peer.close()
        gcs.close()


def test_serial_stream_bytes_that_are_not_uavbus_reach_the_python_handler(flightsw: Generated) -> None:
    gcs = Node(flightsw.catalogue, config=TABLE2, node="gcs")
    # The lowest free pty is held as a decoy: a stale serial path elsewhere on a shared machine (another
    # node retrying /dev/pts/0 by path) would open it and take its bytes (tests/system/test_nmea_gps.py).
    decoy_master, decoy_slave = os.openpty()
    master, slave = os.openpty()
    tty.setraw(slave)
    path = os.ttyname(slave)
    try:
        gcs.open_port("gcsPortDatalink1", f"serial:device={path},baud=9600")
        seen = bytearray()
        gcs.set_foreign_handler("gcsPortDatalink1", lambda data: seen.extend(data))
        gcs.bind("gpsOut")  # the frames below carry it: bound storage gets them delivered
        got = []
        gcs.on_data(got.append)
        sentences = [str(pynmea2.VTG("GP", "VTG", (f"{54.7 + k:.1f}", "T", "", "M", "5.5", "N", "10.2", "K")))
                     for k in range(3)]
        text = [(s + "\r\n").encode() for s in sentences]
        # Text, a frame, text, a frame, text.
        os.write(master, text[0] + _frame(gcs, 1) + text[1] + _frame(gcs, 2) + text[2])
        wait_for(gcs, lambda: len(got) == 2 and len(seen) == sum(map(len, text)))
        assert bytes(seen) == b"".join(text)  # every foreign byte once, in order; no frame byte
        assert [m.source for m in got] == ["rmax1ob1", "rmax1ob1"]
    finally:
        gcs.close()
        for fd in (master, slave, decoy_master, decoy_slave):
            os.close(fd)


def test_tcp_stream_bytes_that_are_not_uavbus_reach_the_python_handler(flightsw: Generated) -> None:
    """The TCP driver's foreign path (a byte stream like serial): text between frames reaches the handler, the
    frames are delivered; a new connection restarts the link's decoder and keeps the handler."""
    gcs = Node(flightsw.catalogue, config=TABLE2, node="gcs")
    try:
        gcs.open_port("gcsPortDatalink1", "tcp:listen=127.0.0.1:0")
        port = gcs.local_port("gcsPortDatalink1")
        seen = bytearray()
        gcs.set_foreign_handler("gcsPortDatalink1", lambda data: seen.extend(data))
        gcs.bind("gpsOut")
        got = []
        gcs.on_data(got.append)
        text = [f"legacy message {k}\r\n".encode() for k in range(4)]
        with socket.create_connection(("127.0.0.1", port)) as peer:
            peer.sendall(text[0] + _frame(gcs, 1) + text[1] + _frame(gcs, 2) + text[2])
            wait_for(gcs, lambda: len(got) == 2 and len(seen) == sum(map(len, text[:3])))
        assert bytes(seen) == b"".join(text[:3])  # every foreign byte once, in order; no frame byte
        wait_for(gcs, lambda: gcs.port_info("gcsPortDatalink1")["tcp"]["state"] == "down")
        with socket.create_connection(("127.0.0.1", port)) as peer:  # a new stream, the same handler
            peer.sendall(_frame(gcs, 3) + text[3])
            wait_for(gcs, lambda: len(got) == 3 and len(seen) == sum(map(len, text)))
        assert bytes(seen) == b"".join(text)
        tcp = gcs.port_info("gcsPortDatalink1")["tcp"]
        assert tcp["foreign_bytes"] == len(seen) and tcp["foreign_refused"] == 0, tcp
    finally:
        gcs.close()
