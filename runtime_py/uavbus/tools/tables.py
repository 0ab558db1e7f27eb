"""`uavbus tables`: the paper's variable browser as text (Figures 4, 5 and 8).

- entity table: every entity with its links (`link[i]`) and the link masks toward every other
  entity in the paper's hex notation, one hex digit per link (`0x00000011` = links 0 and 1);
- publish/subscribe table of each local entity (Figure 4), read from the C router;
- the global administration table (Figure 5): content, source, destination, period, type,
  activation, status;
- the node's bounded state: fragment slots, learned entities, compact dictionaries, with the counter of
  each bound.

The renderers are pure (rows in, lines out) so the TUI shows the very same tables.

    uavbus tables --config table2.json --node gcs --catalogue flightsw.catalogue.json
                  [--port NAME=SPEC]... [--subscribe CONTENT@SOURCE/MS]... [--duration S]
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from typing import IO, Any

from uavbus.config import Config, format_mask_hex

ADMIN_COLUMNS = ("row", "content", "source", "destination", "period_ms", "kind", "active", "status")


def entity_rows(config: Config) -> list[dict[str, Any]]:
    """One row per entity: index, name, hosted here, links, and the mask toward each entity."""
    rows = []
    for i, e in enumerate(config.entities):
        rows.append({"index": i, "entity": e.name, "local": e.name in config.hosts,
                     "links": list(e.links),
                     "linktoentity": {config.entities[j].name: format_mask_hex(m) for j, m in enumerate(e.masks)}})
    return rows


def render_grid(headers: Sequence[str], rows: Sequence[Sequence[Any]]) -> list[str]:
    """A plain left-aligned text grid; every cell is str()."""
    cells = [[str(c) for c in r] for r in rows]
    widths = [max([len(h)] + [len(r[k]) for r in cells]) for k, h in enumerate(headers)]
    line = lambda r: "  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip()  # noqa: E731
    return [line(list(headers)), line(["-" * w for w in widths])] + [line(r) for r in cells]


def render_entity_table(config: Config) -> list[str]:
    rows = entity_rows(config)
    hosts = ", ".join(config.hosts) or "none"
    out = [f"entity table ({config.system or config.path}; this node hosts {hosts})"]
    out += render_grid(["#", "entity", "local", "links (link[0], link[1], ...)"],
                       [[r["index"], r["entity"], "*" if r["local"] else "",
                         " ".join(f"[{k}]{name}" for k, name in enumerate(r["links"])) or "-"] for r in rows])
    out.append("")
    out.append("linktoentity (row: from, column: to; one hex digit per link, rightmost = link[0])")
    names = [r["entity"] for r in rows]
    out += render_grid(["from \\ to", *names], [[r["entity"], *(r["linktoentity"][n] for n in names)] for r in rows])
    return out


def render_dict_rows(title: str, rows: Sequence[dict[str, Any]], columns: Sequence[str] | None = None) -> list[str]:
    """A table of dict rows: `columns` first (those present), then any other keys, in first-seen order."""
    keys: dict[str, None] = dict.fromkeys(c for c in (columns or ()) if any(c in r for r in rows))
    for r in rows:
        keys.update(dict.fromkeys(r))
    if not rows:
        return [title, "  (empty)"]
    return [title, *render_grid(list(keys), [[_cell(r.get(k, "")) for k in keys] for r in rows])]


def _cell(v: Any) -> str:
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return f"{v:.6g}"
    return str(v)


def render_pubsub(entity: str, rows: Sequence[dict[str, Any]]) -> list[str]:
    return render_dict_rows(f"publish/subscribe table of {entity}", rows,
                            ("kind", "content", "peer", "source", "destination", "period_ms", "state"))


def render_admin(entity: str, rows: Sequence[dict[str, Any]]) -> list[str]:
    return render_dict_rows(f"global administration table ({entity})", rows, ADMIN_COLUMNS)


BOUND_COLUMNS = ("state", "counter", "value", "means")
_FRAG_BOUNDS = (("rx_refused", "fragments of new transfers refused: every slot busy with a transfer in progress"),
                ("rx_source_limit", "transfers replaced by a newer one of their source (slots per source)"),
                ("rx_evicted", "transfers dropped for a newcomer after protect_ms without progress"),
                ("rx_timeouts", "transfers dropped after timeout_ms without a new fragment"))
_ROUTE_BOUNDS = (("learned", "entities learned from route updates"),
                 ("learn_full", "entities not learned: the entity table was full"),
                 ("learn_expired", "learned entities removed: no update advertised them for learn_expiry_ms"),
                 ("neighbour_limit", "route entries ignored: their neighbour already advertised max_dests destinations"))
_COMPACT_BOUNDS = (("dict_changes", "the peer's dictionary replaced (epoch, catalogue or entity list)"),
                   ("dict_limited", "dictionary changes refused: unsigned, within change_min_ms of the last"))


def bound_rows(node: Any) -> list[dict[str, Any]]:
    """The counters of the node's bounded state (issue 29): fragment slots, learned entities, compact
    dictionaries -- each bound counted when it is hit."""
    rows = []
    frag = node.wire.fragment_counters()
    rows += [{"state": "fragments", "counter": k, "value": frag.get(k, 0), "means": m} for k, m in _FRAG_BOUNDS]
    if node.routing.enabled:
        rc = node.routing.counters()
        rows += [{"state": "routing", "counter": k, "value": rc.get(k, 0), "means": m} for k, m in _ROUTE_BOUNDS]
    for link, c in node.link_counters().items():
        compact = c.get("compact")
        if compact:
            rows += [{"state": f"compact {link}", "counter": k, "value": compact.get(k, 0), "means": m}
                     for k, m in _COMPACT_BOUNDS]
    return rows


def render_bounds(rows: Sequence[dict[str, Any]]) -> list[str]:
    return render_dict_rows("bounded state (what was refused or removed when a bound was hit)", rows, BOUND_COLUMNS)


def render_all(node: Any, config: Config) -> list[str]:
    """Every table of a live node (uavbus.Node) with its config."""
    out = render_entity_table(config)
    for entity in config.hosts:
        out.append("")
        out += render_pubsub(entity, node.pubsub_rows(entity))
    for entity in config.hosts:
        try:
            rows = node.admin(entity).rows()
        except (KeyError, LookupError, ValueError):
            continue  # this entity has no administration table
        if rows:
            out.append("")
            out += render_admin(entity, rows)
    out.append("")
    out += render_bounds(bound_rows(node))
    return out


def main(argv: list[str] | None = None, out: IO[str] | None = None) -> int:
    from uavbus.tools.common import ArgumentParser
    from uavbus.tools.source import add_node_args, open_node, run_node_for

    p = ArgumentParser(prog="uavbus tables", description="entity, publish/subscribe and administration "
                                "tables of a node (the paper's variable browser)")
    add_node_args(p, required=True)
    p.add_argument("--static", action="store_true", help="entity table of the config only; no node is started")
    args = p.parse_args(argv)
    out = out or sys.stdout
    if args.static:
        from uavbus.config import load_config

        config = load_config(args.config, args.node)  # a ConfigError is one line, status 3 (uavbus cli)
        print("\n".join(render_entity_table(config)), file=out)
        return 0
    session = open_node(args)
    try:
        run_node_for(session, args.duration)
        print("\n".join(render_all(session.node, session.config)), file=out)
    finally:
        session.close()
    return 0
