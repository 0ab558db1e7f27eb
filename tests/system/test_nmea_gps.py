"""A GPS nobody here wrote on a link that also carries uavbus (issue #24, acceptance for NMEA).

pynmea2 (PyPI) encodes GGA, RMC, VTG and GSA sentences; the test writes them into a pty, interleaved with
uavbus frames, line noise and corrupted sentences. On the other side of the pty, uavbus_node runs the port
`nmea:device=...` (programs/node/adapter_nmea.c); no other program is involved. The GPS is on fcs20's serial
port (Table 2 with one more link for it, backupPortGps), and gcs1 subscribes to gpsNmea two hops away
(gcs1 - rmax1ob1 - fcs20, over UDP): it must receive the values pynmea2 encoded (as pynmea2 itself reads
them back), never those of a corrupted sentence; every uavbus frame written into the pty is taken in; every
corrupted sentence is counted.
"""

from __future__ import annotations

import json
import os
import select
import threading
import time
import tty
from pathlib import Path
from typing import Any, Callable

import pynmea2
import pytest
from pyubx2 import UBXMessage, UBXReader

from uavbus._bindings.ub_catalogue import ub_entity_id
from uavbus._bindings.ub_frame import FrameHeader, ub_frame_finish
from uavbus.catalogue import Catalogue
from uavbus.sim.hitl import catalogue_for
from uavbus.sim.portalloc import PortAllocator
from uavbus.sim.process import ProcessGroup

pytestmark = pytest.mark.timeout(60)

ROOT = Path(__file__).resolve().parents[2]
TABLE2 = ROOT / "examples" / "configs" / "table2.json"
EPOCHS = 12
FRAMES_PER_EPOCH = 2
NOISE = b"\x00\x13noise between sentences\xff\r\n"


def _pty_holders(path: str) -> list[str]:
    """Other processes that have `path` open (read from /proc)."""
    me, pids = str(os.getpid()), []
    for fd in Path("/proc").glob("[0-9]*/fd/*"):
        try:
            if os.readlink(fd) == path and fd.parts[2] != me:
                pids.append(fd.parts[2])
        except OSError:
            continue
    return pids


def _new_pty(link: Path, decoys: list[int]) -> int:
    """A raw pty pair; `link` names its slave. Returns the master.

    A device path is a name anyone may reopen: a serial driver that retries a lost device by path (uavbus's
    does) opens whatever pty gets that number next and reads its bytes. On this shared machine another
    session's long-running node retried /dev/pts/0 and took this test's bytes (found through /proc: its pid
    held our pty's slave). So the lowest free pty, the number a stale path most likely names, is held as a
    decoy (in `decoys`, closed by the caller), and a pty someone else already holds is skipped too."""
    d_master, d_slave = os.openpty()
    decoys += [d_master, d_slave]
    while True:
        master, slave = os.openpty()
        path = os.ttyname(slave)
        if not _pty_holders(path):
            break
        decoys += [master, slave]
    tty.setraw(slave)
    os.close(slave)
    if link.is_symlink():
        link.unlink()
    link.symlink_to(path)
    return master


def _drain(master: int, stop: threading.Event, out: bytearray) -> None:
    """Reads what the node sends onto the pty into `out` (the simulated receiver's input), so its writes
    never block. The master stays blocking: the writes below must not be cut. Until the node opens the
    slave, reading the master fails (EIO): it is tried again."""
    while not stop.is_set():
        try:
            ready, _, _ = select.select([master], [], [], 0.05)
            if ready:
                out += os.read(master, 4096)
        except OSError:
            stop.wait(0.05)


def _write_all(master: int, data: bytes) -> None:
    while data:
        data = data[os.write(master, data):]


def _ddmm(value: float, lat: bool) -> tuple[str, str]:
    hemi = ("N" if value >= 0 else "S") if lat else ("E" if value >= 0 else "W")
    v = abs(value)
    deg = int(v)
    minutes = (v - deg) * 60.0
    return (f"{deg:02d}{minutes:07.4f}" if lat else f"{deg:03d}{minutes:07.4f}"), hemi


def _epoch(k: int) -> list[pynmea2.NMEASentence]:
    """One receiver epoch: four sentences whose values change with k."""
    lat, lat_h = _ddmm(32.3738 + 0.0011 * k, True)
    lon, lon_h = _ddmm(-84.9664 - 0.0007 * k, False)
    hhmmss = f"1230{k:02d}.00"
    return [
        pynmea2.GGA("GP", "GGA", (hhmmss, lat, lat_h, lon, lon_h, "1", f"{7 + k % 4:02d}", "0.9",
                                  f"{120.0 + k:.1f}", "M", "-29.4", "M", "", "")),
        pynmea2.RMC("GP", "RMC", (hhmmss, "A", lat, lat_h, lon, lon_h, f"{10.0 + k:.1f}", f"{80.0 + k:.1f}",
                                  "261126", "", "")),
        pynmea2.VTG("GP", "VTG", (f"{81.5 + k:.1f}", "T", "", "M", f"{10.5 + k:.1f}", "N",
                                  f"{(10.5 + k) * 1.852:.1f}", "K")),
        pynmea2.GSA("GP", "GSA", ("A", "3", "04", "05", "09", "12", "24", "", "", "", "", "", "", "",
                                  f"{1.8 + k / 10:.1f}", f"{1.1 + k / 10:.1f}", f"{1.4 + k / 10:.1f}")),
    ]


def _corrupt(sentence: str) -> bytes:
    """A digit of the latitude changed in transit: the checksum no longer matches."""
    i = sentence.index(",", sentence.index(",") + 1) + 3
    d = sentence[i]
    return (sentence[:i] + ("1" if d != "1" else "2") + sentence[i + 1:] + "\r\n").encode()


def _config(tmp_path: Path) -> Path:
    """Table 2 with a second link at fcs20 (link 1) for its GPS receiver; no mask uses it."""
    cfg = json.loads(TABLE2.read_text())
    fcs = next(e for e in cfg["entities"] if e["name"] == "fcs20")
    fcs["links"].append("backupPortGps")
    path = tmp_path / "table2_gps.json"
    path.write_text(json.dumps(cfg))
    return path


class _GpsLink:
    """Table 2 on three nodes (gcs1 - rmax1ob1 - fcs20 over UDP) with a GPS on fcs20's serial port: the port
    `gps_port` (e.g. "nmea:device={dev},baud=9600") on a pty whose master is the receiver's side, and gcs1
    subscribed to `directory` two hops away. What the node writes onto the pty is kept in `from_node`."""

    def __init__(self, program: Path, tmp_path: Path, gps_port: str, directory: str) -> None:
        self.cat = Catalogue.load(str(catalogue_for(program)))
        self.program, self.tmp_path, self.gps_port, self.directory = program, tmp_path, gps_port, directory
        self.from_node = bytearray()
        self.seq = 0

    def __enter__(self) -> "_GpsLink":
        config = _config(self.tmp_path)
        alloc = PortAllocator()
        p_primary, p_gcs, p_relay, p_backup = alloc.port(), alloc.port(), alloc.port(), alloc.port()
        dev = Path(f"/tmp/ub_gps_{os.getpid()}_{self.directory}")
        self.decoys: list[int] = []
        self.master = _new_pty(dev, self.decoys)
        self.stop = threading.Event()
        self.drain = threading.Thread(target=_drain, args=(self.master, self.stop, self.from_node), daemon=True)
        self.drain.start()
        self.group = ProcessGroup().__enter__()
        g, program = self.group, str(self.program)
        g.on_close(lambda: dev.unlink(missing_ok=True))
        self.backup = g.spawn([program, "--config", str(config), "--node", "backup",
                               "--port", f"onboardPortDatalink1=udp:bind=127.0.0.1:{p_backup},peer=127.0.0.1:{p_relay}",
                               "--port", "backupPortGps=" + self.gps_port.format(dev=dev),
                               "--stats-ms", "0"], "backup")
        g.spawn([program, "--config", str(config), "--node", "primary",
                 "--port", f"onboardPortDatalink1=udp:bind=127.0.0.1:{p_primary},peer=127.0.0.1:{p_gcs}",
                 "--port", f"onboardPortRelay=udp:bind=127.0.0.1:{p_relay},peer=127.0.0.1:{p_backup}",
                 "--stats-ms", "0"], "primary")
        self.gcs = g.spawn([program, "--config", str(config), "--node", "gcs",
                            "--port", f"gcsPortDatalink1=udp:bind=127.0.0.1:{p_gcs},peer=127.0.0.1:{p_primary}",
                            "--subscribe", f"gcs1:{self.directory}@fcs20/50", "--stats-ms", "0"], "gcs")
        return self

    def __exit__(self, *exc: object) -> None:
        try:
            self.group.__exit__(*exc)
        finally:
            self.stop.set()
            self.drain.join(timeout=2)
            for fd in [self.master, *self.decoys]:
                os.close(fd)

    def frame(self, directory: str = "fcsSet", values: dict | None = None) -> bytes:
        """The next uavbus DATA frame of `directory` for fcs20 from rmax1ob2 (not running here)."""
        inst = self.cat.instance(directory)
        payload = self.cat.encode(directory, values) if values else bytes(inst.type.packed_size)
        self.seq += 1
        return ub_frame_finish(FrameHeader(dir_id=inst.id, dest_id=ub_entity_id("fcs20"),
                                           src_id=ub_entity_id("rmax1ob2"), admin=0, seq=self.seq,
                                           fingerprint=inst.type.fingerprint), payload)

    def write(self, data: bytes) -> None:
        """Writes into the pty, then waits until fcs20's node has read every byte written so far."""
        _write_all(self.master, data)
        self.written = getattr(self, "written", 0) + len(data)
        deadline = time.monotonic() + 10
        while (gps := self.link())["bytes_in"] < self.written:
            assert time.monotonic() < deadline, f"fcs20's node did not read all that was written: {gps}"
            time.sleep(0.05)

    def link(self) -> dict:
        return self.backup.request_stats()["links"]["backupPortGps"]

    def values_at_gcs(self, done: Callable[[dict], bool]) -> dict:
        """The directory as gcs1 holds it, once `done(values)` (or after 10 s, for the asserts to say)."""
        values: dict = {}
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            m = self.gcs.mark()
            self.gcs.send(f"dump {self.directory}")
            values = self.cat.decode(self.directory, bytes.fromhex(self.gcs.wait_event("dump", 3.0, since=m)["packed"]))
            if done(values):
                break
            time.sleep(0.1)
        return values


def test_nmea_gps_and_uavbus_share_a_serial_link(program: Path, tmp_path: Path) -> None:
    with _GpsLink(program, tmp_path, "nmea:device={dev},baud=9600", "gpsNmea") as gps:
        corrupted = 0
        stream = b""
        last_good: list[pynmea2.NMEASentence] = []
        for k in range(EPOCHS):
            sentences = _epoch(k)
            for i, s in enumerate(sentences):
                stream += (str(s) + "\r\n").encode()
                if i % 2 == 0 and gps.seq < (k + 1) * FRAMES_PER_EPOCH:
                    stream += gps.frame()
            stream += NOISE
            # A corrupted copy of this epoch's GGA after the good ones: it must change nothing.
            stream += _corrupt(str(sentences[0]))
            corrupted += 1
            last_good = sentences
        gps.write(stream)  # one write; everything is read by fcs20's node before the values are judged
        gga, rmc, vtg, gsa = (pynmea2.parse(str(s)) for s in last_good)  # pynmea2 reads its own output
        values = gps.values_at_gcs(lambda v: v["sentencesOk"] == 4 * EPOCHS)  # the last sentence merged
        assert values["utcMilliseconds"] == ((12 * 60 + 30) * 60 + EPOCHS - 1) * 1000, values
        assert values["latitudeDeg"] == pytest.approx(float(gga.latitude), abs=1e-9)
        assert values["longitudeDeg"] == pytest.approx(float(gga.longitude), abs=1e-9)
        assert values["altitudeMsl"] == pytest.approx(float(gga.altitude))
        assert values["geoidSeparation"] == pytest.approx(float(gga.geo_sep))
        assert values["satellitesUsed"] == int(gga.num_sats)
        assert values["fixQuality"] == int(gga.gps_qual)
        assert values["statusValid"] == (rmc.status == "A")
        assert values["utcDate"] == int(rmc.datestamp.strftime("%d%m%y"))
        assert values["courseDeg"] == pytest.approx(float(vtg.true_track))  # VTG came after RMC
        assert values["speedMps"] == pytest.approx(float(vtg.spd_over_grnd_kts) * 1852 / 3600)
        assert values["fixType"] == int(gsa.mode_fix_type)
        assert values["pdop"] == pytest.approx(float(gsa.pdop), rel=1e-6)
        assert values["hdop"] == pytest.approx(float(gsa.hdop), rel=1e-6)  # GSA came after GGA
        assert values["vdop"] == pytest.approx(float(gsa.vdop), rel=1e-6)
        link = gps.link()
        assert values["sentencesOk"] == 4 * EPOCHS, link
        assert values["badChecksums"] == corrupted

        nmea = link["nmea"]
        assert nmea["sentences_ok"] == 4 * EPOCHS
        assert nmea["gga"] == nmea["rmc"] == nmea["vtg"] == nmea["gsa"] == EPOCHS
        assert nmea["bad_checksum"] == corrupted
        assert nmea["frames_in"] == gps.seq and nmea["frames_rejected"] == 0
        assert nmea["foreign_refused"] == 0
        assert link["frames_accepted"] == gps.seq  # every uavbus frame on the shared wire was taken in


def _pvt(k: int) -> bytes:
    """One NAV-PVT epoch from pyubx2 (it scales lat/lon/headMot/pDOP to the wire units itself)."""
    return UBXMessage("NAV", "NAV-PVT", 0, iTOW=100000 + 200 * k, year=2026, month=11, day=26, hour=17, min=1,
                      second=k, fixType=3, numSV=7 + k % 5, lon=-84.9664 - 0.0007 * k, lat=32.3738 + 0.0011 * k,
                      height=150000 + k, hMSL=120000 + 10 * k, hAcc=1500, vAcc=2500, velN=1000 + k, velE=-200,
                      velD=30, gSpeed=5500 + k, headMot=81.5 + k, pDOP=1.8 + k / 100).serialize()


def test_ubx_gps_and_uavbus_share_a_serial_link(program: Path, tmp_path: Path) -> None:
    """The same with a u-blox receiver: pyubx2's NAV-PVT messages on fcs20's serial port (`ubx:` port),
    gcs1 two hops away receives gpsUbx with the values pyubx2 encoded; corrupted copies are counted.

    Then the other way (R1's "writing"): a uavbus frame on the same wire writes gpsUbxCfg; the adapter writes
    a UBX-CFG-RATE onto the pty, which pyubx2 reads back with the values written; the simulated receiver
    answers ACK-ACK (built by pyubx2), and gcs1 reads cfgAcked and the acknowledged rate in gpsUbx."""
    with _GpsLink(program, tmp_path, "ubx:device={dev},baud=115200", "gpsUbx") as gps:
        stream = b""
        for k in range(EPOCHS):
            pvt = _pvt(k)
            bad = bytearray(pvt)
            bad[6 + 28] ^= 0x04  # latitude changed in transit: the checksum no longer matches
            stream += pvt + gps.frame() + NOISE + bytes(bad)
        gps.write(stream)
        want = UBXReader.parse(_pvt(EPOCHS - 1))  # pyubx2 reads its own output
        values = gps.values_at_gcs(lambda v: v["navPvtOk"] == EPOCHS)
        assert values["navPvtOk"] == EPOCHS, values
        assert values["latitudeDeg"] == pytest.approx(want.lat, abs=1e-7)
        assert values["longitudeDeg"] == pytest.approx(want.lon, abs=1e-7)
        assert values["altitudeMsl"] == pytest.approx(want.hMSL / 1000)
        assert values["heightEllipsoid"] == pytest.approx(want.height / 1000)
        assert values["groundSpeedMps"] == pytest.approx(want.gSpeed / 1000)
        assert values["headingDeg"] == pytest.approx(want.headMot, abs=1e-5)
        assert values["pdop"] == pytest.approx(want.pDOP, rel=1e-6)
        assert values["velNorth"] == pytest.approx(want.velN / 1000, rel=1e-6)
        assert values["iTowMs"] == want.iTOW
        assert values["second"] == want.second and values["fixType"] == want.fixType
        assert values["satellitesUsed"] == want.numSV
        assert values["badChecksums"] == EPOCHS
        ubx = gps.link()["ubx"]
        assert ubx["nav_pvt"] == EPOCHS and ubx["bad_checksum"] == EPOCHS, ubx
        assert ubx["frames_in"] == EPOCHS and ubx["frames_rejected"] == 0
        assert gps.link()["frames_accepted"] == EPOCHS
        assert values["cfgSent"] == 0 and not _ubx_messages(bytes(gps.from_node))  # nothing written unasked

        # Writing: gpsUbxCfg arrives as a uavbus frame on the same wire.
        gps.write(gps.frame("gpsUbxCfg", {"measRateMs": 200, "navRate": 1, "timeRef": 1}))
        cfg = _wait_cfg(gps, 1, 200)
        assert (cfg.measRate, cfg.navRate, cfg.timeRef) == (200, 1, 1)
        gps.write(UBXMessage("ACK", "ACK-ACK", 0, clsID=0x06, msgID=0x08).serialize())
        values = gps.values_at_gcs(lambda v: v["cfgAcked"] == 1)
        assert (values["cfgSent"], values["cfgAcked"], values["cfgNaked"]) == (1, 1, 0), values
        assert values["cfgMeasRateMs"] == 200
        assert gps.link()["ubx"]["ack"] == 1 and gps.link()["ubx"]["foreign_out"] == 1

        # A rate the receiver refuses: ACK-NAK is counted, the acknowledged rate stays, nothing is sent again.
        gps.write(gps.frame("gpsUbxCfg", {"measRateMs": 25, "navRate": 1, "timeRef": 1}))
        _wait_cfg(gps, 2, 25)
        gps.write(UBXMessage("ACK", "ACK-NAK", 0, clsID=0x06, msgID=0x08).serialize())
        values = gps.values_at_gcs(lambda v: v["cfgNaked"] == 1)
        assert (values["cfgSent"], values["cfgAcked"], values["cfgNaked"]) == (2, 1, 1), values
        assert values["cfgMeasRateMs"] == 200
        # A receiver that does not answer: after a second the message is counted a time-out and sent again.
        gps.write(gps.frame("gpsUbxCfg", {"measRateMs": 1000, "navRate": 1, "timeRef": 1}))
        _wait_cfg(gps, 3, 1000)
        _wait_cfg(gps, 4, 1000)  # no ACK: sent again
        values = gps.values_at_gcs(lambda v: v["cfgTimeouts"] >= 1 and v["cfgSent"] >= 4)
        assert values["cfgTimeouts"] >= 1 and values["cfgSent"] >= 4 and values["cfgMeasRateMs"] == 200, values


def _wait_cfg(gps: _GpsLink, count: int, rate_ms: int) -> Any:
    """Until the node has written `count` CFG-RATE messages onto the pty; the last (pyubx2's), with `rate_ms`."""
    deadline = time.monotonic() + 10
    while len(cfg := [m for m in _ubx_messages(bytes(gps.from_node)) if m.identity == "CFG-RATE"]) < count:
        assert time.monotonic() < deadline, f"{len(cfg)} CFG-RATE of {count} on the wire: {gps.link()}"
        time.sleep(0.05)
    assert cfg[count - 1].measRate == rate_ms
    return cfg[count - 1]


def _ubx_messages(data: bytes) -> list:
    """The UBX messages pyubx2 finds in what the node wrote onto the pty (uavbus frames in between)."""
    out, i = [], 0
    while (i := data.find(b"\xb5\x62", i)) >= 0 and i + 6 <= len(data):
        n = 8 + int.from_bytes(data[i + 4:i + 6], "little")
        try:
            out.append(UBXReader.parse(data[i:i + n]))
            i += n
        except Exception:  # a sync pair inside a uavbus frame: not a message
            i += 1
    return out
