"""Faults a node must survive (issue #17): a file-size limit on its log, hostile bytes in its
supervision output, a serial device that hangs up, TCP peers that half-close.

Each test reproduces what an adversarial run found against the earlier code (named in its docstring).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from uavbus.logfile import LogReader

pytestmark = pytest.mark.timeout(60)

ROOT = Path(__file__).resolve().parents[2]
TABLE2 = ROOT / "examples" / "configs" / "table2.json"
LIMIT = 192 * 1024  # bytes per file: the header (the embedded flightsw catalogue) takes ~172 KiB

# Runs argv[2:] with RLIMIT_FSIZE = argv[1] bytes and SIGXFSZ at its default action (Python itself ignores
# SIGXFSZ, and an ignored signal stays ignored across exec: the node must ignore it on its own).
_WITH_FSIZE = (
    "import os, resource, signal, sys\n"
    "signal.signal(signal.SIGXFSZ, signal.SIG_DFL)\n"
    "n = int(sys.argv[1]); resource.setrlimit(resource.RLIMIT_FSIZE, (n, n))\n"
    "os.execv(sys.argv[2], sys.argv[2:])\n"
)


def _events(stdout: str) -> list[dict]:
    return [json.loads(line) for line in stdout.splitlines() if line.strip()]


def test_log_survives_a_file_size_limit(program: Path, tmp_path: Path) -> None:
    """Before: the node died of SIGXFSZ at the limit (exit by signal 25), its log cut mid-record."""
    log = tmp_path / "primary.ublog"
    argv = [sys.executable, "-c", _WITH_FSIZE, str(LIMIT), str(program), "--config", str(TABLE2),
            "--node", "primary", "--port", "onboardPortRelay=udp:bind=127.0.0.1:0,peer=127.0.0.1:9",
            "--publish", "rmax1ob1:imuOutPrimary>fcs20/2", "--record", str(log), "--record-tx",
            "--record-max-files", "3", "--duration-ms", "1500", "--stats-ms", "0"]
    run = subprocess.run(argv, capture_output=True, text=True, timeout=30, stdin=subprocess.DEVNULL)
    assert run.returncode == 0, f"exit {run.returncode} ({signal.Signals(-run.returncode).name if run.returncode < 0 else ''}): {run.stderr}"
    final = [e for e in _events(run.stdout) if e.get("event") == "stats" and e.get("final")][-1]
    s = final["log"]
    assert s["write_errors"] == 0 and s["limit_rotations"] >= 3 and s["failing"] is False
    assert s["files"] == s["file_index"] + 1 and s["files_deleted"] == s["files"] - 3
    sent = final["links"]["onboardPortRelay"]["frames_out"]
    assert s["records"] == sent > 300
    # The newest three files remain; each reads alone, whole, and the records run on across them.
    files = sorted(tmp_path.glob("primary*.ublog"))
    assert len(files) == 3
    next_seq = None
    for f in files:
        assert f.stat().st_size <= LIMIT
        r = LogReader(f)
        recs = r.records()
        assert r.ignored_bytes == 0 and r.stats.missing_records == 0 and recs
        if next_seq is not None:
            assert recs[0].seq == next_seq
        next_seq = recs[-1].seq + 1
    assert next_seq == s["records"]
