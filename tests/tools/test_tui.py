"""The Textual variable browser, headless (App.run_test / pilot), against an in-process vehicle node.

The TUI's node hosts gcs1 (Table 2's "gcs" node); a vehicle node hosts rmax1ob1; a MemLink joins
gcsPortDatalink1 and onboardPortDatalink1. Both run on one injected clock that the app's loop
advances, so the test is deterministic and never waits for wall time beyond Textual's own steps.
"""

from __future__ import annotations

import asyncio
from pathlib import Path

from uavbus import MemLink, Node
from uavbus.config import load_config
from uavbus.tools.common import Contents
from uavbus.tools.source import NodeSession, install_tap
from uavbus.tui.app import BrowserApp

ROOT = Path(__file__).resolve().parents[2]
TABLE2 = ROOT / "examples" / "configs" / "table2.json"


def test_tui_tables_and_admin_row_becomes_acknowledged_then_active(cat) -> None:
    now = [0]
    clock = lambda: now[0]  # noqa: E731
    gcs = Node(cat, config=TABLE2, node="gcs", clock=clock)
    vehicle = Node(cat, config=TABLE2, node="primary", clock=clock)
    gps = vehicle.bind("gpsOut")
    gps.latitudeDeg = 33.77
    # 3 ms each way, so the source's first ACK (no data yet) and its FLOWING ACK arrive apart.
    MemLink(gcs, "gcsPortDatalink1", vehicle, "onboardPortDatalink1", faults={"delay_ms": 3})
    session = NodeSession(node=gcs, config=load_config(TABLE2, "gcs"), contents=Contents(cat))
    install_tap(session)

    statuses: list[str] = []  # every status the row took, seen on each loop turn of the app

    def pump() -> None:
        now[0] += 1
        vehicle.poll(timeout=0)
        rows = gcs.admin("gcs1").rows()
        if rows and (not statuses or statuses[-1] != rows[0]["status"]):
            statuses.append(rows[0]["status"])

    async def scenario() -> tuple[list[str], BrowserApp]:
        app = BrowserApp(session, pump=pump, poll_s=0.02, refresh_s=0.1)
        async with app.run_test(size=(180, 50)) as pilot:
            masks = app.query_one("#masks")
            assert masks.row_count == 4
            row = [str(c) for c in masks.get_row_at(0)]
            assert row == ["rmax1ob1", "0x00000000", "0x00000100", "0x00001000", "0x00000011"]
            app.query_one("#tabs").active = "tab-admin"
            await pilot.pause()
            # Figure 5's row (gpsOut from rmax1ob1 to gcs1), as a subscription at 100 ms: the SUB_REQUEST
            # is acknowledged by gcs1 at once, and the row is active once gcs1 receives the data.
            for widget, text in (("content", "gpsOut"), ("source", "rmax1ob1"), ("destination", "gcs1"),
                                 ("period", "100")):
                await pilot.click(f"#{widget}")
                await pilot.press(*text)
            await pilot.click("#kind")
            await pilot.press("down", "enter")
            assert str(app.query_one("#kind").value) == "subscription"
            await pilot.click("#add")
            assert app.row_status(0) == "inactive"
            await pilot.click("#activate")
            cells: list[str] = []
            for _ in range(100):
                await pilot.pause(0.02)
                cell = str(app.query_one("#admin").get_row_at(0)[-1])
                if not cells or cells[-1] != cell:
                    cells.append(cell)
                if cell == "active" and app.streams:
                    break
            app.query_one("#tabs").active = "tab-values"
            await pilot.pause(0.05)
            assert app.query_one("#values").row_count == 1
            return cells, app

    cells, app = asyncio.run(scenario())
    assert statuses == ["inactive", "pending", "acknowledged", "active"], statuses
    assert cells[-1] == "active", cells
    # The vehicle's table holds the publication the row created; the values tab saw the data.
    assert [(r["kind"], r["content"], r["peer"], r["period_ms"]) for r in vehicle.pubsub_rows("rmax1ob1")] == \
        [("publication", "gpsOut", "gcs1", 100)]
    assert [(r["kind"], r["content"], r["peer"]) for r in gcs.pubsub_rows("gcs1")] == \
        [("subscription", "gpsOut", "rmax1ob1")]
    stream = app.streams[("gpsOut", "rmax1ob1")]
    assert stream.count >= 1 and stream.last["latitudeDeg"] == 33.77
    gcs.close()
    vehicle.close()
