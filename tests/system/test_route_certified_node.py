"""uavbus_node --route certified=1 (issue 23 item 6, docs/security.md "Routing from insiders"): the routing
engine's destination filter from the identity store. Without identities it is refused with a clear one-line
error; with them the node starts and reports its routing bounds (neighbour_limit)."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

from uavbus import keys
from uavbus.sim.build import REPO, node_program

TABLE2 = REPO / "examples" / "configs" / "table2.json"


def test_certified_routes_need_identities() -> None:
    r = subprocess.run([str(node_program()), "--config", str(TABLE2), "--node", "gcs", "--route", "certified=1"],
                       stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=20)
    assert r.returncode != 0
    assert "--route certified=1 needs identities" in r.stderr


def test_certified_routes_start_with_identities(tmp_path: Path) -> None:
    cfg, _ = keys.fleet(str(TABLE2), str(tmp_path / "fleet"), days=30)
    p = subprocess.Popen([str(node_program()), "--config", cfg, "--node", "gcs", "--route",
                          "certified=1,max_dests=4", "--stats-ms", "100"],
                         stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         cwd=str(tmp_path / "fleet"))
    try:
        assert p.stdout is not None
        events = {}
        for _ in range(5):
            line = p.stdout.readline()
            if not line:
                break
            ev = json.loads(line)
            events[ev["event"]] = ev
            if "stats" in events:
                break
        assert "ready" in events, p.stderr.read() if p.poll() is not None else events
        assert events["stats"]["routing"]["neighbour_limit"] == 0
    finally:
        p.kill()
        p.wait(timeout=10)
