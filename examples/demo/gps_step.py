"""`make demo`'s GPS step (issue #24): a simulated COTS GPS on fcs20's serial port becomes a directory at gcs1.

Table 2 again, unsigned, with one more link at fcs20 for its GPS receiver: a pty whose far end is the receiver,
simulated here with pynmea2 (PyPI), which writes GGA, RMC, VTG and GSA at 5 Hz and, every third epoch, a GGA
corrupted in transit; a uavbus frame shares the wire every epoch. fcs20's `uavbus_node` runs the port
`nmea:device=...` (programs/node/adapter_nmea.c; no other program), and gcs1 subscribes to `gpsNmea` two hops
away (gcs1 - rmax1ob1 - fcs20, over UDP). Checks: gcs1 holds the last fix pynmea2 encoded (as pynmea2 reads it
back) and receives it at the receiver's rate (its subscription asks for the receiver's period); every good
sentence was merged and every corrupted one counted, never merged; every uavbus frame on the shared wire was
taken in; the nodes exit cleanly. About two seconds.

Returns summary.json's "gps" object: {"epochs", "rate_hz", "sensor_hz", "sentences_ok", "bad_checksum", "frames_in", "at_gcs1": {...}}.
"""

from __future__ import annotations

import json
import os
import time
import tty
from pathlib import Path
from typing import Any, Callable

import pynmea2

from uavbus._bindings.ub_catalogue import ub_entity_id
from uavbus._bindings.ub_frame import FrameHeader, ub_frame_finish
from uavbus.catalogue import Catalogue
from uavbus.sim.hitl import catalogue_for
from uavbus.sim.portalloc import PortAllocator
from uavbus.sim.process import ProcessGroup

TABLE2 = Path(__file__).resolve().parents[2] / "examples" / "configs" / "table2.json"
EPOCH_S = 0.2  # the receiver's 5 Hz


def _epoch(k: int) -> list[pynmea2.NMEASentence]:
    lat, lon = 32.3738 + 0.0011 * k, -84.9664 - 0.0007 * k
    la = f"{int(lat):02d}{(lat - int(lat)) * 60:07.4f}"
    lo = f"{int(-lon):03d}{(-lon - int(-lon)) * 60:07.4f}"
    t = f"1230{k:02d}.00"
    return [pynmea2.GGA("GP", "GGA", (t, la, "N", lo, "W", "1", "09", "0.9", f"{120 + k:.1f}", "M", "-29.4", "M",
                                      "", "")),
            pynmea2.RMC("GP", "RMC", (t, "A", la, "N", lo, "W", f"{10 + k:.1f}", f"{80 + k:.1f}", "261126", "", "")),
            pynmea2.VTG("GP", "VTG", (f"{81.5 + k:.1f}", "T", "", "M", f"{10.5 + k:.1f}", "N", "19.4", "K")),
            pynmea2.GSA("GP", "GSA", ("A", "3", "04", "05", "09", "12", "24", "", "", "", "", "", "", "", "1.8",
                                      "1.1", "1.4"))]


def _corrupt(sentence: str) -> bytes:
    i = sentence.index(",", sentence.index(",") + 1) + 3  # a latitude digit changed: the checksum fails
    return (sentence[:i] + ("1" if sentence[i] != "1" else "2") + sentence[i + 1:] + "\r\n").encode()


def gps_part(out: Path, program: Path, check: Callable[[str, bool, str], bool], say: Callable[[str], None],
             short: bool = False) -> dict[str, Any]:
    epochs = 6 if short else 10
    say("\n== GPS step (issue #24): a simulated COTS GPS on fcs20's serial port, gpsNmea at gcs1 two hops away")
    cat = Catalogue.load(str(catalogue_for(program)))
    cfg = json.loads(TABLE2.read_text())
    next(e for e in cfg["entities"] if e["name"] == "fcs20")["links"].append("backupPortGps")
    config = out / "table2_gps.json"
    config.write_text(json.dumps(cfg))
    alloc = PortAllocator()
    p_primary, p_gcs, p_relay, p_backup = (alloc.port() for _ in range(4))
    master, slave = os.openpty()
    tty.setraw(slave)
    dev = Path(f"/tmp/ub_demo_gps_{os.getpid()}")  # short: a device path has at most 63 characters
    dev.unlink(missing_ok=True)
    dev.symlink_to(os.ttyname(slave))
    inst = cat.instance("fcsSet")
    result: dict[str, Any] = {"epochs": epochs}
    try:
        with ProcessGroup() as g:
            fcs20 = g.spawn([str(program), "--config", str(config), "--node", "backup",
                             "--port", f"onboardPortDatalink1=udp:bind=127.0.0.1:{p_backup},peer=127.0.0.1:{p_relay}",
                             "--port", f"backupPortGps=nmea:device={dev},baud=9600", "--stats-ms", "0"], "fcs20")
            g.spawn([str(program), "--config", str(config), "--node", "primary",
                     "--port", f"onboardPortDatalink1=udp:bind=127.0.0.1:{p_primary},peer=127.0.0.1:{p_gcs}",
                     "--port", f"onboardPortRelay=udp:bind=127.0.0.1:{p_relay},peer=127.0.0.1:{p_backup}",
                     "--stats-ms", "0"], "rmax1ob1")
            gcs = g.spawn([str(program), "--config", str(config), "--node", "gcs",
                           "--port", f"gcsPortDatalink1=udp:bind=127.0.0.1:{p_gcs},peer=127.0.0.1:{p_primary}",
                           "--subscribe", "gcs1:gpsNmea@fcs20/200", "--stats-ms", "0"], "gcs1")
            say(f"  the receiver (pynmea2) writes GGA, RMC, VTG, GSA at 5 Hz into {dev} for {epochs * EPOCH_S:.1f} s, "
                "a corrupted GGA every third epoch and a uavbus frame every epoch; fcs20 runs nmea:device=...")
            def received() -> int:  # gcs1's subscription row: gpsNmea frames it took in
                rows = gcs.request_stats()["pubsub"].get("gcs1", [])
                return sum(r["frames"] for r in rows if r["content"] == "gpsNmea")

            written = corrupted = 0
            got0 = received()
            last: list[pynmea2.NMEASentence] = []
            t0 = time.monotonic()
            for k in range(epochs):
                last = _epoch(k)
                chunk = b"".join((str(s) + "\r\n").encode() for s in last)
                chunk += ub_frame_finish(FrameHeader(dir_id=inst.id, dest_id=ub_entity_id("fcs20"),
                                                     src_id=ub_entity_id("rmax1ob2"), admin=0, seq=k + 1,
                                                     fingerprint=inst.type.fingerprint), bytes(inst.type.packed_size))
                if k % 3 == 2:
                    chunk += _corrupt(str(last[0]))
                    corrupted += 1
                os.write(master, chunk)
                written += len(chunk)
                time.sleep(max(0.0, t0 + (k + 1) * EPOCH_S - time.monotonic()))
            got = received() - got0
            window = time.monotonic() - t0
            deadline = time.monotonic() + 5
            while (link := fcs20.request_stats()["links"]["backupPortGps"])["bytes_in"] < written:
                if time.monotonic() > deadline:
                    break
                time.sleep(0.05)
            values: dict[str, Any] = {}
            deadline = time.monotonic() + 5
            while time.monotonic() < deadline:  # the next publication (every 200 ms) carries the last fix
                m = gcs.mark()
                gcs.send("dump gpsNmea")
                values = cat.decode("gpsNmea", bytes.fromhex(gcs.wait_event("dump", 3.0, since=m)["packed"]))
                if values["sentencesOk"] == 4 * epochs:
                    break
                time.sleep(0.1)
            gga = pynmea2.parse(str(last[0]))
            nmea = link["nmea"]
            result.update(rate_hz=got / window, sensor_hz=1 / EPOCH_S, sentences_ok=nmea["sentences_ok"], bad_checksum=nmea["bad_checksum"],
                          frames_in=nmea["frames_in"],
                          at_gcs1={k: values.get(k) for k in ("latitudeDeg", "longitudeDeg", "altitudeMsl",
                                                              "sentencesOk", "badChecksums")})
            check("GPS fix at gcs1: the values pynmea2 encoded",
                  abs(values.get("latitudeDeg", 0) - float(gga.latitude)) < 1e-9
                  and abs(values.get("longitudeDeg", 0) - float(gga.longitude)) < 1e-9
                  and abs(values.get("altitudeMsl", 0) - float(gga.altitude)) < 1e-6,
                  f"gcs1 {values.get('latitudeDeg')}, {values.get('longitudeDeg')}, {values.get('altitudeMsl')} m; "
                  f"pynmea2 {gga.latitude:.6f}, {gga.longitude:.6f}, {gga.altitude} m (2 hops)")
            check("GPS sentences: every good one merged, every corrupted one counted",
                  values.get("sentencesOk") == 4 * epochs and values.get("badChecksums") == corrupted
                  and nmea["bad_checksum"] == corrupted,
                  f"{values.get('sentencesOk')} of {4 * epochs} merged, {nmea['bad_checksum']} of {corrupted} "
                  "corrupted counted")
            # The subscription asks for the sensor's period: gcs1 receives gpsNmea at the sensor's rate (one
            # publication either way is the sampling of two counters at the window's ends; 10 % for a loaded machine).
            check("GPS at gcs1 at the sensor's rate", abs(got - window / EPOCH_S) <= 1 + 0.1 * window / EPOCH_S,
                  f"{got} publications in {window:.2f} s = {got / window:.2f} Hz, the receiver's {1 / EPOCH_S:g} Hz")
            check("GPS wire shared: every uavbus frame taken in", nmea["frames_in"] == epochs
                  and nmea["frames_rejected"] == 0 and link["frames_accepted"] == epochs,
                  f"{nmea['frames_in']} of {epochs} frames, {nmea['frames_rejected']} rejected")
            status = g.close()
        check("GPS step: all C nodes exit cleanly", all(s == 0 for s in status.values()),
              ", ".join(f"{n}: exit {s}" for n, s in status.items()))
    finally:
        dev.unlink(missing_ok=True)
        os.close(master)
        os.close(slave)
    return result
