"""Helpers shared by the bridge tests and bench/bridges_bench.py."""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
AUTOPILOT = HERE / "mav_autopilot.py"


def autopilot_argv(port: int, key: Path | None = None, duration: float = 60.0, sysid: int = 1) -> list[str]:
    """The pymavlink autopilot (mav_autopilot.py) on udp 127.0.0.1:`port` as system `sysid`, signing with
    `key` if given."""
    argv = [sys.executable, str(AUTOPILOT), "--port", str(port), "--duration", str(duration), "--sysid", str(sysid)]
    if key is not None:
        argv += ["--key", str(key)]
    return argv
