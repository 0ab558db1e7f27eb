"""Tools against live nodes over real 127.0.0.1 sockets: log play into a fresh node; spy/echo/hz/tables
as console scripts hosting the GCS node of Table 2 and subscribing to a Python vehicle node."""

from __future__ import annotations

import json
import subprocess
import threading
import time
from pathlib import Path

from tools_testutil import UAVBUS

from uavbus import MemLink, Node
from uavbus.logfile import LogReader

ROOT = Path(__file__).resolve().parents[2]
TABLE2 = ROOT / "examples" / "configs" / "table2.json"


def _record_gcs_log(cat, path: Path) -> None:
    now = [1000]
    gcs = Node(cat, config=TABLE2, node="gcs", clock=lambda: now[0])
    vehicle = Node(cat, config=TABLE2, node="primary", clock=lambda: now[0])
    MemLink(gcs, "gcsPortDatalink1", vehicle, "onboardPortDatalink1")
    gps, imu = vehicle.bind("gpsOut"), vehicle.bind("imuOutPrimary")
    gcs.bind("gpsOut"), gcs.bind("imuOutPrimary")
    gcs.record(path)
    gcs.subscribe("gcs1", "gpsOut", source="rmax1ob1", period_ms=50)
    gcs.subscribe("gcs1", "imuOutPrimary", source="rmax1ob1", period_ms=20)
    for k in range(300):
        now[0] += 5
        gps.latitudeDeg, imu.sampleCount = 30.0 + k, k
        vehicle.poll(timeout=0)
        gcs.poll(timeout=0)
    gcs.close()
    vehicle.close()


def test_play_into_a_fresh_node_delivers_the_same_frames_in_order(cat, catalogue_path, tmp_path: Path) -> None:
    log_path = tmp_path / "gcs.ublog"
    _record_gcs_log(cat, log_path)
    want = [(r.header.src_id.rstrip(b"\0").decode(), r.header.seq, cat.instance_by_id(r.header.dir_id).name,
             cat.decode(cat.instance_by_id(r.header.dir_id), r.payload))
            for r in LogReader(log_path) if r.header.admin == 0 and cat.find(r.header.dir_id).name == "gpsOut"]
    assert len(want) >= 20
    fresh = Node(cat, config=TABLE2, node="gcs")
    fresh.bind("gpsOut"), fresh.bind("imuOutPrimary")
    fresh.open_port("gcsPortDatalink1", "tcp:listen=127.0.0.1:0")
    port = fresh.local_port("gcsPortDatalink1")
    got: list[tuple[str, int, str, dict]] = []
    fresh.on_data(lambda m: got.append((m.source, m.seq, m.name, m.value)))
    play = subprocess.Popen([UAVBUS, "log", "play", str(log_path), "--into", f"tcp:connect=127.0.0.1:{port}",
                             "--only", "gpsOut", "--speed", "50"], stdout=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 10
    while len(got) < len(want) and time.monotonic() < deadline:
        fresh.poll(timeout=0.01)
    out, _ = play.communicate(timeout=10)
    # --only plays every frame of the content: its DATA and the ACKs of the subscription's requests.
    played = [r for r in LogReader(log_path) if r.header.dir_id == cat.instance("gpsOut").id]
    assert play.returncode == 0 and json.loads(out)["frames"] == len(played) > len(want)
    assert got == want  # same source, seq, content and values, in the same order; nothing else
    fresh.close()


def _vehicle_server(cat, stop: threading.Event, ready: list[int]) -> None:
    vehicle = Node(cat, config=TABLE2, node="primary")
    gps = vehicle.bind("gpsOut")
    vehicle.open_port("onboardPortDatalink1", "tcp:listen=127.0.0.1:0")
    ready.append(vehicle.local_port("onboardPortDatalink1"))
    k = 0
    while not stop.is_set():
        k += 1
        gps.latitudeDeg, gps.solutionCount = 33.5, k
        vehicle.poll(timeout=0.005)
    vehicle.close()


def _run_tool(cat, catalogue_path: Path, *argv: str) -> subprocess.CompletedProcess[str]:
    stop, ready = threading.Event(), []
    t = threading.Thread(target=_vehicle_server, args=(cat, stop, ready))
    t.start()
    try:
        while not ready:
            time.sleep(0.005)
        return subprocess.run([UAVBUS, *argv, "--config", str(TABLE2), "--node", "gcs", "--catalogue",
                               str(catalogue_path), "--port", f"gcsPortDatalink1=tcp:connect=127.0.0.1:{ready[0]}"],
                              capture_output=True, text=True, timeout=30)
    finally:
        stop.set()
        t.join(10)


def test_echo_live_node(cat, catalogue_path) -> None:
    res = _run_tool(cat, catalogue_path, "echo", "gpsOut", "--subscribe", "gpsOut@rmax1ob1/20", "--count", "5",
                    "--duration", "10")
    assert res.returncode == 0, res.stderr
    lines = [json.loads(x) for x in res.stdout.splitlines()]
    assert len(lines) == 5 and {x["source"] for x in lines} == {"rmax1ob1"}
    assert all(x["value"]["latitudeDeg"] == 33.5 for x in lines)
    assert lines[0]["link"] == "gcsPortDatalink1"
    assert [x["seq"] for x in lines] == sorted(x["seq"] for x in lines)


def test_hz_and_spy_live_node(cat, catalogue_path) -> None:
    res = _run_tool(cat, catalogue_path, "hz", "gpsOut", "--subscribe", "gpsOut@rmax1ob1/20", "--duration", "1.2",
                    "--interval", "5")
    assert res.returncode == 0, res.stderr
    line = res.stdout.strip().splitlines()[-1]
    rate = float(line.split(": ")[1].split(" Hz")[0])
    assert line.startswith("gpsOut from rmax1ob1:") and 35 < rate < 65, line
    res = _run_tool(cat, catalogue_path, "spy", "--subscribe", "gpsOut@rmax1ob1/50", "--duration", "0.8")
    assert res.returncode == 0, res.stderr
    assert any(x.split()[:2] == ["gpsOut", "rmax1ob1"] and "latitudeDeg=33.5" in x for x in res.stdout.splitlines())


def test_tables_live_node(cat, catalogue_path) -> None:
    res = _run_tool(cat, catalogue_path, "tables", "--subscribe", "gpsOut@rmax1ob1/100", "--duration", "0.5")
    assert res.returncode == 0, res.stderr
    assert "publish/subscribe table of gcs1" in res.stdout
    assert any(x.split()[:4] == ["subscription", "gpsOut", "rmax1ob1", "100"] for x in res.stdout.splitlines()), \
        res.stdout
