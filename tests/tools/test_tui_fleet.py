"""The TUI follows the live fleet and never waits on the bus (issue 27): in-process nodes over memlinks.

gcs1 runs the app; rmax1ob1 (over a memlink) and rmax1ob2 (behind it, another administrator) are polled
from the app's loop; fcs20 is in the configuration but silent. An entity announced at run time appears in
the Remote tree, and shows revoked once removed; a read of the silent fcs20 leaves the app running until it
says "no answer"; a directory shows its units; a period changed on a row rmax1ob2 keeps says "temporary".
"""

from __future__ import annotations

import asyncio
from pathlib import Path
from typing import Any

import pytest

from uavbus import Catalogue, MemLink, Node
from uavbus.config import load_config
from uavbus.tools.common import Contents
from uavbus.tools.source import NodeSession
from uavbus.tui.app import BrowserApp
from uavbus.tui.remote_view import RemoteView

ROOT = Path(__file__).resolve().parents[2]
TABLE2 = ROOT / "examples" / "configs" / "table2.json"
pytestmark = pytest.mark.timeout(60)


async def until(pilot: Any, cond: Any, what: str, timeout: float = 8.0) -> None:
    for _ in range(int(timeout / 0.02)):
        if cond():
            return
        await pilot.pause(0.02)
    raise AssertionError(f"{what}: not within {timeout} s")


def labels(view: RemoteView) -> dict[str, str]:
    return {n.data[1]: str(n.label) for n in view.query_one("#remote-tree").root.children}


def test_tui_follows_the_fleet_and_stays_responsive(cat: Catalogue) -> None:
    gcs = Node(cat, config=TABLE2, node="gcs")
    air = Node(cat, config=TABLE2, node="primary")
    sec = Node(cat, config=TABLE2, node="secondary")
    try:
        MemLink(air, "onboardPortDatalink1", gcs, "gcsPortDatalink1")
        MemLink(air, "onboardPortIPC", sec, "onboard2PortIPC")
        for content in ("gpsOut", "imuOut"):
            air.bind(content)
        sec.bind("gpsOut")
        other = sec.admin("rmax1ob2")  # another administrator keeps gpsOut rmax1ob1 -> rmax1ob2
        other.activate(other.add("gpsOut", "rmax1ob1", "rmax1ob2", 100, "publication"))
        member = air.membership("rmax1ob1")
        session = NodeSession(node=gcs, config=load_config(TABLE2, "gcs"), contents=Contents(cat))

        def pump() -> None:
            air.poll(0)
            sec.poll(0)

        async def scenario() -> None:
            app = BrowserApp(session, pump=pump, live_s=0.3)
            async with app.run_test(size=(200, 50)) as pilot:
                app.query_one("#tabs").active = "tab-remote"
                await pilot.pause()
                view = app.query_one(RemoteView)
                assert set(labels(view)) == {"rmax1ob1", "rmax1ob2", "fcs20", "gcs1"}

                # Learned at run time: rmax1ob1 tells gcs1 that rmax9 exists (membership, admin code 11).
                member.request("add_entity", "gcs1", "rmax9")
                await until(pilot, lambda: "rmax9" in labels(view), "rmax9 in the tree")
                assert labels(view)["rmax9"] == "rmax9 (learned)"

                # The silent fcs20: the app keeps turning while the read waits, then says so.
                view.query_one("#remote-tree").select_node(view.find("fcs20", "directories", "gpsOutBackup"))
                await pilot.pause()
                turns = app.turns
                assert view.busy
                await until(pilot, lambda: not view.busy, "fcs20's answer or its timeout", 10.0)
                assert "no answer" in view.message, view.message
                assert app.turns - turns > 20  # the loop ran all along (the read never held the UI)

                # Units from imu.h's comments, beside the values.
                view.query_one("#remote-tree").select_node(view.find("rmax1ob1", "directories", "imuOut"))
                await pilot.pause()
                await until(pilot, lambda: not view.busy and view.rows and "field" in view.rows[0], "imuOut read")
                units = {r["field"]: r["unit"] for r in view.rows}
                assert units["imuOut.p"] == "rad/s" and units["imuOut.specificForce.x"] == "m/s^2"

                # Discovery: what rmax1ob1 offers (the Python node hosts only what it bound).
                view.query_one("#remote-tree").select_node(view.find("rmax1ob1", "what it offers"))
                await pilot.pause()
                await until(pilot, lambda: not view.busy and view.rows and "directory" in view.rows[0],
                            "rmax1ob1's offer", 20.0)
                offered = {r["directory"]: r["flows now"] for r in view.rows}
                assert set(offered) == {"gpsOut", "imuOut"}, offered
                assert offered["gpsOut"] == "publication to rmax1ob2 every 100 ms"

                # A period changed on the row rmax1ob2 keeps: temporary, and said so.
                view.query_one("#remote-tree").select_node(view.find("rmax1ob1", "tables", "pubsub"))
                await pilot.pause()
                await until(pilot, lambda: not view.busy and any(r.get("content") == "gpsOut" for r in view.rows),
                            "rmax1ob1's pubsub table")
                (row,) = [r for r in view.rows if r["content"] == "gpsOut"]
                assert row["owner"] == "rmax1ob2"
                view.query_one("#remote-edit").value = f"period {row['row']} = 40"
                await pilot.click("#remote-apply")
                await pilot.click("#remote-confirm")
                await until(pilot, lambda: not view.busy and "sent" not in view.message, "the period change")
                assert view.message.startswith("temporary change: rmax1ob1's row"), view.message
                assert "kept by administrator rmax1ob2" in view.message and view.message.endswith("Not done.")

                # Removed at run time: shown revoked, not silently dropped.
                member.request("remove_entity", "gcs1", "rmax9")
                await until(pilot, lambda: labels(view).get("rmax9") == "rmax9 (revoked)", "rmax9 revoked")

        asyncio.run(scenario())
    finally:
        for n in (gcs, air, sec):
            n.close()
