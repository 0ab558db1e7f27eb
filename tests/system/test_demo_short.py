"""`make demo` in its short mode, inside `make test` (issue 6 acceptance)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.timeout(90)
def test_demo_short_mode_passes_and_writes_its_outputs(program: Path, tmp_path: Path) -> None:
    r = subprocess.run([sys.executable, str(REPO / "examples/demo/hitl_demo.py"), "--short", "--out", str(tmp_path),
                        "--program", str(program)], capture_output=True, text=True, timeout=80)
    assert r.returncode == 0, r.stdout[-4000:] + r.stderr[-2000:]
    doc = json.loads((tmp_path / "summary.json").read_text())
    rows = {(row["name"], row["source"]): row for row in doc["rows"]}
    imu, gps = rows[("imuOut", "fcs20")], rows[("gpsOut", "rmax1ob1")]
    assert imu["hops"] == 2 and gps["hops"] == 1
    for row in (imu, gps):
        assert abs(row["achieved_hz"] - row["requested_hz"]) <= 0.1 * row["requested_hz"]
        assert set(row) >= {"name", "source", "destination", "hops", "requested_hz", "achieved_hz",
                            "transport_p50_ms", "transport_p99_ms", "age_p50_ms", "age_p99_ms", "delivered",
                            "duplicates", "dropped"}
        # Transport latency (send -> arrival of the same frame) is measured apart from data age (which adds
        # the value's staleness), and on the 0x11 pair every second copy is an expected duplicate, not a loss.
        assert row["transport_p50_ms"] is not None and row["age_p50_ms"] is not None
        # (transport is timed from the sender's log, whose clock has 1 ms steps: +-0.5 ms)
        assert -0.5 <= row["transport_p50_ms"] <= row["age_p50_ms"] + 0.5
        assert sum(row["duplicates"].values()) > 0
        assert all("duplicate" not in reasons for link, reasons in row["dropped"].items()
                   if link.startswith("gcs1:")), row["dropped"]
    assert (tmp_path / "imu.png").stat().st_size > 1000
    # signed, with a reduced attacker step (issue 11 item 9): every attack refused and counted, rates kept
    sec = doc["security"]
    assert sec["signed"] and len(sec["attacks"]) >= 5
    for attack in sec["attacks"]:
        assert set(attack) >= {"name", "sent", "accepted", "dropped_as"}
        assert attack["accepted"] == 0 and sum(attack["dropped_as"].values()) == attack["sent"] > 0, attack
    assert {c["name"] for c in doc["checks"] if c["ok"]} >= {f"attack refused: {a['name']}" for a in sec["attacks"]}
    # issue 23 item 5: a group-key holder's lockout frames (counter 2^48-2: in fcs20's name, then in gcs1's and
    # rmax1ob1's) are refused and silence nobody
    assert len(sec["insider"]) == 2
    for lockout in sec["insider"]:
        assert lockout["accepted"] == 0 and lockout["dropped_as"] == {"counter_jump": lockout["sent"]}, lockout
    assert "rate kept after the lockout frame: imuOut" in {c["name"] for c in doc["checks"] if c["ok"]}
    # the variable browser over the bus (issue 16): a directory no flow publishes, read 2 hops away; a rate changed
    browser, held = doc["browser"], {c["name"] for c in doc["checks"] if c["ok"]}
    assert {"browser: read airData from fcs20", "browser: change a publication rate"} <= held
    assert browser["read"]["hops"] == 2 and browser["read"]["rows_publishing_it"] == 0
    assert "staticPressurePa" in browser["read"]["fields"] and browser["read"]["rtt_ms"] > 0
    assert browser["rate"]["period_ms"] == [100, 50]
    assert abs(browser["rate"]["achieved_hz"] - 20.0) <= 3.0
    assert not list((tmp_path / "secure" / "keys").glob("*.key"))[0].stat().st_mode & 0o077
    assert (tmp_path / "gcs1.ublog").read_bytes()[:8] == b"UBLOG3\r\n"
    # the GPS step (issue #24): a simulated COTS GPS on fcs20's serial port becomes gpsNmea at gcs1, 2 hops away
    gps_step = doc["gps"]
    assert {"GPS fix at gcs1: the values pynmea2 encoded", "GPS sentences: every good one merged, every corrupted "
            "one counted", "GPS wire shared: every uavbus frame taken in", "GPS at gcs1 at the sensor's rate"} <= held
    assert gps_step["at_gcs1"]["sentencesOk"] == 4 * gps_step["epochs"] and gps_step["bad_checksum"] >= 1
