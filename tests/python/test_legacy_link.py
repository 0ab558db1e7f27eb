"""The paper's legacy datalink envelope on a real serial link (issue #24 item 2; section IV: the publish/subscribe
message is one more message type of the existing datalink).

A pty is the radio link. On one end a uavbus Node (gcs1's, Table 2) opens it as `legacy:...,type=200`. On the
other end this test is the old ground station of the legacy system: it knows exactly two message types, 1
(heartbeat) and 2 (telemetry), written and read with its own codec below (the envelope as docs/wire-format.md
gives it, shared with no uavbus code), and it ignores every type it does not know, as an old ground station
would. The same end also carries a uavbus peer's frames, in the uavbus type. Both ways, on the one wire:
 - legacy messages and uavbus frames from the old side: the node delivers the frame, and every legacy message
   (types 1, 2, and 7, which uavbus does not know) reaches the application's handler whole and byte-exact;
   a corrupted message is counted, not delivered;
 - from the node: the application writes a legacy heartbeat (Node.write_foreign) and the node sends a uavbus
   frame; the old ground station reads its heartbeat byte-exact and skips the uavbus message as unknown, and
   the frame inside it is the node's, intact."""

from __future__ import annotations

import os
import select
import struct
import time
import tty

import pytest

from binding_testutil import TABLE2, Generated
from uavbus import Node
from uavbus._bindings.ub_frame import FrameHeader, ub_frame_finish, ub_frame_parse
from uavbus._bindings.ub_node import entity_id

pytestmark = pytest.mark.timeout(30)
UAVBUS_TYPE = 200


def legacy(msg_type: int, payload: bytes) -> bytes:
    """The old system's message: sync EB 90, header and message checksums (8-bit sums), type, size."""
    head = struct.pack("<HH", msg_type, len(payload))
    hck = sum(head) & 0xFF
    return bytes([0xEB, 0x90, hck, (hck + sum(payload)) & 0xFF]) + head + payload


class OldGroundStation:
    """Knows types 1 and 2; anything else it counts as unknown and skips (whole, by its size field)."""

    KNOWN = {1: "heartbeat", 2: "telemetry"}

    def __init__(self) -> None:
        self.buf = b""
        self.known: list[bytes] = []
        self.unknown: list[tuple[int, bytes]] = []

    def feed(self, data: bytes) -> None:
        self.buf += data
        while True:
            i = self.buf.find(b"\xeb\x90")
            if i < 0 or len(self.buf) - i < 8:
                return
            msg_type, size = struct.unpack_from("<HH", self.buf, i + 4)
            if len(self.buf) - i < 8 + size:
                return
            msg, self.buf = self.buf[i:i + 8 + size], self.buf[i + 8 + size:]
            if self.KNOWN.get(msg_type):
                self.known.append(msg)
            else:
                self.unknown.append((msg_type, msg[8:]))


def wait_for(node: Node, cond, seconds: float = 5.0, master: int | None = None, gs: OldGroundStation | None = None):
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        node.poll(0.005)
        if master is not None and gs is not None and select.select([master], [], [], 0)[0]:
            gs.feed(os.read(master, 4096))
        if cond():
            return
    raise AssertionError("condition not met within the time limit")


def test_a_legacy_ground_station_and_uavbus_share_one_serial_link(flightsw: Generated) -> None:
    gcs = Node(flightsw.catalogue, config=TABLE2, node="gcs")
    decoy_master, decoy_slave = os.openpty()  # a stale path elsewhere would take the lowest pty (test_nmea_gps.py)
    master, slave = os.openpty()
    tty.setraw(slave)
    tty.setraw(master)
    try:
        gcs.open_port("gcsPortDatalink1", f"legacy:device={os.ttyname(slave)},baud=57600,type={UAVBUS_TYPE}")
        handled = bytearray()
        gcs.set_foreign_handler("gcsPortDatalink1", lambda data: handled.extend(data))
        gcs.bind("gpsOut")
        got = []
        gcs.on_data(got.append)

        # The old side: its own types, a uavbus frame in the uavbus type, a type uavbus does not know, noise,
        # and a telemetry message corrupted in transit.
        inst = gcs.catalogue.instance("gpsOut")
        frame = ub_frame_finish(FrameHeader(dir_id=inst.id, dest_id=entity_id("gcs1"), src_id=entity_id("rmax1ob1"),
                                            admin=0, seq=1, fingerprint=inst.type.fingerprint),
                                bytes(inst.type.packed_size))
        heartbeat, telemetry = legacy(1, b"GS alive"), legacy(2, struct.pack("<fff", 32.37, -84.96, 120.5))
        unknown = legacy(7, bytes(range(40)) + b"\xeb\x90")  # a newer type, with the sync pair inside
        corrupted = bytearray(legacy(2, b"lost in transit"))
        corrupted[-1] ^= 0x20
        os.write(master, heartbeat + b"\x00noise\xeb" + legacy(UAVBUS_TYPE, frame) + telemetry + bytes(corrupted)
                 + unknown)
        want = heartbeat + telemetry + unknown
        wait_for(gcs, lambda: len(got) == 1 and len(handled) >= len(want))
        assert bytes(handled) == want  # every legacy message whole, in order, byte-exact; never the uavbus one
        assert got[0].source == "rmax1ob1"
        info = gcs.port_info("gcsPortDatalink1")["legacy"]
        assert (info["frames_in"], info["foreign_messages"], info["bad_checksum"]) == (1, 3, 1), info

        # The other way: the application's legacy heartbeat, and a uavbus frame from the node.
        gs = OldGroundStation()
        mine = legacy(1, b"vehicle alive")
        gcs.write_foreign("gcsPortDatalink1", mine)
        assert gcs.send("gcs1", "gpsOut", "rmax1ob1") == 1
        wait_for(gcs, lambda: len(gs.known) == 1 and len(gs.unknown) == 1, master=master, gs=gs)
        assert gs.known == [mine]  # the old ground station still works: it reads its type byte-exact
        msg_type, inner = gs.unknown[0]  # and skips what it does not know
        assert msg_type == UAVBUS_TYPE
        h = ub_frame_parse(inner)  # a whole, valid uavbus frame (its CRC checked by the parse)
        assert (h.src_id, h.dest_id, h.dir_id) == (entity_id("gcs1"), entity_id("rmax1ob1"), inst.id)
        info = gcs.port_info("gcsPortDatalink1")["legacy"]
        assert info["frames_out"] == 1 and info["unhandled"] == 0, info
    finally:
        gcs.close()
        for fd in (master, slave, decoy_master, decoy_slave):
            os.close(fd)
