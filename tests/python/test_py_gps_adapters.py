"""The GPS adapters from Python (issue #24 item 4): a Python node's serial link carries a GPS nobody here
wrote (pynmea2's NMEA sentences, pyubx2's UBX messages) interleaved with uavbus frames, on a real pty; the
adapter (uavbus.adapters: the C decoder splits the stream, the C parsers decode, ub_gps_fields.h maps, all
through cffi) keeps the catalogued directory at the values the library encoded; corrupted input is counted,
never merged; every uavbus frame is still delivered. The UBX adapter writes a CFG-RATE when gpsUbxCfg changes (from Python or from a uavbus frame) and counts the
ACK-ACK, ACK-NAK and time-out."""

from __future__ import annotations

import os
import select
import time
import tty
from collections.abc import Callable, Iterator

import pynmea2
import pytest
from pyubx2 import UBXMessage, UBXReader

from binding_testutil import TABLE2, Generated
from uavbus import Node
from uavbus._bindings.ub_error import InvalidArgumentError
from uavbus._bindings.ub_frame import FrameHeader, ub_frame_finish
from uavbus._bindings.ub_node import entity_id
from uavbus.adapters import NmeaAdapter, UbxAdapter

pytestmark = pytest.mark.timeout(30)

LINK = "gcsPortDatalink1"
EPOCHS = 6
NOISE = b"\x00\x13noise between sentences\xff\r\n"


class _Pty:
    """A Python node (gcs of Table 2) whose datalink is a serial port on a raw pty; the master is the device."""

    def __init__(self, gen: Generated) -> None:
        # The lowest free pty is held as a decoy: a stale serial path elsewhere on a shared machine would open
        # it and take its bytes (tests/system/test_nmea_gps.py).
        self.fds = list(os.openpty())
        self.master, slave = os.openpty()
        self.fds += [self.master, slave]
        tty.setraw(slave)
        self.node = Node(gen.catalogue, config=TABLE2, node="gcs")
        self.node.open_port(LINK, f"serial:device={os.ttyname(slave)},baud=115200")
        self.node.bind("gpsOut")  # the frames carry it: bound storage gets them delivered
        self.got: list = []
        self.node.on_data(self.got.append)
        self.from_node = bytearray()
        self.seq = 0

    def frame(self, directory: str = "gpsOut", values: dict | None = None) -> bytes:
        """The next DATA frame of `directory` from rmax1ob1 to gcs1 (zeroes unless `values`)."""
        inst = self.node.catalogue.instance(directory)
        payload = self.node.catalogue.encode(directory, values) if values else bytes(inst.type.packed_size)
        self.seq += 1
        return ub_frame_finish(FrameHeader(dir_id=inst.id, dest_id=entity_id("gcs1"), src_id=entity_id("rmax1ob1"),
                                           admin=0, seq=self.seq, fingerprint=inst.type.fingerprint), payload)

    def write(self, data: bytes) -> None:
        while data:
            data = data[os.write(self.master, data):]

    def wait(self, cond: Callable[[], bool], seconds: float = 5.0) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.node.poll(0.005)
            while select.select([self.master], [], [], 0)[0]:  # what the node writes: the device's input
                self.from_node += os.read(self.master, 4096)
            if cond():
                return
        raise AssertionError("condition not met within the time limit")

    def close(self) -> None:
        self.node.close()
        for fd in self.fds:
            os.close(fd)


@pytest.fixture
def pty(flightsw: Generated) -> Iterator[_Pty]:
    p = _Pty(flightsw)
    yield p
    p.close()


def _epoch(k: int) -> list[pynmea2.NMEASentence]:
    lat, lon = 32.3738 + 0.0011 * k, 84.9664 + 0.0007 * k
    lat_s = f"{int(lat):02d}{(lat - int(lat)) * 60:07.4f}"
    lon_s = f"{int(lon):03d}{(lon - int(lon)) * 60:07.4f}"
    t = f"1230{k:02d}.00"
    return [
        pynmea2.GGA("GP", "GGA", (t, lat_s, "N", lon_s, "W", "1", f"{7 + k:02d}", "0.9", f"{120.0 + k:.1f}", "M",
                                  "-29.4", "M", "", "")),
        pynmea2.RMC("GP", "RMC", (t, "A", lat_s, "N", lon_s, "W", f"{10.0 + k:.1f}", f"{80.0 + k:.1f}", "261126",
                                  "", "")),
        pynmea2.VTG("GP", "VTG", (f"{81.5 + k:.1f}", "T", "", "M", f"{10.5 + k:.1f}", "N", "19.4", "K")),
        pynmea2.GSA("GP", "GSA", ("A", "3", "04", "05", "09", "", "", "", "", "", "", "", "", "",
                                  f"{1.8 + k / 10:.1f}", f"{1.1 + k / 10:.1f}", f"{1.4 + k / 10:.1f}")),
    ]


def _corrupt(sentence: str) -> bytes:
    """A digit of the time changed in transit: the checksum no longer matches."""
    i = sentence.index(",") + 2
    return (sentence[:i] + ("1" if sentence[i] != "1" else "2") + sentence[i + 1:] + "\r\n").encode()


def test_nmea_adapter_keeps_the_directory_at_what_pynmea2_encoded(pty: _Pty) -> None:
    gps = NmeaAdapter(pty.node, LINK, "gpsNmea")
    for k in range(EPOCHS):
        sentences = _epoch(k)
        stream = b""
        for s in sentences:
            stream += (str(s) + "\r\n").encode()
            if s.sentence_type == "RMC":
                stream += pty.frame()  # a uavbus frame between two sentences of one epoch
        pty.write(stream + NOISE + _corrupt(str(sentences[0])) + b"$GPGGA,no checksum\r\n")
        pty.wait(lambda: gps.stats["sentences_ok"] == 4 * (k + 1) and len(pty.got) == k + 1)
    pty.wait(lambda: gps.stats["no_checksum"] == EPOCHS)  # the last line ends only with the next '$' or CR
    gga, rmc, vtg, gsa = (pynmea2.parse(str(s)) for s in _epoch(EPOCHS - 1))  # pynmea2 reads its own output
    d = gps.directory
    assert d.utcMilliseconds == ((12 * 60 + 30) * 60 + EPOCHS - 1) * 1000
    assert d.latitudeDeg == pytest.approx(float(gga.latitude), abs=1e-9)
    assert d.longitudeDeg == pytest.approx(float(gga.longitude), abs=1e-9) and d.longitudeDeg < 0
    assert d.altitudeMsl == pytest.approx(float(gga.altitude))
    assert d.geoidSeparation == pytest.approx(float(gga.geo_sep))
    assert (d.satellitesUsed, d.fixQuality) == (int(gga.num_sats), int(gga.gps_qual))
    assert d.statusValid == 1 and d.utcDate == int(rmc.datestamp.strftime("%d%m%y"))
    assert d.courseDeg == pytest.approx(float(vtg.true_track))  # VTG came after RMC
    assert d.speedMps == pytest.approx(float(vtg.spd_over_grnd_kts) * 1852 / 3600)
    assert d.fixType == int(gsa.mode_fix_type)
    assert (d.pdop, d.hdop, d.vdop) == pytest.approx((float(gsa.pdop), float(gsa.hdop), float(gsa.vdop)), rel=1e-6)
    assert d.time.seconds * 1000 + d.time.microseconds // 1000 > 0  # node time of the last merge
    s = gps.stats
    assert (d.sentencesOk, d.badChecksums, d.badSentences) == (4 * EPOCHS, EPOCHS, EPOCHS)
    assert (s["gga"], s["rmc"], s["vtg"], s["gsa"], s["bad_checksum"]) == (EPOCHS,) * 5
    assert [m.source for m in pty.got] == ["rmax1ob1"] * EPOCHS  # every uavbus frame on the shared wire
    serial = pty.node.port_info(LINK)["serial"]
    assert serial["foreign_refused"] == 0 and serial["foreign_bytes"] == s["bytes_in"], serial  # every byte taken

    gps.close()  # the handler is removed: sentences are no longer merged
    pty.write((str(_epoch(0)[0]) + "\r\n").encode() + pty.frame())
    pty.wait(lambda: len(pty.got) == EPOCHS + 1)
    assert gps.stats["sentences_ok"] == 4 * EPOCHS and d.sentencesOk == 4 * EPOCHS


def test_an_adapter_refuses_a_directory_of_another_type(pty: _Pty) -> None:
    with pytest.raises(InvalidArgumentError, match="not nmeaGps_t"):
        NmeaAdapter(pty.node, LINK, "gpsOut")
    with pytest.raises(InvalidArgumentError, match="not ubxGps_t"):
        UbxAdapter(pty.node, LINK, "gpsNmea")
    assert pty.node.directory("gpsNmea") is None  # refused before binding: not hosted


def _pvt(k: int) -> bytes:
    return UBXMessage("NAV", "NAV-PVT", 0, iTOW=100000 + 200 * k, year=2026, month=11, day=26, hour=17, min=1,
                      second=k, fixType=3, numSV=7 + k, lon=-84.9664 - 0.0007 * k, lat=32.3738 + 0.0011 * k,
                      height=150000 + k, hMSL=120000 + 10 * k, hAcc=1500, vAcc=2500, velN=1000 + k, velE=-200,
                      velD=30, gSpeed=5500 + k, headMot=81.5 + k, pDOP=1.8 + k / 100).serialize()


def test_ubx_adapter_reads_nav_pvt_and_writes_cfg_rate(pty: _Pty) -> None:
    gps = UbxAdapter(pty.node, LINK, "gpsUbx")
    for k in range(EPOCHS):
        good = _pvt(k)
        bad = bytearray(good)
        bad[20] ^= 0x40  # a bit of the longitude flipped in transit
        pty.write(good + pty.frame() + NOISE + bytes(bad))
        pty.wait(lambda: gps.stats["nav_pvt"] == k + 1 and gps.stats["bad_checksum"] == k + 1
                 and len(pty.got) == k + 1)
    want = UBXReader.parse(_pvt(EPOCHS - 1))  # pyubx2 reads its own output
    d = gps.directory
    assert d.latitudeDeg == pytest.approx(want.lat, abs=1e-7)
    assert d.longitudeDeg == pytest.approx(want.lon, abs=1e-7)
    assert d.altitudeMsl == pytest.approx(want.hMSL / 1000) and d.heightEllipsoid == pytest.approx(want.height / 1000)
    assert d.groundSpeedMps == pytest.approx(want.gSpeed / 1000) and d.headingDeg == pytest.approx(want.headMot)
    assert d.velNorth == pytest.approx(want.velN / 1000, rel=1e-6) and d.pdop == pytest.approx(want.pDOP, rel=1e-6)
    assert (d.iTowMs, d.year, d.second, d.fixType, d.satellitesUsed) == (want.iTOW, 2026, EPOCHS - 1, 3, want.numSV)
    assert (d.navPvtOk, d.badChecksums, d.badMessages) == (EPOCHS, EPOCHS, 0)
    assert len(pty.got) == EPOCHS

    # Writing: the rate into gpsUbxCfg; the adapter's service turn writes CFG-RATE onto the pty, as pyubx2
    # reads it; the receiver's ACK-ACK, then (a rate written by a uavbus frame, as the fleet would) an ACK-NAK,
    # then no answer: a time-out, and the same message again.
    def cfg_rates() -> list:
        out, data = [], bytes(pty.from_node)
        at = data.find(b"\xb5\x62\x06\x08")
        while at >= 0:
            out.append(UBXReader.parse(data[at:at + 14]))
            at = data.find(b"\xb5\x62\x06\x08", at + 14)
        return out

    gps.configure(200, 1, 1)
    pty.wait(lambda: len(cfg_rates()) == 1)
    cfg = cfg_rates()[0]
    assert (cfg.identity, cfg.measRate, cfg.navRate, cfg.timeRef) == ("CFG-RATE", 200, 1, 1)
    assert d.cfgSent == 1 and d.cfgAcked == 0
    pty.write(UBXMessage("ACK", "ACK-ACK", 0, clsID=0x06, msgID=0x08).serialize())
    pty.wait(lambda: d.cfgAcked == 1)
    assert d.cfgMeasRateMs == 200
    for _ in range(5):  # the receiver answered: nothing is sent again
        pty.node.poll(0.005)
    assert len(cfg_rates()) == 1 and d.cfgSent == 1

    pty.write(pty.frame("gpsUbxCfg", {"measRateMs": 25, "navRate": 1, "timeRef": 0}))
    pty.wait(lambda: len(cfg_rates()) == 2)
    assert cfg_rates()[1].measRate == 25
    pty.write(UBXMessage("ACK", "ACK-NAK", 0, clsID=0x06, msgID=0x08).serialize())
    pty.wait(lambda: d.cfgNaked == 1)
    assert (d.cfgSent, d.cfgAcked, d.cfgNaked, d.cfgMeasRateMs) == (2, 1, 1, 200)

    gps.configure(1000)
    pty.wait(lambda: len(cfg_rates()) == 3)
    pty.node.service(now_ms=pty.node.now() + 1100)  # a second later, no answer
    assert (d.cfgSent, d.cfgTimeouts) == (4, 1), (d.cfgSent, d.cfgTimeouts, pty.node.port_info(LINK))
    pty.wait(lambda: len(cfg_rates()) == 4)
    for _ in range(5):  # polled again at the real (earlier) time: not overdue, not sent again
        pty.node.poll(0.005)
    assert (len(cfg_rates()), d.cfgSent, d.cfgTimeouts) == (4, 4, 1)
    assert (d.cfgSent, d.cfgTimeouts, cfg_rates()[3].measRate) == (4, 1, 1000)
    gps.close()


def test_the_shared_mapping_covers_every_member_of_the_catalogued_types(pty: _Pty) -> None:
    """ub_gps_fields.h against the catalogue the generator made from examples/flightsw: a member added to
    nmeaGps_t/ubxGps_t and not mapped (or mapped under a name the type lacks) fails here, in both languages'
    adapters at once. The time tag and the UBX adapter's CFG bookkeeping are the adapters' own."""
    from uavbus._bindings import ub_gps

    nmea = {m for m, _, _ in ub_gps.nmea_dir_values(ub_gps.ub_nmea_new())}
    ubx = {m for m, _, _ in ub_gps.ubx_dir_values(ub_gps.ub_ubx_new())}
    cat = pty.node.catalogue
    assert nmea == {f.name for f in cat.instance("gpsNmea").type.packed_fields} - {"time"}
    cfg = {m for m, _, _ in ub_gps.ubx_cfg_dir_values(ub_gps.ub_ubx_cfg_new())}
    assert ubx | cfg == {f.name for f in cat.instance("gpsUbx").type.packed_fields} - {"time"}


def test_nmea_adapter_on_a_udp_link(flightsw: Generated) -> None:
    """The datagram path (a GPS forwarded over UDP, as NMEA-over-IP gateways do): one sentence per datagram,
    a uavbus frame in its own datagram between them, a corrupted sentence counted."""
    import socket

    node = Node(flightsw.catalogue, config=TABLE2, node="gcs")
    peer = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    peer.bind(("127.0.0.1", 0))
    try:
        node.open_port(LINK, f"udp:bind=127.0.0.1:0,peer=127.0.0.1:{peer.getsockname()[1]}")
        gps = NmeaAdapter(node, LINK)
        node.bind("gpsOut")
        got: list = []
        node.on_data(got.append)
        port = node.local_port(LINK)
        gga = _epoch(2)[0]
        inst = node.catalogue.instance("gpsOut")
        frame = ub_frame_finish(FrameHeader(dir_id=inst.id, dest_id=entity_id("gcs1"), src_id=entity_id("rmax1ob1"),
                                            admin=0, seq=1, fingerprint=inst.type.fingerprint),
                                bytes(inst.type.packed_size))
        for data in ((str(gga) + "\r\n").encode(), frame, _corrupt(str(_epoch(3)[0]))):
            peer.sendto(data, ("127.0.0.1", port))
        end = time.monotonic() + 5
        while time.monotonic() < end and not (len(got) == 1 and gps.stats["bad_checksum"] == 1):
            node.poll(0.005)
        want = pynmea2.parse(str(gga))
        d = gps.directory
        assert (len(got), d.sentencesOk, d.badChecksums) == (1, 1, 1)
        assert d.latitudeDeg == pytest.approx(float(want.latitude), abs=1e-9)
        assert d.altitudeMsl == pytest.approx(float(want.altitude))
    finally:
        peer.close()
        node.close()
