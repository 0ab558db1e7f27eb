"""`uavbus log info|export|play`: console script and main(argv)."""

from __future__ import annotations

import csv
import io
import json
import socket
import subprocess
import threading
from pathlib import Path

from tools_testutil import UAVBUS

from uavbus.logfile import LogReader
from uavbus.tools import logcmd


def run(*argv: str) -> str:
    out = io.StringIO()
    assert logcmd.main(list(argv), out=out) == 0
    return out.getvalue()


def test_info_console_script(sample_log) -> None:
    path, _, _ = sample_log()
    res = subprocess.run([UAVBUS, "log", "info", str(path)], capture_output=True, text=True, timeout=30)
    assert res.returncode == 0, res.stderr
    text = res.stdout
    assert "node:       gcs" in text
    assert "catalogue:  flightsw" in text
    assert "0=gcsPortDatalink1, 1=gcsPortDatalink2" in text
    assert "records:    121" in text
    assert ("time span:  1000 .. 5000 ms (4.000 s): 2023-11-14 22:13:20.000 UTC .. 2023-11-14 22:13:24.000 UTC"
            ) in text
    assert "gcsPortDatalink1         rx  20" in text and "gcsPortDatalink2         rx  100" in text
    assert "gcsPortDatalink1         tx  1" in text
    # gpsOut: 20 frames at 100 ms = 10 Hz; imuOut: 100 frames, 50 Hz on average.
    assert any(line.split()[:5] == ["gpsOut", "data", "rx", "20", "10.00"] for line in text.splitlines())
    assert "damage:     none (nothing skipped, nothing missing)" in text


def test_info_reports_truncated_tail(sample_log, tmp_path: Path) -> None:
    _, data, _ = sample_log()
    cut = tmp_path / "cut.ublog"
    cut.write_bytes(data[:-10])
    text = run("info", str(cut))
    assert "records:    120" in text
    assert "truncated tail" in text and "ignored " in text


def test_info_on_a_log_whose_header_is_lost_takes_catalogue(sample_log, catalogue_path, tmp_path: Path) -> None:
    """Both copies of the header damaged (the same byte of each catalogue copy): `log info` says what to do;
    with --catalogue it reads every record and says the header is lost. export takes it too."""
    path, data, expected = sample_log()
    size = LogReader(path).header.size
    bad = bytearray(data)
    bad[size // 2 - 5] ^= 0x08
    bad[size - 5] ^= 0x08
    lost = tmp_path / "lost.ublog"
    lost.write_bytes(bytes(bad))
    res = subprocess.run([UAVBUS, "log", "info", str(lost)], capture_output=True, text=True, timeout=30)
    assert res.returncode == 3
    assert "header CRC mismatch: both copies" in res.stderr and "--catalogue FILE" in res.stderr
    text = run("info", str(lost), "--catalogue", str(catalogue_path))
    assert "header:     both copies of the header are lost" in text
    assert "flightsw (id scheme" in text and f"--catalogue {catalogue_path}" in text
    assert "records:    121" in text and "damage:     none" in text
    rows = [json.loads(line) for line in run("export", str(lost), "--jsonl", "--catalogue",
                                             str(catalogue_path)).splitlines()]
    assert [r["value"] for r in rows if r["name"] == "gpsOut"] == [e["shown"] for e in expected]
    # One copy damaged: info says which, and reads as before.
    bad[size - 5] ^= 0x08
    lost.write_bytes(bytes(bad))
    text = run("info", str(lost))
    assert "header:     header primary copy damaged, spare used" in text and "records:    121" in text


def test_export_jsonl_matches_encoded_values(sample_log) -> None:
    path, _, expected = sample_log()
    lines = [json.loads(x) for x in run("export", str(path), "--jsonl", "--only", "gpsOut").splitlines()]
    assert [(x["name"], x["t_ms"], x["seq"], x["source"], x["dest"], x["link"]) for x in lines] == \
        [("gpsOut", e["t_ms"], e["seq"], "rmax1ob1", "gcs1", "gcsPortDatalink1") for e in expected]
    assert [x["value"] for x in lines] == [e["shown"] for e in expected]
    every = run("export", str(path), "--jsonl").splitlines()
    assert len(every) == 120  # DATA only by default
    with_admin = [json.loads(x) for x in run("export", str(path), "--jsonl", "--admin").splitlines()]
    assert with_admin[-1]["kind"] == "ack" and "value" not in with_admin[-1]


def test_export_csv_union_of_columns(sample_log, tmp_path: Path) -> None:
    path, _, expected = sample_log()
    out = tmp_path / "x.csv"
    run("export", str(path), "--csv", "-o", str(out))
    rows = list(csv.DictReader(out.open()))
    assert len(rows) == 120
    gps = [r for r in rows if r["name"] == "gpsOut"]
    assert [float(r["latitudeDeg"]) for r in gps] == [e["value"]["latitudeDeg"] for e in expected]
    assert [int(r["status.jammingLevel"]) for r in gps] == [0] * 20
    imu = [r for r in rows if r["name"] == "imuOut"]
    assert imu[0]["latitudeDeg"] == "" and imu[7]["sampleCount"] == "1"
    assert "specificForce.x" in rows[0]


def test_export_only_unknown_name_says_what_to_do(sample_log) -> None:
    path, _, _ = sample_log()
    res = subprocess.run([UAVBUS, "log", "export", str(path), "--jsonl", "--only", "gpsOutt"],
                         capture_output=True, text=True, timeout=30)
    assert res.returncode != 0 and "gpsOutt: not in the log's catalogue 'flightsw'" in res.stderr


def test_play_udp_sends_the_same_frames_in_order(sample_log) -> None:
    path, _, _ = sample_log()
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.bind(("127.0.0.1", 0))
    rx.settimeout(5)
    port = rx.getsockname()[1]
    text = run("play", str(path), "--into", f"udp:peer=127.0.0.1:{port}", "--only", "gpsOut", "--speed", "20")
    assert json.loads(text)["frames"] == 20
    got = [rx.recv(2048) for _ in range(20)]
    want = [r.frame for r in LogReader(path) if r.dir == "rx" and r.header.payload_size and
            r.header.dir_id == got[0][8:24]]
    assert got == want
    rx.close()


def test_play_tcp_paced_by_timestamps(sample_log) -> None:
    path, _, _ = sample_log(n_gps=5)
    srv = socket.create_server(("127.0.0.1", 0))
    port = srv.getsockname()[1]
    chunks: list[bytes] = []

    def accept() -> None:
        conn, _ = srv.accept()
        conn.settimeout(5)
        while data := conn.recv(65536):
            chunks.append(data)
        conn.close()

    t = threading.Thread(target=accept)
    t.start()
    sleeps: list[float] = []
    now = [0.0]

    def sleep(s: float) -> None:
        sleeps.append(s)
        now[0] += s

    args = logcmd.build_parser().parse_args(["play", str(path), "--into", f"tcp:connect=127.0.0.1:{port}",
                                             "--speed", "2"])
    assert logcmd.cmd_play(args, io.StringIO(), sleep=sleep, clock=lambda: now[0]) == 0
    t.join(5)
    srv.close()
    rx = [r.frame for r in LogReader(path) if r.dir == "rx"]
    assert b"".join(chunks) == b"".join(rx)
    # 5 gps periods of 100 ms, last imu at +480 ms: 480 ms of log time at speed 2 = 0.24 s.
    assert abs(sum(sleeps) - 0.24) < 1e-9


def test_play_bad_spec(sample_log) -> None:
    path, _, _ = sample_log(n_gps=1)
    res = subprocess.run([UAVBUS, "log", "play", str(path), "--into", "udp:host=1"], capture_output=True, text=True,
                         timeout=30)
    assert res.returncode != 0 and "'host=1' is not a udp parameter" in res.stderr
