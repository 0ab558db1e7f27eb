"""`uavbus tui`: the paper's variable browser in the terminal (Textual).

    uavbus tui --config table2.json --node gcs --catalogue flightsw.catalogue.json [--port NAME=SPEC]...

Five tabs: the entity table with link masks in the paper's hex notation (Figure 8), the
publish/subscribe table of each local entity (Figure 4), the global administration table with a
form to fill in and activate a row (Figure 5), the values of every directory seen, and Remote: any
reachable entity's tables and directories read and changed over the bus (remote_view.py). The node is
the C router (uavbus.Node); the app drives its loop from a timer.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import Any

from textual.app import App, ComposeResult
from textual.containers import Horizontal, Vertical
from textual.widgets import Button, DataTable, Footer, Header, Input, Label, Select, TabbedContent, TabPane

from uavbus.tools.common import ArgumentParser, Stream, short_value
from uavbus.tools.source import NodeSession, add_node_args, open_node
from uavbus.tools.tables import ADMIN_COLUMNS, entity_rows
from uavbus.tui.remote_view import RemoteView

PUBSUB_COLUMNS = ("row", "kind", "content", "peer", "owner", "period_ms", "state", "frames")


class BrowserApp(App[None]):
    """The variable browser over one live node session.

    `pump` (tests) is called on every loop turn before the node is polled, e.g. to advance an
    injected clock and run an in-process peer node."""

    TITLE = "uavbus variable browser"
    BINDINGS = [("q", "quit", "Quit"), ("r", "refresh", "Refresh")]
    CSS = """
    #admin-form Input { width: 16; }
    #admin-form Select { width: 20; }
    #admin-form Button { min-width: 10; }
    DataTable { height: auto; max-height: 24; }
    """

    def __init__(self, session: NodeSession, admin_entity: str | None = None, poll_s: float = 0.02,
                 refresh_s: float = 0.2, pump: Callable[[], None] | None = None, live_s: float = 1.0) -> None:
        super().__init__()
        self.session = session
        self.admin_entity = admin_entity or session.config.hosts[0]
        self.poll_s, self.refresh_s, self.pump, self.live_s = poll_s, refresh_s, pump, live_s
        self.streams: dict[tuple[str, str], Stream] = {}
        self.admin_rows: list[Any] = []  # row handles returned by adm.add(), in table order
        self.message = ""
        self._shown: dict[str, list[tuple[str, ...]]] = {}
        self.selected: int | None = None  # admin row chosen in the table; None: the last one added
        self._remote_view: RemoteView | None = None
        self.turns = 0  # loop turns so far (tests: the UI kept running while a request was in flight)

    # -- layout ---------------------------------------------------------------------------------
    def compose(self) -> ComposeResult:
        yield Header()
        with TabbedContent(initial="tab-entities", id="tabs"):
            with TabPane("Entities", id="tab-entities"):
                yield Label("entity table: links of each entity (link[0], link[1], ...)")
                yield DataTable(id="entities", zebra_stripes=True)
                yield Label("linktoentity: row = from, column = to; one hex digit per link, rightmost = link[0]")
                yield DataTable(id="masks", zebra_stripes=True)
            with TabPane("Pub/Sub", id="tab-pubsub"):
                yield DataTable(id="pubsub", zebra_stripes=True)
            with TabPane("Admin", id="tab-admin"):
                with Vertical():
                    with Horizontal(id="admin-form"):
                        yield Input(placeholder="content", id="content")
                        yield Input(placeholder="source", id="source")
                        yield Input(placeholder="destination", id="destination")
                        yield Input(placeholder="period ms", id="period", type="integer")
                        yield Select([("publication", "publication"), ("subscription", "subscription")],
                                     value="publication", allow_blank=False, id="kind")
                        yield Button("Add", id="add", variant="primary")
                        yield Button("Activate", id="activate", variant="success")
                        yield Button("Deactivate", id="deactivate", variant="warning")
                    yield Label("", id="admin-message")
                    yield DataTable(id="admin", zebra_stripes=True, cursor_type="row")
            with TabPane("Values", id="tab-values"):
                yield DataTable(id="values", zebra_stripes=True)
            with TabPane("Remote", id="tab-remote"):
                yield RemoteView(self.session, live_s=self.live_s, admin=self.admin)
        yield Footer()

    def on_mount(self) -> None:
        cfg = self.session.config
        self.sub_title = f"{cfg.system or cfg.path}: hosting {', '.join(cfg.hosts)}"
        rows = entity_rows(cfg)
        ent = self.query_one("#entities", DataTable)
        ent.add_columns("#", "entity", "local", *(f"link[{k}]" for k in range(max(len(r["links"]) for r in rows))))
        for r in rows:
            ent.add_row(r["index"], r["entity"], "*" if r["local"] else "", *r["links"])
        masks = self.query_one("#masks", DataTable)
        names = [r["entity"] for r in rows]
        masks.add_columns("from \\ to", *names)
        for r in rows:
            masks.add_row(r["entity"], *(r["linktoentity"][n] for n in names))
        self.query_one("#pubsub", DataTable).add_columns("entity", *PUBSUB_COLUMNS)
        self.query_one("#admin", DataTable).add_columns(*ADMIN_COLUMNS)
        self.query_one("#values", DataTable).add_columns("name", "source", "msgs", "dups", "Hz", "seq", "last value")
        self.set_interval(self.poll_s, self.turn)
        self.set_interval(self.refresh_s, self.action_refresh)
        self.action_refresh()

    # -- node loop ------------------------------------------------------------------------------
    def turn(self) -> None:
        if self.pump is not None:
            self.pump()
        self.session.node.poll(timeout=0)
        self.turns += 1
        if self._remote_view is None:
            views = self.query(RemoteView)  # walks the DOM: done once, not on every turn
            self._remote_view = views.first() if views else None
        if self._remote_view is not None:
            self._remote_view.step()  # a remote request's answer, if it came (the UI never waits for one)
        contents = self.session.contents
        while self.session.seen:
            seen = self.session.seen.popleft()
            if not seen.is_data:
                continue
            key = (contents.name(seen.header), seen.source)
            st = self.streams.get(key)
            if st is None:
                st = self.streams[key] = Stream(*key)
            if st.add(seen.t_ms, seen.header.seq, None, len(seen.frame)):  # copies counted apart
                st.last = contents.labelled(seen, contents.decode(seen)) or st.last

    # -- tables ---------------------------------------------------------------------------------
    def admin(self) -> Any:
        return self.session.node.admin(self.admin_entity)

    def admin_table_rows(self) -> list[dict[str, Any]]:
        out = []
        for k, row in enumerate(self.admin().rows()):
            r = dict(row)
            r.setdefault("row", k)
            out.append(r)
        return out

    def _fill(self, table_id: str, rows: list[tuple[str, ...]]) -> None:
        """Rebuilds a table only when its rows changed (rebuilding costs far more than comparing)."""
        if self._shown.get(table_id) == rows:
            return
        self._shown[table_id] = rows
        table = self.query_one(f"#{table_id}", DataTable)
        cursor = table.cursor_row
        table.clear()
        for r in rows:
            table.add_row(*r)
        if 0 <= cursor < len(rows):
            table.move_cursor(row=cursor)

    def action_refresh(self) -> None:
        if not self.query("#tabs"):
            return  # the app is exiting and its screen is gone, but a refresh timer can still fire
        self._fill("pubsub", [(entity, *(str(r.get(c, "")) for c in PUBSUB_COLUMNS))
                              for entity in self.session.config.hosts
                              for r in self.session.node.pubsub_rows(entity)])
        self._fill("admin", [tuple(str(r.get(c, "")) for c in ADMIN_COLUMNS) for r in self.admin_table_rows()])
        values = []
        for (name, source), st in sorted(self.streams.items()):
            rate = st.rate()
            values.append((name, source, str(st.unique), str(st.duplicates), f"{rate:.2f}" if rate is not None else "-",
                           str(st.last_seq),
                           short_value(st.last, 120) if st.last is not None else "(not decodable)"))
        self._fill("values", values)
        if self.query_one("#tabs", TabbedContent).active == "tab-remote":
            self.query_one(RemoteView).live()

    # -- administration form (Figure 5) ---------------------------------------------------------
    def on_button_pressed(self, event: Button.Pressed) -> None:
        label = self.query_one("#admin-message", Label)
        try:
            if event.button.id == "add":
                self.add_row()
            elif event.button.id in ("activate", "deactivate"):
                handle = self.selected_row()
                if event.button.id == "activate":
                    self.admin().activate(handle)
                else:
                    self.admin().deactivate(handle)
                self.message = f"row {handle}: {event.button.id}d"
        except (ValueError, LookupError, RuntimeError) as exc:
            self.message = f"error: {exc}"
        label.update(self.message)
        self.action_refresh()

    def add_row(self) -> Any:
        values = {k: self.query_one(f"#{k}", Input).value.strip() for k in ("content", "source", "destination", "period")}
        missing = [k for k, v in values.items() if not v]
        if missing:
            raise ValueError(f"fill in {', '.join(missing)}")
        kind = str(self.query_one("#kind", Select).value)
        node = self.session.node
        if kind == "subscription" and values["destination"] in self.session.config.hosts \
                and node.directory(values["content"]) is None:
            node.bind(values["content"])  # the local destination needs storage for the data it asks for
        handle = self.admin().add(content=values["content"], source=values["source"],
                                  destination=values["destination"], period_ms=int(values["period"]), kind=kind)
        self.admin_rows.append(handle)
        self.selected = None
        self.message = f"row {handle} added ({kind} of {values['content']}, {values['source']} -> " \
                       f"{values['destination']} every {values['period']} ms): select it and press Activate"
        return handle

    def on_data_table_row_selected(self, event: DataTable.RowSelected) -> None:
        if event.data_table.id == "admin":
            rows = self.admin_table_rows()
            if 0 <= event.cursor_row < len(rows):
                self.selected = int(rows[event.cursor_row]["row"])
                self.query_one("#admin-message", Label).update(f"row {self.selected} selected")

    def selected_row(self) -> int:
        """The admin row last selected in the table (click or Enter), else the last row added here."""
        if self.selected is not None:
            return self.selected
        if self.admin_rows:
            return int(self.admin_rows[-1])
        raise ValueError("add a row first (fill in the form and press Add)")

    def row_status(self, handle: Any) -> str:
        return str(self.admin().status(handle)["status"])


def main(argv: list[str] | None = None) -> int:
    p = ArgumentParser(prog="uavbus tui", description="terminal variable browser: entity, "
                                "publish/subscribe and administration tables, live values")
    add_node_args(p, required=True)
    p.add_argument("--admin-entity", help="hosted entity whose administration table to use (default: the first)")
    args = p.parse_args(argv)
    session = open_node(args)
    try:
        BrowserApp(session, admin_entity=args.admin_entity).run()
    finally:
        session.close()
    return 0
