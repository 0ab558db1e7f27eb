"""Tools that tell the truth (issue 14, item 5), on logs whose every byte the test controls.

- A message is one (source, sequence): copies over a redundant link are duplicates, shown apart and
  never in a rate (hz, spy, log info, log export's `dup` column).
- `uavbus bw` adds up what the links carried; `echo --field` picks members; times are readable.
- Enum members show their constants' names when the catalogue records them, numbers otherwise.
- spy, hz and bw say what to do when they see nothing.
"""

from __future__ import annotations

import csv
import io
import json
import subprocess
from pathlib import Path
from typing import Any

import pytest
from logwriter import write_log
from tools_testutil import ROOT, UAVBUS, gps_value, make_frame

from uavbus.catalogue import Catalogue
from uavbus.tools import live, logcmd

ENUMCAT = ROOT / "tests" / "fixtures" / "enums" / "enumcat.catalogue.json"


def run(*argv: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([UAVBUS, *argv], capture_output=True, text=True, timeout=60)


@pytest.fixture
def redundant_log(tmp_path: Path, cat: Catalogue) -> tuple[Path, list[tuple[bytes, int, int, int]]]:
    """gpsOut at 10 Hz received twice (over both datalinks of a 0x11 mask, 3 ms apart), imuOut once at 50 Hz."""
    records = []
    for k in range(20):
        t = 1000 + 100 * k
        frame = make_frame(cat, "gpsOut", gps_value(cat, k), "rmax1ob1", "gcs1", 100 + k)
        records.append((frame, t, 0, 0))
        records.append((frame, t + 3, 1, 0))  # the same message, the other link
        for j in range(5):
            imu = cat.default("imuOut")
            imu["sampleCount"] = 5 * k + j
            records.append((make_frame(cat, "imuOut", imu, "fcs20", "gcs1", 5000 + 5 * k + j), t + 20 * j, 1, 0))
    path = tmp_path / "redundant.ublog"
    write_log(path, "gcs", {0: "gcsPortDatalink1", 1: "gcsPortDatalink2"}, cat.json_text, records)
    return path, records


def test_rates_count_messages_not_copies(redundant_log: tuple[Path, list]) -> None:
    path, _ = redundant_log
    out = io.StringIO()
    assert live.hz_main(["gpsOut", "--log", str(path)], out=out) == 0
    text = out.getvalue()
    assert "gpsOut from rmax1ob1: 10.00 Hz over 20 messages" in text  # not 20 Hz (or 82 and 101 Hz)
    assert "20 messages in all; 20 duplicates" in text

    spy = io.StringIO()
    assert live.spy_main(["--log", str(path)], out=spy) == 0
    row = next(line.split() for line in spy.getvalue().splitlines() if line.startswith("gpsOut"))
    assert row[:6] == ["gpsOut", "rmax1ob1", "20", "20", "10.00", "119"]  # msgs, dups, Hz, last seq

    info = io.StringIO()
    assert logcmd.main(["info", str(path)], out=info) == 0
    gps = next(line.split() for line in info.getvalue().splitlines() if line.strip().startswith("gpsOut"))
    imu = next(line.split() for line in info.getvalue().splitlines() if line.strip().startswith("imuOut"))
    assert gps == ["gpsOut", "data", "rx", "20", "10.00", "20"]
    assert imu == ["imuOut", "data", "rx", "100", "50.00", "0"]

    exported = io.StringIO()
    assert logcmd.main(["export", str(path), "--csv", "--only", "gpsOut"], out=exported) == 0
    rows = list(csv.DictReader(io.StringIO(exported.getvalue())))
    assert len(rows) == 40 and sum(int(r["dup"]) for r in rows) == 20
    assert [r["link"] for r in rows if r["dup"] == "1"] == ["gcsPortDatalink2"] * 20


def test_bw_adds_up_the_bytes(redundant_log: tuple[Path, list]) -> None:
    path, records = redundant_log
    out = io.StringIO()
    assert live.bw_main(["--log", str(path)], out=out) == 0
    text = out.getvalue()
    span_s = (max(t for _, t, _, _ in records) - min(t for _, t, _, _ in records)) / 1000.0
    total = sum(len(f) for f, _, _, _ in records)
    gps_bytes = sum(len(f) for f, _, _, _ in records[:2])  # one gps message, both copies
    assert f"total: {total / span_s / 1e3:.2f} kB/s" in text
    gps = next(line.split() for line in text.splitlines() if line.startswith("gpsOut"))
    assert gps[:4] == ["gpsOut", "rmax1ob1", f"{20 / span_s:.1f}", f"{20 / span_s:.1f}"]  # msgs/s, dups/s
    assert gps[4:6] == [f"{20 * gps_bytes / span_s / 1e3:.2f}", "kB/s"]
    link2 = next(line.split() for line in text.splitlines() if line.startswith("gcsPortDatalink2"))
    assert link2[1] == f"{100 / span_s:.1f}"  # unique messages on link 2: the 100 imu ones
    only = io.StringIO()
    assert live.bw_main(["imuOut", "--log", str(path)], out=only) == 0
    assert "gpsOut" not in only.getvalue() and "imuOut" in only.getvalue()


def test_echo_field_selection_and_readable_time(redundant_log: tuple[Path, list], cat: Catalogue) -> None:
    path, _ = redundant_log
    out = io.StringIO()
    assert live.echo_main(["gpsOut", "--log", str(path), "--field", "latitudeDeg", "--count", "3"], out=out) == 0
    lines = [json.loads(x) for x in out.getvalue().splitlines()]
    assert [x["value"] for x in lines] == [gps_value(cat, k)["latitudeDeg"] for k in range(3)]
    assert lines[0]["time"] == "2023-11-14T22:13:20.000Z"  # start_unix_ms at node clock 1000
    assert all("duplicate" not in x for x in lines)  # copies left out unless --all
    two = io.StringIO()
    assert live.echo_main(["gpsOut", "--log", str(path), "--field", "status.jammingLevel", "--field",
                           "longitudeDeg", "--count", "1"], out=two) == 0
    assert set(json.loads(two.getvalue())["value"]) == {"status.jammingLevel", "longitudeDeg"}
    every = io.StringIO()
    assert live.echo_main(["gpsOut", "--log", str(path), "--all", "--field", "latitudeDeg"], out=every) == 0
    flags = [json.loads(x).get("duplicate", False) for x in every.getvalue().splitlines()]
    assert len(flags) == 40 and sum(flags) == 20
    bad = run("echo", "gpsOut", "--log", str(path), "--field", "velocity.north")
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1
    assert "has no member 'velocity' (members: time, latitudeDeg," in bad.stderr
    info = run("log", "info", str(path))
    assert "started:    2023-11-14 22:13:20.000 UTC" in info.stdout


def enum_log(tmp_path: Path, catalogue_json: str, name: str) -> Path:
    cat = Catalogue.from_json_text(catalogue_json)
    records = []
    for k, mode in enumerate((0, 3, 4, 9)):  # 9: a value with no constant
        v = cat.default("vehicleState")
        v["tMs"], v["mode"] = k, mode
        v["motors"][1]["lastMode"] = 2
        v["history"] = [1, 3, mode]
        records.append((make_frame(cat, "vehicleState", v, "uav1", "gcs1", k + 1), 1000 + 100 * k, 0, 0))
    path = tmp_path / name
    write_log(path, "gcs", {0: "radio"}, cat.json_text, records)
    return path


def test_enum_names_from_the_catalogue(tmp_path: Path) -> None:
    doc: dict[str, Any] = json.loads(ENUMCAT.read_text())
    path = enum_log(tmp_path, json.dumps(doc), "enums.ublog")
    out = io.StringIO()
    assert live.echo_main(["vehicleState", "--log", str(path)], out=out) == 0
    values = [json.loads(x)["value"] for x in out.getvalue().splitlines()]
    assert [v["mode"] for v in values] == ["MODE_STANDBY", "MODE_AUTO", "MODE_LAND", 9]
    assert values[1]["motors"][1]["lastMode"] == "MODE_HOVER" and values[2]["history"] == [
        "MODE_TAKEOFF", "MODE_AUTO", "MODE_LAND"]
    numeric = io.StringIO()
    assert live.echo_main(["vehicleState", "--log", str(path), "--numeric", "--field", "mode"], out=numeric) == 0
    assert [json.loads(x)["value"] for x in numeric.getvalue().splitlines()] == [0, 3, 4, 9]
    exported = io.StringIO()
    assert logcmd.main(["export", str(path), "--csv"], out=exported) == 0
    rows = list(csv.DictReader(io.StringIO(exported.getvalue())))
    assert [r["mode"] for r in rows] == ["MODE_STANDBY", "MODE_AUTO", "MODE_LAND", "9"]
    assert rows[0]["motors[1].lastMode"] == "MODE_HOVER"
    spy = io.StringIO()
    assert live.spy_main(["--log", str(path), "--width", "400"], out=spy) == 0
    assert "mode=9" in spy.getvalue() and "history[1]=MODE_AUTO" in spy.getvalue()

    # The same log with a catalogue written before enums were recorded: numbers, and nothing breaks.
    del doc["enums"]
    for t in doc["types"]:
        for f in t["fields"]:
            f.pop("enum", None)
    old = enum_log(tmp_path, json.dumps(doc), "old.ublog")
    plain = io.StringIO()
    assert live.echo_main(["vehicleState", "--log", str(old), "--field", "mode"], out=plain) == 0
    assert [json.loads(x)["value"] for x in plain.getvalue().splitlines()] == [0, 3, 4, 9]


def test_spy_says_what_to_do_when_it_sees_nothing(tmp_path: Path, cat: Catalogue, catalogue_path: Path) -> None:
    # A log with administration frames only.
    ack = make_frame(cat, "gpsOut", {}, "rmax1ob1", "gcs1", 7, admin=5)
    path = tmp_path / "admin-only.ublog"
    write_log(path, "gcs", {0: "gcsPortDatalink1"}, cat.json_text, [(ack, 1000, 0, 0), (ack, 1001, 0, 0)])
    res = run("spy", "--log", str(path))
    assert res.returncode == 0
    assert "the log holds 2 frames, none of them DATA (2 administration frames)" in res.stdout

    # A live node that nobody sends to: the hint names --subscribe and the state of its port.
    res = run("spy", "--config", str(ROOT / "examples" / "configs" / "table2.json"), "--node", "gcs",
              "--catalogue", str(catalogue_path), "--port", "gcsPortDatalink1=udp:bind=127.0.0.1:0",
              "--duration", "0.3", "--interval", "10")
    assert res.returncode == 0, res.stderr
    assert "-- 0 directories seen --" in res.stdout
    assert "no DATA received yet (0 frames in all" in res.stdout
    assert "--subscribe gpsOut@rmax1ob1/100" in res.stdout
    assert "port gcsPortDatalink1 (udp:bind=127.0.0.1:" in res.stdout and "no peer known yet" in res.stdout
    hz = run("hz", "gpsOut", "--log", str(path))
    assert "gpsOut: no messages seen" in hz.stdout and "none of them DATA" in hz.stdout


def test_echo_shows_the_units_the_headers_document(redundant_log: tuple[Path, list]) -> None:
    """imu.h: `double p; /**< [rad/s] roll rate, body x */`, `vector3d_t specificForce; /* m/s^2, body axes */`."""
    path, _ = redundant_log
    out = io.StringIO()
    assert live.echo_main(["imuOut", "--log", str(path), "--field", "p", "--field", "sampleCount", "--count", "1"],
                          out=out) == 0
    line = json.loads(out.getvalue())
    assert line["units"] == {"p": "rad/s"}  # sampleCount has none
    whole = io.StringIO()
    assert live.echo_main(["imuOut", "--log", str(path), "--count", "1"], out=whole) == 0
    units = json.loads(whole.getvalue())["units"]
    assert units["specificForce.x"] == "m/s^2" and units["temperatureC"] == "degC" and "time.seconds" not in units
    gps = io.StringIO()
    assert live.echo_main(["gpsOut", "--log", str(path), "--count", "1"], out=gps) == 0
    assert "units" not in json.loads(gps.getvalue())  # gps.h documents no unit
