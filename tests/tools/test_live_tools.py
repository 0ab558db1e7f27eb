"""spy / echo / hz on logs (whole and followed while written)."""

from __future__ import annotations

import io
import json
import subprocess
import threading
import time
from pathlib import Path

from tools_testutil import UAVBUS
from logwriter import record

from uavbus.logfile import LogReader
from uavbus.tools import live


def test_spy_on_log(sample_log) -> None:
    path, _, _ = sample_log()
    res = subprocess.run([UAVBUS, "spy", "--log", str(path)], capture_output=True, text=True, timeout=30)
    assert res.returncode == 0, res.stderr
    lines = res.stdout.splitlines()
    assert lines[0] == "-- 2 directories seen --"
    gps = next(x for x in lines if x.startswith("gpsOut"))
    imu = next(x for x in lines if x.startswith("imuOut"))
    assert gps.split()[:6] == ["gpsOut", "rmax1ob1", "20", "0", "10.00", "20"]  # msgs, dups, Hz, seq
    assert "latitudeDeg=33.7002 longitudeDeg=-89.15" in gps
    assert imu.split()[:5] == ["imuOut", "fcs20", "100", "0", "50.00"]


def test_echo_on_log_gives_decoded_values(sample_log) -> None:
    path, _, expected = sample_log()
    out = io.StringIO()
    assert live.echo_main(["gpsOut", "--log", str(path), "--count", "5"], out=out) == 0
    lines = [json.loads(x) for x in out.getvalue().splitlines()]
    assert [x["value"] for x in lines] == [e["shown"] for e in expected[:5]]
    assert [x["seq"] for x in lines] == [1, 2, 3, 4, 5]
    assert {x["source"] for x in lines} == {"rmax1ob1"}


def test_echo_unknown_name(sample_log) -> None:
    path, _, _ = sample_log()
    res = subprocess.run([UAVBUS, "echo", "gpsOutX", "--log", str(path)], capture_output=True, text=True, timeout=30)
    assert res.returncode != 0 and "gpsOutX: no such content in catalogue 'flightsw'" in res.stderr


def test_hz_on_log(sample_log) -> None:
    path, _, _ = sample_log()
    out = io.StringIO()
    assert live.hz_main(["imuOut", "--log", str(path), "--window", "10"], out=out) == 0
    assert out.getvalue().strip() == ("imuOut from fcs20: 50.00 Hz over 10 messages, gap min 20 ms max 20 ms "
                                      "(100 messages in all; no duplicates)")


def test_echo_follows_a_growing_log(sample_log, tmp_path: Path) -> None:
    _, data, expected = sample_log(n_gps=4)
    src = LogReader(tmp_path / "gcs.ublog")
    path = tmp_path / "live.ublog"

    def writer() -> None:
        with open(path, "wb") as f:
            f.write(data[:src.header.size]); f.flush()
            for r in src.records():
                time.sleep(0.002)
                f.write(record(r.frame, r.t_ms, r.link_id, 0 if r.dir == "rx" else 1, seq=r.seq)); f.flush()

    t = threading.Thread(target=writer)
    t.start()
    out = io.StringIO()
    assert live.echo_main(["gpsOut", "--log", str(path), "--follow", "--count", "4", "--duration", "10"],
                          out=out) == 0
    t.join()
    lines = [json.loads(x) for x in out.getvalue().splitlines()]
    assert [x["value"] for x in lines] == [e["shown"] for e in expected]
