"""A scenario that mixes real and simulated nodes (issue 25, item 3): the emulated board (fcs20, a run: external
member on its UART's pty, no routing engine: a fixed entity table) beside a simulated vehicle process, both
linked to a Python ground station. `uavbus sim` (run as a user runs it) connects to the board, includes it in
the flows and the report, kills and restarts the ground station (item 5), and kills the simulated vehicle for
good: its flow turns stale in the report."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from uavbus.sim.qemu import QemuBoard
from uavbus.sim.scenario import load_scenario

pytestmark = pytest.mark.timeout(180)

SCENARIO = """\
name: hitl-mix
duration_s: 10
routing: {{hello_ms: 200, dead_misses: 3}}
ground_stations:
  - {{name: gcs1, run: python}}
vehicles:
  - {{name: fcs20, run: external, port: "serial:device={pty}", routing: false}}
  - {{name: uav1, motion: "orbit:r=100,v=10"}}
links:
  - {{between: [gcs1, fcs20], model: wire}}
  - {{between: [gcs1, uav1], model: wire}}
flows:
  - {{name: imu20, content: imuOut, source: fcs20, destination: gcs1, period_ms: 50}}
  - {{name: gps1, content: gpsOut, source: uav1, destination: gcs1, period_ms: 100}}
events:
  - {{t: 3, kill: gcs1}}
  - {{t: 4, restart: gcs1}}
  - {{t: 6.5, kill: uav1}}
"""


@pytest.fixture(scope="module")
def scenario_file(board: QemuBoard, tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("hitl-mix") / "hitl-mix.yaml"
    path.write_text(SCENARIO.format(pty=board.pty))
    return path


def test_check_says_the_board_is_external(scenario_file: Path) -> None:
    r = subprocess.run([sys.executable, "-m", "uavbus.sim.run_scenario", str(scenario_file), "--check"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "fcs20: external on serial:device=/dev/pts/" in r.stdout and "not started, killed or restarted" in r.stdout


def test_scenario_with_the_board_as_external_member(scenario_file: Path, program: Path, tmp_path: Path) -> None:
    """As a user runs it: `uavbus sim FILE`, its printed report and its summary.json."""
    r = subprocess.run([sys.executable, "-m", "uavbus.cli", "sim", str(scenario_file), "--out", str(tmp_path),
                        "--program", str(program)], capture_output=True, text=True, timeout=150)
    assert r.returncode == 0, r.stderr[-3000:]
    summary = json.loads((tmp_path / "summary.json").read_text())
    # The printed report names the board as external and lists its flow with what reached the ground station.
    report = r.stdout.splitlines()
    assert any(line.strip().startswith("fcs20: external on serial:device=/dev/pts/") for line in report), r.stdout
    (imu_line,) = [line for line in report if line.strip().startswith("imu20 ")]
    assert "fcs20 -> gcs1" in imu_line and "flowing" in imu_line, imu_line
    flows = {f["name"]: f for f in summary["flows"]}
    assert f"delivered {flows['imu20']['delivered']:5d}" in imu_line, imu_line
    assert summary["external"] == {"fcs20": {"port": load_scenario(scenario_file).station("fcs20").port,
                                             "routing": False}}
    imu = flows["imu20"]
    # The board's flow, measured at the ground station, through its kill and restart.
    assert imu["external"] == ["fcs20"] and imu["hops"] == 1, imu
    assert imu["delivered"] > 50 and imu["delivery_ratio_connected"] is not None, imu
    assert imu["status"] == "flowing", imu
    kill_gcs = next(e for e in summary["events"] if e["event"] == "kill" and e["target"] == ["gcs1"])
    restart = next(e for e in summary["events"] if e["event"] == "restart" and e["target"] == ["gcs1"])
    assert kill_gcs["t"] >= 3.0 and restart["reconverged_s"] is not None, restart
    assert {"imu20", "gps1"} <= set(restart["affected"]), restart   # both came back after the ground station did
    # The simulated vehicle killed for good: its flow is stale, with the cause of its last outage.
    gps = flows["gps1"]
    assert gps["status"] == "stale", gps
    last = gps["outages_explained"][-1]
    assert last["open"] and last["cause"].startswith("source gone: kill uav1"), last
