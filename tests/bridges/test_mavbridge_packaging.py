"""Packaging of the MAVLink bridge (#26 item 4), as a packager and a consumer meet it.

- A fresh configure with UAVBUS_BUILD_TESTS=OFF (what a packager or a consumer that wants no tests runs)
  has the documented targets `uavbus_mavbridge` and `uavbus_mavbridge_lib`, no bridge test, install rules
  for the program, and the mavbridge.json it writes names the program the target builds.
- `cmake --install` of the bridge's directory of the build `make test` made puts a program in bin/ that
  runs (its usage, exit 0).
Configure only: building a second copy of the bridge would cost minutes on the shared machine.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from uavbus.sim.build import REPO

from conftest import build_dir


def run(cmd: list, timeout: float = 300) -> str:
    proc = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, timeout=timeout)
    assert proc.returncode == 0, f"{' '.join(map(str, cmd))} failed ({proc.returncode}):\n{proc.stdout}\n{proc.stderr}"
    return proc.stdout


def test_configure_without_tests_has_the_documented_targets_and_no_bridge_test(tmp_path: Path) -> None:
    build = tmp_path / "build"
    run(["cmake", "-S", REPO, "-B", build, "-G", "Ninja", f"-DUAVBUS_PYTHON={sys.executable}",
         "-DUAVBUS_BUILD_TESTS=OFF", f"-DCMAKE_INSTALL_PREFIX={tmp_path / 'prefix'}"])
    targets = {line.split(":")[0] for line in run(["ninja", "-C", build, "-t", "targets", "all"]).splitlines()}
    assert {"uavbus_mavbridge", "uavbus_mavbridge_lib", "uavbus_node"} <= targets
    tests = sorted(t for t in targets if "test_mavbridge" in t or "bridges/mavlink/tests" in t)
    assert not tests, f"UAVBUS_BUILD_TESTS=OFF still builds bridge tests: {tests}"
    info = json.loads((build / "mavbridge.json").read_text())
    assert Path(info["program"]) == build / "bridges" / "mavlink" / "uavbus_mavbridge", info
    install_rules = (build / "bridges" / "mavlink" / "cmake_install.cmake").read_text()
    assert "uavbus_mavbridge" in install_rules and "/bin" in install_rules, install_rules[:2000]


def test_install_puts_a_working_program_in_bin(tmp_path: Path, mavbridge: dict[str, str]) -> None:
    prefix = tmp_path / "prefix"
    run(["cmake", f"-DCMAKE_INSTALL_PREFIX={prefix}", "-P", build_dir() / "bridges" / "mavlink" / "cmake_install.cmake"])
    prog = prefix / "bin" / "uavbus_mavbridge"
    assert prog.is_file(), sorted(str(p) for p in prefix.rglob("*"))
    out = run([prog, "--help"], timeout=10)
    assert out.startswith("usage: uavbus_mavbridge") and "--gcs" in out, out
