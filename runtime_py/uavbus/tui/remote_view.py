"""The Remote tab of `uavbus tui`: browse and change any reachable entity over the bus (issue 16).

A tree lists the entities the node knows -- the configuration's, and those learned at run time (routing,
membership), added as they appear; an entity removed from the table is marked revoked -- and under each, its
four tables and every catalogued directory (added when "directories" is first opened). Selecting a leaf reads it through
`Node.remote(entity)` (INSPECT requests answered by the target's C router, whatever hop it is on) and
shows it in the grid; the shown leaf is read again every `live_s` while it answers. An edit is typed as
one line and runs only after Confirm:

    airData.staticPressurePa = 101325      a directory field (JSON value; a whole directory too)
    period 3 = 20                          publish/subscribe row 3 every 20 ms
    mask rmax1ob2 = 0x00000001             the entity's link mask toward rmax1ob2 (pinned)
    admin 0 = 50                           administration row 0 every 50 ms, in place

Selecting a grid row (a field, a pubsub or admin row, an entity) fills in the line to edit. A refusal
shows its reason, e.g. "fcs20: write airData: refused (not_authorized)". A period changed on a row that
another administrator keeps says "temporary change" (uavbus.tools.changes), never "done".

Every request is started with `Remote.begin()` and stepped from the app's loop (`step()`), so the UI never
waits on the bus: a silent entity shows "no answer" after its timeout while everything else goes on.
"""

from __future__ import annotations

import json
import re
import time
from collections.abc import Callable, Iterator
from typing import Any

from textual.app import ComposeResult
from textual.containers import Horizontal, Vertical
from textual.widgets import Button, DataTable, Input, Label, Tree

from uavbus.errors import UbError
from uavbus.tools.common import short_value

TABLE_NAMES = ("entities", "links", "pubsub", "admin")
_EDIT = re.compile(r"^\s*(?:(period|admin)\s+(\d+)|mask\s+(\S+)|([^\s=]+))\s*=\s*(.+?)\s*$")


def flatten(value: Any, prefix: str) -> Iterator[tuple[str, Any]]:
    """("airData", {"a": 1, "b": {"c": [1, 2]}}) -> ("airData.a", 1), ("airData.b.c", [1, 2]): one row per
    leaf; an array of scalars stays one row (it is written whole), an array of structures is indexed."""
    if isinstance(value, dict):
        for k, v in value.items():
            yield from flatten(v, f"{prefix}.{k}")
    elif isinstance(value, list) and value and isinstance(value[0], (dict, list)):
        for i, v in enumerate(value):
            yield from flatten(v, f"{prefix}[{i}]")
    else:
        yield prefix, value


def parse_edit(remote: Any, text: str, admin: Any | None = None, me: str = "") -> tuple[str, Callable[[], Any]]:
    """One edit line -> (what it does, in words; a function that starts it and returns its RemoteCall).
    ValueError on a bad line. `admin`/`me`: the operator's administration table and entity (period edits
    tell a lasting change from a temporary one)."""
    from uavbus.remote import RemoteCall
    from uavbus.tools.changes import g_set_period

    m = _EDIT.match(text)
    if m is None:
        raise ValueError("edit: NAME.FIELD = VALUE, period ROW = MS, mask ENTITY = 0xMASK or admin ROW = MS")
    kind, row, dest, name, value = m.groups()
    if kind is not None and not value.isdigit():
        raise ValueError(f"{kind} {row}: the period is a whole number of milliseconds, not {value!r}")
    if kind == "period":
        return f"set the period of pubsub row {row} to {value} ms", \
            lambda: RemoteCall.of_task(g_set_period(remote.node, remote, int(row), int(value), me, admin))
    if kind == "admin":
        return f"set the period of admin row {row} to {value} ms", \
            lambda: remote.begin("set_admin_row", int(row), period_ms=int(value))
    if dest is not None:
        return f"set the mask toward {dest} to {value}", lambda: remote.begin("set_mask", dest, value)
    try:
        parsed = json.loads(value)
    except json.JSONDecodeError:
        parsed = value  # a bare word: a string field
    return f"set {name} to {json.dumps(parsed)}", lambda: remote.begin("set", name, parsed)


class RemoteView(Vertical):
    """Tree of reachable entities -> tables and directories; a grid of the selected leaf; an edit line."""

    DEFAULT_CSS = """
    RemoteView #remote-tree { width: 36; }
    RemoteView #remote-edit { width: 1fr; }
    RemoteView #remote-grid { height: 1fr; }
    """

    def __init__(self, session: Any, live_s: float = 1.0, timeout: float = 2.0,
                 admin: Callable[[], Any] | None = None) -> None:
        super().__init__(id="remote-view")
        self.session = session
        self.live_s, self.timeout = live_s, timeout
        self.admin = admin  # the operator's administration table (period edits: lasting or temporary)
        self.leaf: tuple[str, str, str] | None = None  # ("table" | "dir", entity, table or directory name)
        self.rows: list[dict[str, Any]] = []            # what the grid shows, one dict per row
        self.pending: Callable[[], Any] | None = None   # the edit waiting for Confirm
        self.message = ""
        self._live_at = 0.0
        self._call: Any = None                          # the RemoteCall in flight, stepped by step()
        self._done: Callable[[Any, BaseException | None], None] | None = None
        self._known: dict[str, str] = {}                # entity -> "configured" | "learned" | "revoked"
        self.failed = False                             # the shown leaf's last read was not answered

    @property
    def busy(self) -> bool:
        """A request is in flight (its answer is shown when it comes, by step())."""
        return self._call is not None

    def _start(self, call: Any, done: Callable[[Any, BaseException | None], None]) -> None:
        self._call, self._done = call, done

    def step(self) -> None:
        """Called by the app after each poll of the node: finishes the request in flight when answered."""
        call = self._call
        if call is None or not call.step():
            return
        done, self._call, self._done = self._done, None, None
        try:
            value, error = call.result(), None
        except Exception as exc:  # noqa: BLE001 - shown with its reason by `done`
            value, error = None, exc
        if done is not None:
            done(value, error)

    def compose(self) -> ComposeResult:
        with Horizontal():
            yield Tree("bus", id="remote-tree")
            with Vertical():
                yield Label("select a table or a directory of an entity", id="remote-title")
                yield DataTable(id="remote-grid", zebra_stripes=True, cursor_type="row")
                with Horizontal():
                    yield Input(placeholder="NAME.FIELD = VALUE | period ROW = MS | mask ENTITY = 0xMASK | "
                                            "admin ROW = MS", id="remote-edit")
                    yield Button("Apply", id="remote-apply", variant="primary")
                    yield Button("Confirm", id="remote-confirm", variant="warning", disabled=True)
                    yield Button("Cancel", id="remote-cancel", disabled=True)
                yield Label("", id="remote-message")

    def on_mount(self) -> None:
        self.query_one("#remote-tree", Tree).root.expand()
        self.sync_entities()

    def sync_entities(self) -> None:
        """The tree follows the node's entity table: learned entities appear, removed ones say revoked."""
        trees = self.query("#remote-tree")
        if not trees:
            return  # the app is exiting: its widgets are gone, a timer can still fire
        tree = trees.first(Tree)
        configured = [e.name for e in self.session.config.entities]
        table = [e["name"] for e in self.session.node.entities()]
        names = list(dict.fromkeys([*configured, *table, *self._known]))
        by_name = {n.data[1]: n for n in tree.root.children}
        for name in names:
            state = "revoked" if name not in table and name in self._known else \
                "configured" if name in configured else "learned"
            if self._known.get(name) == state and name in by_name:
                continue
            self._known[name] = state
            here = " (this node)" if name in self.session.config.hosts else ""
            label = name + here + ("" if state == "configured" else f" ({state})")
            node = by_name.get(name)
            if node is not None:
                node.set_label(label)
                continue
            ent = tree.root.add(label, data=("entity", name))
            ent.add_leaf("what it offers", data=("offer", name, "offer"))  # discovery (uavbus list ENTITY)
            tables = ent.add("tables", data=("tables", name))
            for t in TABLE_NAMES:
                tables.add_leaf(t, data=("table", name, t))
            ent.add("directories", data=("dirs", name))  # leaves added on first expansion

    # -- tree -----------------------------------------------------------------------------------
    def on_tree_node_expanded(self, event: Tree.NodeExpanded) -> None:
        self._add_dirs(event.node)

    def _add_dirs(self, node: Any) -> None:
        data = node.data
        if data and data[0] == "dirs" and not node.children:
            for inst in self.session.node.catalogue:
                node.add_leaf(inst.name, data=("dir", data[1], inst.name))

    def on_tree_node_selected(self, event: Tree.NodeSelected) -> None:
        data = event.node.data
        if data and data[0] in ("table", "dir", "offer"):
            if self._call is not None:
                self._call.cancel()  # the operator moved on: its answer is no longer wanted
                self._call = self._done = None
            self.leaf = data
            self.failed = False
            self.load()

    def find(self, entity: str, *path: str) -> Any:
        """The tree node under `entity` at `path` (e.g. "tables", "pubsub"), expanding on the way."""
        node = next(n for n in self.query_one("#remote-tree", Tree).root.children if n.data[1] == entity)
        for label in path:
            self._add_dirs(node)
            node.expand()
            node = next(n for n in node.children if str(n.label) == label)
        return node

    # -- reading --------------------------------------------------------------------------------
    def remote(self) -> Any:
        assert self.leaf is not None
        return self.session.node.remote(self.leaf[1], timeout=self.timeout)

    def load(self) -> bool:
        """Starts reading the selected leaf; the grid shows it when the answer comes (step()). False if a
        request is already in flight or nothing is selected."""
        if self.leaf is None or self.busy:
            return False
        kind, entity, name = self.leaf
        leaf = self.leaf
        if kind == "offer":
            from uavbus.remote import RemoteCall
            from uavbus.tools.discover import g_offer

            call = RemoteCall.of_task(g_offer(self.remote(), self.session.node.catalogue))
        else:
            call = self.remote().begin("table", name) if kind == "table" else self.remote().begin("get", name)

        def done(value: Any, error: BaseException | None) -> None:
            self._live_at = time.monotonic()
            if self.leaf != leaf:
                return  # the operator moved on meanwhile
            if error is not None:
                self.say(error.detail if isinstance(error, UbError) else str(error))
                self.failed = True
                return
            if kind == "offer":  # what it hosts and lets this node read, and its flows now
                rows = [{"directory": r["name"], "type": r["type"].removeprefix("struct "), "bytes": r["size"],
                         "flows now": "; ".join(r["flows"]) or "-"} for r in value["instances"] if r["bound"]]
                title = f"offers: {value['note']}"
            else:
                rows = value if kind == "table" else self._field_rows(name, value)
                title = name
            self.failed = False
            self.query_one("#remote-title", Label).update(f"{entity}: {title} ({len(rows)} rows, read "
                                                          f"{time.strftime('%H:%M:%S')})")
            self.show(rows)

        self._start(call, done)
        return True

    def _field_rows(self, name: str, value: Any) -> list[dict[str, Any]]:
        from uavbus.units import units_of

        cat = self.session.node.catalogue
        units = units_of(cat, cat.instance(name).type)
        rows = []
        for f, v in flatten(value, name):
            key = re.sub(r"\[\d+\]", "", f[len(name) + 1:])
            rows.append({"field": f, "value": v, "unit": units.get(key, {}).get("unit", "")})
        return rows

    def show(self, rows: list[dict[str, Any]]) -> None:
        grid = self.query_one("#remote-grid", DataTable)
        columns = list(rows[0]) if rows else []
        if rows == self.rows and grid.columns:
            return
        cursor = grid.cursor_row
        if not self.rows or list(self.rows[0]) != columns:
            grid.clear(columns=True)
            grid.add_columns(*columns)
        else:
            grid.clear()
        self.rows = rows
        for r in rows:
            grid.add_row(*(short_value(v, 80) if isinstance(v, (list, dict)) else str(v) for v in r.values()))
        if 0 <= cursor < len(rows):
            grid.move_cursor(row=cursor)

    def live(self) -> None:
        """Called by the app's refresh timer: follows the entity table, and reads the shown leaf again every
        `live_s` while it answers (one that did not answer is read again only when selected again)."""
        self.sync_entities()
        if self.leaf is not None and self.leaf[0] != "offer" and self.pending is None and not self.busy \
                and not self.failed and time.monotonic() - self._live_at >= self.live_s:
            self.load()

    # -- editing --------------------------------------------------------------------------------
    def on_data_table_row_selected(self, event: DataTable.RowSelected) -> None:
        if event.data_table.id != "remote-grid" or self.leaf is None or not 0 <= event.cursor_row < len(self.rows):
            return
        r, name = self.rows[event.cursor_row], self.leaf[2]
        line = {"pubsub": lambda: f"period {r['row']} = {r['period_ms']}",
                "admin": lambda: f"admin {r['row']} = {r['period_ms']}",
                "entities": lambda: f"mask {r['entity']} = {r['mask']}"}.get(name)
        if self.leaf[0] == "dir":
            line = lambda: f"{r['field']} = {json.dumps(r['value'])}"  # noqa: E731
        if line is not None:
            self.query_one("#remote-edit", Input).value = line()

    def on_input_submitted(self, event: Input.Submitted) -> None:
        if event.input.id == "remote-edit":
            self.apply()

    def on_button_pressed(self, event: Button.Pressed) -> None:
        {"remote-apply": self.apply, "remote-confirm": self.confirm, "remote-cancel": self.cancel}[event.button.id]()
        event.stop()

    def apply(self) -> None:
        if self.leaf is None:
            self.say("select an entity's table or directory first")
            return
        admin = self.admin() if self.admin is not None else None
        me = getattr(admin, "entity", "") if admin is not None else ""
        try:
            what, call = parse_edit(self.remote(), self.query_one("#remote-edit", Input).value, admin, me)
        except ValueError as exc:
            self.say(str(exc))
            return
        self.pending = call
        self._confirming(True)
        self.say(f"{self.leaf[1]}: {what}? press Confirm to send it, Cancel to drop it")

    def confirm(self) -> None:
        start, self.pending = self.pending, None
        self._confirming(False)
        if start is None or self.leaf is None:
            return
        if self._call is not None:
            self._call.cancel()  # a live read in flight: the edit goes first
            self._call = self._done = None
        entity = self.leaf[1]
        try:
            call = start()
        except (UbError, ValueError, LookupError, TypeError) as exc:
            self.say(exc.detail if isinstance(exc, UbError) else str(exc))
            return
        self.say(f"{entity}: sent, waiting for the answer")

        def done(value: Any, error: BaseException | None) -> None:
            if error is not None:
                self.say(error.detail if isinstance(error, UbError) else str(error))
                return
            if isinstance(value, dict):  # a period change: lasting, or temporary (uavbus.tools.changes)
                self.say(value["message"] if value.get("temporary") or value.get("owner") else
                         f"{entity}: done" if value["changed"] else f"{entity}: unchanged (it already was so)")
            else:
                self.say(f"{entity}: done" if value else f"{entity}: unchanged (it already was so)")
            self.load()

        self._start(call, done)

    def cancel(self) -> None:
        self.pending = None
        self._confirming(False)
        self.say("edit dropped")

    def _confirming(self, on: bool) -> None:
        self.query_one("#remote-confirm", Button).disabled = not on
        self.query_one("#remote-cancel", Button).disabled = not on

    def say(self, text: str) -> None:
        self.message = text
        self.query_one("#remote-message", Label).update(text)
