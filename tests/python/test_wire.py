"""The wire issue from Python (one C router under cffi): compact links over real UDP sockets and over a pty
null-modem running at a 57,600-baud radio's byte rate, and a directory larger than the payload limit sent in
fragments over a 255-byte-MTU compact link."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from binding_testutil import TABLE2, FakeClock, Generated, _generate, run_nodes
from uavbus import MemLink, Node
from uavbus.sim.nullmodem import NullModem

pytestmark = pytest.mark.timeout(60)


def wait_for(nodes: list[Node], cond, seconds: float = 5.0) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        for n in nodes:
            n.poll(0.002)
        if cond():
            return
    raise AssertionError("condition not met within the time limit")


def test_compact_udp_link_delivers_with_short_headers(flightsw: Generated) -> None:
    gcs = Node(flightsw.catalogue, config=TABLE2, node="gcs")
    air = Node(flightsw.catalogue, config=TABLE2, node="primary")
    try:
        air.open_port("onboardPortDatalink1", "udp:bind=127.0.0.1:0,accept=learn,encoding=compact,mtu=255")
        pa = air.local_port("onboardPortDatalink1")
        gcs.open_port("gcsPortDatalink1", f"udp:bind=127.0.0.1:0,peer=127.0.0.1:{pa},encoding=compact,mtu=255")
        assert gcs.port_info("gcsPortDatalink1")["spec"].endswith(",encoding=compact,mtu=255")
        gps = air.bind("gpsOut")
        gps.altitudeMsl = 321.5
        got = []
        gcs.on_data(got.append)
        gcs.subscribe("gcs1", "gpsOut", source="rmax1ob1", period_ms=10)
        wait_for([gcs, air], lambda: len(got) >= 20 and air.link_counters()["onboardPortDatalink1"].get("agreed"))
        assert got[-1].value["altitudeMsl"] == 321.5 and got[-1].source == "rmax1ob1"
        out = air.link_counters()["onboardPortDatalink1"]
        assert out["encoding"] == "compact" and out["mtu"] == 255
        c = out["compact"]
        # Once agreed, a DATA frame costs its payload plus 11 bytes instead of 64.
        size = flightsw.catalogue.instance("gpsOut").type.packed_size
        assert c["tx_bytes"] < c["tx_full_bytes"]
        assert c["rejected"]["bad_crc"] == 0 and c["rejected"]["no_dictionary"] == 0
        # Both ends started once: first contact is no dictionary change, and nothing was refused (issue 29).
        assert c["dict_changes"] == 0 and c["dict_limited"] == 0
        before = dict(c)
        n0 = len(got)
        wait_for([gcs, air], lambda: len(got) >= n0 + 10)
        c = air.link_counters()["onboardPortDatalink1"]["compact"]
        frames = c["tx_frames"] - before["tx_frames"]
        per_frame = (c["tx_bytes"] - before["tx_bytes"]) / frames
        assert per_frame <= size + 11 + 12  # a LINK_HELLO round or a 32-bit sequence may fall in the window
    finally:
        gcs.close()
        air.close()


def test_compact_serial_link_at_radio_rate(flightsw: Generated) -> None:
    """A 57,600-baud radio on loopback: a pty pair relaying 5,760 bytes/s each way. The sender offers far more;
    the radio carries its rate, flow control pushes back on the sender, nothing arrives corrupted."""
    with NullModem("radio", byte_rate=5760, buffer_bytes=512) as nm:
        gcs = Node(flightsw.catalogue, config=TABLE2, node="gcs")
        air = Node(flightsw.catalogue, config=TABLE2, node="primary")
        try:
            air.open_port("onboardPortDatalink1", f"serial:device={nm.path_a},baud=57600,encoding=compact")
            gcs.open_port("gcsPortDatalink1", f"serial:device={nm.path_b},baud=57600,encoding=compact")
            gps = air.bind("gpsOut")
            gcs.bind("gpsOut")
            got = []
            gcs.on_data(got.append)
            wait_for([gcs, air], lambda: air.link_counters()["onboardPortDatalink1"].get("agreed", False))
            pub = air.publisher("rmax1ob1", "gpsOut", "gcs1")
            start = time.monotonic()
            relayed0 = nm.snapshot()["relayed"]["a>b"]
            sent = 0
            while time.monotonic() - start < 1.5:
                gps.altitudeMsl = float(sent)
                pub.send()
                sent += 1
                for n in (air, gcs):
                    n.poll(0)
            end = time.monotonic() + 0.2
            while time.monotonic() < end:  # what is under way arrives
                for n in (air, gcs):
                    n.poll(0.002)
            elapsed = time.monotonic() - start
            relayed = nm.snapshot()["relayed"]["a>b"] - relayed0
            assert relayed <= 5760 * elapsed + 512 + 64  # never faster than the radio (plus its buffer)
            assert relayed >= 5760 * elapsed * 0.3       # and it did carry traffic (loose: a loaded machine)
            assert sent > 2 * len(got) > 0               # the sender offered more than the radio carried
            link = gcs.link_counters()["gcsPortDatalink1"]
            assert link["bad_frames"]["bad_crc"] == 0 and link["compact"]["rejected"]["bad_crc"] == 0
            vals = [m.value["altitudeMsl"] for m in got]
            assert vals == sorted(vals)                  # in order, each a value that was sent
            assert air.counters()["drops"]["backpressure"] > 0
        finally:
            gcs.close()
            air.close()


BIG_HEADER = """\
#include <stdint.h>
typedef struct { uint32_t version; uint8_t cells[9000]; } mapTile_t;
typedef struct { float x; float y; } smallPos_t;
extern mapTile_t mapTile;
extern smallPos_t smallPos;
"""


@pytest.fixture(scope="module")
def bigcat(tmp_path_factory: pytest.TempPathFactory) -> Generated:
    src = tmp_path_factory.mktemp("big") / "big.h"
    src.write_text(BIG_HEADER, encoding="utf-8")
    return _generate(tmp_path_factory.mktemp("gen"), "bigcat", [src], [])


def test_directory_above_the_payload_limit_in_fragments(bigcat: Generated) -> None:
    clock = FakeClock()
    a = Node(bigcat.catalogue, clock=clock)
    b = Node(bigcat.catalogue, clock=clock)
    for n, me, other in ((a, "a", "b"), (b, "b", "a")):
        n.add_entity(me, local=True)
        n.add_entity(other)
        n.add_link(me, 0, "radio")
        n.set_mask(me, other, 1)
        n.wire.set_encoding("radio", "compact")
        n.wire.set_mtu("radio", 255)
    MemLink(a, "radio", b, "radio")
    tile = a.bind("mapTile")
    b.bind("mapTile")
    got = []
    b.on_data(got.append)
    run_nodes([a, b], clock, 50)
    for version in (1, 2):
        tile.version = version
        tile.cells[0] = version
        tile.cells[8999] = 255 - version
        a.send("a", "mapTile", "b")
        run_nodes([a, b], clock, 100)
    assert [m.value["version"] for m in got] == [1, 2]
    assert got[-1].raw == tile.raw
    frag = a.wire.fragment_counters()
    assert frag["tx_transfers"] == 2 and frag["tx_fragments"] >= 2 * 9004 // 240
    assert b.wire.fragment_counters()["rx_complete"] == 2
    link = a.link_counters()["radio"]
    assert link["bytes_out"] <= 255 * link["frames_out"]
    with pytest.raises(Exception, match="64..65535"):
        a.wire.set_mtu("radio", 10)
    a.close()
    b.close()


def test_compact_frames_are_not_larger_than_mavlink2(tmp_path: Path) -> None:
    """Issue #15's size goal, as bytes (not time): the three benchmark messages, every field non-zero, as the
    compact link sends them (C encoder, COBS, delimiter) against pymavlink's MAVLink 2 frames, unsigned and
    signed; the full frame keeps the paper's 64-byte header. bench/wire_bench.py is the code make bench
    measures with (figure 9a)."""
    import importlib.util
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[2]
    out = tmp_path / "gen"
    subprocess.run([str(Path(sys.executable).with_name("uavbus")), "gen", str(root / "bench/catalogue/bench_msgs.h"), "--name",
                    "benchcat", "-o", str(out)], check=True, capture_output=True)
    spec = importlib.util.spec_from_file_location("wire_bench", root / "bench" / "wire_bench.py")
    assert spec is not None and spec.loader is not None
    wb = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(wb)
    from uavbus import Catalogue

    cat = Catalogue.load(out / "benchcat.catalogue.json")
    for label in ("ATTITUDE", "GPS_RAW_INT", "HIGHRES_IMU"):
        s = wb.streams(cat, label)
        size = {form: len(frames[1]) for form, frames in s.items()}
        payload = size["full"] - 64
        assert size["full_signed"] == size["full"] + 11, label
        assert size["compact"] <= size["mavlink2"], (label, size)
        assert size["compact_signed"] <= size["mavlink2_signed"], (label, size)
        assert size["compact"] <= payload + 11 and size["compact_signed"] <= payload + 22, (label, size)
        # Every 128th frame carries the whole 32-bit sequence: ctl1 (SEQ32) and two more sequence bytes.
        assert len(s["compact"][0]) == size["compact"] + 3, label
