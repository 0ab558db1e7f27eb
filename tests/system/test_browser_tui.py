"""Issue 16 acceptance, the TUI: `uavbus tui`'s Remote tab (headless pilot) against real C processes.

Table 2 as in test_browser.py: the app's node is the Python GCS (gcs1); fcs20 runs in a `uavbus_node`
process two hops away (gcs1 -> rmax1ob1 -> fcs20). Through the tree and the edit line the operator
reads a directory never bound by hand and writes one of its fields, reads every table, changes a
publication rate and a mask after a confirmation, and sees the reason of a policy's refusal.
"""

from __future__ import annotations

import asyncio
from pathlib import Path
from typing import Any

import pytest

from uavbus.config import load_config
from uavbus.sim.hitl import Hitl, HitlOptions
from uavbus.tools.common import Contents
from uavbus.tools.source import NodeSession
from uavbus.tui.app import BrowserApp
from uavbus.tui.remote_view import RemoteView

pytestmark = pytest.mark.timeout(90)


def session_of(h: Hitl, config: Path) -> NodeSession:
    return NodeSession(node=h.gcs, config=load_config(config, "gcs"), contents=Contents(h.gcs.catalogue))


async def settle(pilot: Any, view: RemoteView, timeout: float = 10.0) -> None:
    """Lets the app run until the request in flight is answered (the UI never blocks on one)."""
    for _ in range(int(timeout / 0.02)):
        if not view.busy:
            return
        await pilot.pause(0.02)
    raise AssertionError(f"still waiting for an answer after {timeout} s ({view.message})")


async def open_leaf(pilot: Any, view: RemoteView, *path: str) -> None:
    """Selects a leaf of the tree as the operator would (cursor on it, Enter), and waits for its answer."""
    tree = view.query_one("#remote-tree")
    tree.select_node(view.find(*path))
    await pilot.pause()
    await settle(pilot, view)


async def edit(pilot: Any, view: RemoteView, row: int, new_tail: str, keep: int) -> None:
    """Picks grid row `row` (fills in the edit line), replaces all but its first `keep` characters with
    `new_tail`, and presses Apply."""
    grid = view.query_one("#remote-grid")
    grid.focus()
    grid.move_cursor(row=row)
    await pilot.press("enter")
    line = view.query_one("#remote-edit")
    await pilot.click("#remote-edit")
    await pilot.press("end", *["backspace"] * (len(line.value) - keep), *new_tail)
    await pilot.click("#remote-apply")


def test_tui_reads_tables_and_changes_a_rate_two_hops(hitl_opts: HitlOptions) -> None:
    hitl_opts.node_args = {"backup": ["--publish", "fcs20:imuOut>gcs1/100"]}
    with Hitl(hitl_opts) as h:
        assert h.topo is not None and h.topo.hops("gcs", "backup") == 2
        h.gcs.bind("imuOut")

        async def scenario() -> None:
            app = BrowserApp(session_of(h, Path(hitl_opts.config)), live_s=0.3)
            async with app.run_test(size=(200, 50)) as pilot:
                app.query_one("#tabs").active = "tab-remote"
                await pilot.pause()
                view = app.query_one(RemoteView)

                # A directory uavbus_node never binds by hand: read through the generated bind table.
                await open_leaf(pilot, view, "fcs20", "directories", "airData")
                fields = {r["field"]: r["value"] for r in view.rows}
                assert "airData.staticPressurePa" in fields and "airData.rawCounts" in fields, view.message

                # Every table, as fcs20's C router lists it.
                seen = {}
                for table in ("entities", "links", "pubsub", "admin"):
                    await open_leaf(pilot, view, "fcs20", "tables", table)
                    seen[table] = list(view.rows)
                assert {r["entity"] for r in seen["entities"]} == {"rmax1ob1", "rmax1ob2", "fcs20", "gcs1"}
                assert [r["link"] for r in seen["links"]] == ["onboardPortDatalink1"]
                assert seen["admin"] == []

                # A rate: the imuOut publication's row, 100 ms -> 20 ms, only after Confirm.
                await open_leaf(pilot, view, "fcs20", "tables", "pubsub")
                (k,) = [i for i, r in enumerate(view.rows) if r["content"] == "imuOut"]
                row = view.rows[k]["row"]
                await edit(pilot, view, k, "20", keep=len(f"period {row} = "))
                assert view.query_one("#remote-edit").value == f"period {row} = 20"
                assert "press Confirm" in view.message, view.message
                assert view.rows[k]["period_ms"] == 100  # nothing sent yet
                await pilot.click("#remote-confirm")
                await settle(pilot, view)
                assert view.message == "fcs20: done", view.message
                assert view.rows[k]["period_ms"] == 20
                assert [r["period_ms"] for r in h.gcs.remote("fcs20").table("pubsub") if r["row"] == row] == [20]
                # The grid is live: it shows the frame count growing without any selection.
                frames = view.rows[k]["frames"]
                for _ in range(100):
                    await pilot.pause(0.05)
                    if view.rows[k]["frames"] > frames:
                        break
                assert view.rows[k]["frames"] > frames

                # A field of that directory, written only after Confirm; the other fields stay.
                await open_leaf(pilot, view, "fcs20", "directories", "airData")
                (k,) = [i for i, r in enumerate(view.rows) if r["field"] == "airData.staticPressurePa"]
                raw = [r["value"] for r in view.rows if r["field"].startswith("airData.rawCounts")]
                await edit(pilot, view, k, "90000.5", keep=len("airData.staticPressurePa = "))
                await pilot.click("#remote-confirm")
                await settle(pilot, view)
                assert view.message == "fcs20: done", view.message
                fcs = h.gcs.remote("fcs20")
                assert fcs.get("airData.staticPressurePa") == pytest.approx(90000.5)
                assert [r["value"] for r in view.rows if r["field"].startswith("airData.rawCounts")] == raw

                # A mask: fcs20's mask toward rmax1ob2, 0x00000001 -> 0x00000000 (no link toward it), after Confirm.
                await open_leaf(pilot, view, "fcs20", "tables", "entities")
                (k,) = [i for i, r in enumerate(view.rows) if r["entity"] == "rmax1ob2"]
                await edit(pilot, view, k, "0x00000000", keep=len("mask rmax1ob2 = "))
                await pilot.click("#remote-confirm")
                await settle(pilot, view)
                assert view.message == "fcs20: done", view.message
                (after,) = [r for r in view.rows if r["entity"] == "rmax1ob2"]
                assert after["mask"] == "0x00000000", after
                assert [e["mask"] for e in fcs.table("entities") if e["entity"] == "rmax1ob2"] == ["0x00000000"]

        asyncio.run(scenario())
        t0 = h.mark("fast")
        h.run_for(1.0)
        assert h.meter("imuOut", "fcs20").rate_hz(t0, t0 + 1.0) > 30.0  # 50 Hz asked, 10 Hz before


def test_tui_shows_a_policy_refusal_and_its_reason(browser_policy_opts: HitlOptions) -> None:
    hitl_opts = browser_policy_opts  # only rmax1ob2 administers; gcs1 may write fcsSet into fcs20; reads open
    path = Path(hitl_opts.config)
    with Hitl(hitl_opts) as h:
        async def scenario() -> None:
            app = BrowserApp(session_of(h, path), live_s=60.0)
            async with app.run_test(size=(200, 50)) as pilot:
                app.query_one("#tabs").active = "tab-remote"
                await pilot.pause()
                view = app.query_one(RemoteView)
                await open_leaf(pilot, view, "fcs20", "directories", "airData")
                (k,) = [i for i, r in enumerate(view.rows) if r["field"] == "airData.staticPressurePa"]
                before = view.rows[k]["value"]
                await edit(pilot, view, k, "1.5", keep=len("airData.staticPressurePa = "))
                await pilot.click("#remote-confirm")
                await settle(pilot, view)
                assert view.message == "fcs20: write airData: refused (not_authorized)", view.message
                assert view.rows[k]["value"] == before
                # Tables are the administrators': the grid keeps what it showed, the reason is shown.
                await open_leaf(pilot, view, "fcs20", "tables", "links")
                assert view.message == "fcs20: list links: refused (not_authorized)", view.message

        asyncio.run(scenario())
