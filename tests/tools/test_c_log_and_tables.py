"""The reader on logs written by the C writer (Node.record), and the tables tool."""

from __future__ import annotations

import io
import json
import subprocess
from pathlib import Path

from tools_testutil import UAVBUS

from uavbus import MemLink, Node
from uavbus.config import load_config
from uavbus.enums import catalogue_enums
from uavbus.logfile import LogReader
from uavbus.tools import logcmd, tables

ROOT = Path(__file__).resolve().parents[2]
TABLE2 = ROOT / "examples" / "configs" / "table2.json"


def _pair(cat, now):
    gcs = Node(cat, config=TABLE2, node="gcs", clock=lambda: now[0])
    vehicle = Node(cat, config=TABLE2, node="primary", clock=lambda: now[0])
    MemLink(gcs, "gcsPortDatalink1", vehicle, "onboardPortDatalink1")
    return gcs, vehicle


def test_reader_reads_the_c_writer_and_export_matches_received_values(cat, tmp_path: Path) -> None:
    now = [1000]
    gcs, vehicle = _pair(cat, now)
    gps = vehicle.bind("gpsOut")
    gcs.bind("gpsOut")
    log_path = tmp_path / "gcs.ublog"
    gcs.record(log_path, tx=True)
    received = []
    labels = catalogue_enums(cat).labels  # the export shows enum members by name
    gcs.on_data(lambda m: received.append((m.seq, m.source, labels(m.instance.type, m.value))))
    gcs.subscribe("gcs1", "gpsOut", source="rmax1ob1", period_ms=50)
    for k in range(200):
        now[0] += 5
        gps.latitudeDeg = 33.0 + k
        gps.solutionCount = k
        vehicle.poll(timeout=0)
        gcs.poll(timeout=0)
    stats = gcs.stop_recording()
    log = LogReader(log_path)
    assert log.header.node == "gcs" and log.header.record_tx
    assert log.header.links[gcs.link_id("gcsPortDatalink1")] == "gcsPortDatalink1"
    assert log.ignored_bytes == 0 and len(log.records()) == stats["records"]
    lines = [json.loads(x) for x in _run_export(log_path)]
    assert [(x["seq"], x["source"], x["value"]) for x in lines] == received
    assert len(received) >= 15
    # Cut the C-written file anywhere in its last record: whole records before the cut remain.
    data = log_path.read_bytes()
    last = log.records()[-1].offset
    (tmp_path / "cut.ublog").write_bytes(data[: last + 11])
    cut = LogReader(tmp_path / "cut.ublog")
    assert len(cut.records()) == len(log.records()) - 1 and cut.ignored_bytes == 11
    gcs.close()
    vehicle.close()


def _run_export(path: Path) -> list[str]:
    out = io.StringIO()
    assert logcmd.main(["export", str(path), "--jsonl", "--only", "gpsOut"], out=out) == 0
    return [x for x in out.getvalue().splitlines() if '"dir":"rx"' in x]


def test_tables_static_console_script() -> None:
    res = subprocess.run([UAVBUS, "tables", "--static", "--config", str(TABLE2), "--node", "primary"],
                         capture_output=True, text=True, timeout=30)
    assert res.returncode == 0, res.stderr
    lines = res.stdout.splitlines()
    assert lines[0] == "entity table (hitl-table2; this node hosts rmax1ob1)"
    row = next(x for x in lines if x.startswith("0  rmax1ob1"))
    assert "[0]onboardPortDatalink1 [1]onboardPortDatalink2 [2]onboardPortIPC [3]onboardPortRelay" in row
    assert "*" in row.split()
    masks = next(x for x in lines if x.startswith("rmax1ob1   ") or x.split()[:1] == ["rmax1ob1"] and "0x" in x)
    assert masks.split() == ["rmax1ob1", "0x00000000", "0x00000100", "0x00001000", "0x00000011"]


def test_tables_of_a_live_node_show_pubsub_and_admin(cat) -> None:
    now = [0]
    gcs, vehicle = _pair(cat, now)
    vehicle.bind("gpsOut")
    adm = gcs.admin("gcs1")
    row = adm.add(content="gpsOut", source="rmax1ob1", destination="gcs1", period_ms=2000, kind="publication")
    adm.activate(row)
    for _ in range(20):
        now[0] += 5
        gcs.poll(timeout=0)
        vehicle.poll(timeout=0)
    text = "\n".join(tables.render_all(gcs, load_config(TABLE2, "gcs")))
    assert "global administration table (gcs1)" in text
    admin_line = next(x for x in text.splitlines() if x.startswith("0    gpsOut"))
    assert admin_line.split()[:8] == ["0", "gpsOut", "rmax1ob1", "gcs1", "2000", "publication", "yes", "active"]
    vtext = "\n".join(tables.render_all(vehicle, load_config(TABLE2, "primary")))
    assert "publish/subscribe table of rmax1ob1" in vtext
    assert any(x.split()[:4] == ["publication", "gpsOut", "gcs1", "2000"] for x in vtext.splitlines())
    # The bounded state (issue 29): each bound's counter, with routing's once routing runs.
    assert "bounded state" in vtext
    bounds = {(r["state"], r["counter"]): r["value"] for r in tables.bound_rows(vehicle)}
    assert bounds[("fragments", "rx_refused")] == 0 and ("fragments", "rx_source_limit") in bounds
    vehicle.routing.enable()
    bounds = {(r["state"], r["counter"]) for r in tables.bound_rows(vehicle)}
    assert {("routing", "learn_full"), ("routing", "learn_expired")} <= bounds
    gcs.close()
    vehicle.close()
