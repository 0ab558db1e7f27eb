"""A source killed for good turns its flows `stale` (issue 25, item 5) -- in the report and in the ground
station's administration table, which before showed such a row as `acknowledged`. Run as a user runs it,
`uavbus sim FILE`: uav1 is killed at t=3 and never restarted; its plain subscription and its administered
flow both end stale, with the kill as the open outage's cause; uav2's administered flow, on the same ground
station, stays flowing and active (the same report can say both)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.timeout(120)

SCENARIO = """\
name: stale-source
duration_s: 7
routing: {hello_ms: 200, dead_misses: 3}
ground_stations:
  - {name: gcs1, run: python}
vehicles:
  - {name: uav1, motion: "orbit:r=100,v=10"}
  - {name: uav2, motion: "orbit:r=120,v=10"}
links:
  - {between: [gcs1, uav1], model: wire}
  - {between: [gcs1, uav2], model: wire}
flows:
  - {name: nav1, content: navFilterState, source: uav1, destination: gcs1, period_ms: 100, admin: gcs1}
  - {name: gps1, content: gpsOut, source: uav1, destination: gcs1, period_ms: 100}
  - {name: nav2, content: navFilterState, source: uav2, destination: gcs1, period_ms: 100, admin: gcs1}
events:
  - {t: 3, kill: uav1}
"""


def test_a_source_killed_for_good_reads_stale_in_the_report_and_the_admin_table(program: Path,
                                                                                 tmp_path: Path) -> None:
    path = tmp_path / "stale-source.yaml"
    path.write_text(SCENARIO)
    r = subprocess.run([sys.executable, "-m", "uavbus.cli", "sim", str(path), "--out", str(tmp_path / "out"),
                        "--program", str(program)], capture_output=True, text=True, timeout=100)
    assert r.returncode == 0, r.stderr[-3000:]
    flows = {f["name"]: f for f in json.loads((tmp_path / "out" / "summary.json").read_text())["flows"]}
    for name in ("nav1", "gps1"):
        f = flows[name]
        assert f["delivered"] > 10 and f["status"] == "stale", f          # it flowed, then its source died
        last = f["outages_explained"][-1]
        assert last["open"] and last["cause"].startswith("source gone: kill uav1"), last
    assert flows["nav1"]["admin_status"] == "stale", flows["nav1"]
    assert flows["nav2"]["status"] == "flowing" and flows["nav2"]["admin_status"] == "active", flows["nav2"]
    lines = {line.split()[0]: line for line in r.stdout.splitlines() if line.startswith("  nav")}
    assert lines["nav1"].endswith("stale, admin row stale") and lines["nav2"].endswith("flowing, admin row active"), \
        lines
