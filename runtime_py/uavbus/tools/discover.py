"""Discovery: what an entity can offer before anyone subscribes (`uavbus list ENTITY`, the console, the TUI).

For each directory of the catalogue: whether the entity hosts it and lets this node read it (one short
INSPECT probe each, `Remote.probe`: no value travels), and the flows it has now (its publish/subscribe
table, when the entity lets this node list it). Probes go out `LANES` at a time.

    uavbus list fcs20 --config table2.json --node gcs --catalogue flightsw.catalogue.json [--port ...]
        [--all] [--json]
"""

from __future__ import annotations

import json
import sys
import time
from collections.abc import Generator
from typing import IO, Any

from uavbus.errors import UbError
from uavbus.tools.common import ArgumentParser
from uavbus.tools.tables import render_grid

LANES = 4  # UB_MAX_INSPECT_REQUESTS: probes in flight at once


def g_offer(remote: Any, catalogue: Any, names: list[str] | None = None) -> Generator[Any, Any, dict[str, Any]]:
    """A console task (yields RemoteCalls): the offer of `remote`'s entity, per catalogued directory."""
    from uavbus.remote import Remote
    from uavbus.units import units_of

    flows: dict[str, list[str]] = {}
    note = ""
    try:
        rows = yield remote.begin("table", "pubsub")
        for r in rows:
            what = (f"{r['kind']} to {r['peer']}" if r["kind"] == "publication" else f"{r['kind']} from {r['peer']}")
            flows.setdefault(r["content"], []).append(f"{what} every {r['period_ms']} ms")
    except UbError as exc:
        note = f"its flows are not shown: {getattr(exc, 'reason', None) or exc}"
    insts = [catalogue.instance(n) for n in names] if names else list(catalogue)
    bound: dict[str, str] = {}
    for k in range(0, len(insts), LANES):
        batch = [remote.begin("probe", i.name) for i in insts[k:k + LANES]]
        yield Remote.all(batch)
        for inst, call in zip(insts[k:k + LANES], batch):
            try:
                bound[inst.name] = call.result()
            except UbError as exc:
                bound[inst.name] = f"no answer ({type(exc).__name__})"
    out = []
    for inst in insts:
        b = bound.get(inst.name)
        units = units_of(catalogue, inst.type)
        out.append({"name": inst.name, "type": inst.type.name, "size": inst.type.packed_size,
                    "bound": b == "hosted", "probe": b, "flows": flows.get(inst.name, []),
                    "units": {k: v["unit"] for k, v in units.items() if "unit" in v}})
    hosted = sum(1 for r in out if r["bound"])
    return {"entity": remote.entity, "instances": out, "hosted": hosted, "catalogue": catalogue.name,
            "note": note or f"{hosted} of {len(out)} directories hosted and readable"}


def run_task(node: Any, gen: Generator[Any, Any, Any], timeout: float = 120.0) -> Any:
    """Drives a console task from a plain loop: polls the node, steps each RemoteCall it yields."""
    deadline = time.monotonic() + timeout
    call = next(gen)
    while True:
        while not call.step():
            node.poll(0.002)
            if time.monotonic() > deadline:
                raise TimeoutError("discovery took too long")
        try:
            value = call.result()
        except Exception as exc:  # noqa: BLE001 - handed to the task
            try:
                call = gen.throw(exc)
            except StopIteration as stop:
                return stop.value
            continue
        try:
            call = gen.send(value)
        except StopIteration as stop:
            return stop.value


def main(argv: list[str] | None = None, out: IO[str] | None = None) -> int:
    from uavbus.tools.source import add_node_args, open_node

    out = out or sys.stdout
    p = ArgumentParser(prog="uavbus list", description="what ENTITY offers: the directories it hosts (and lets this "
                                                       "node read), and its flows now, before subscribing")
    p.add_argument("entity", help="the entity to ask, e.g. fcs20")
    add_node_args(p)
    p.add_argument("--all", action="store_true", help="also list the directories it does not host")
    p.add_argument("--json", action="store_true", help="one JSON document instead of a table")
    p.add_argument("--timeout", type=float, default=2.0, help="seconds to wait for each answer (default 2)")
    args = p.parse_args(argv)
    session = open_node(args)
    try:
        node = session.node
        node.entity_index(args.entity)  # NotFoundError (bad input) if the table does not know it
        offer = run_task(node, g_offer(node.remote(args.entity, timeout=args.timeout), node.catalogue))
    finally:
        session.close()
    if args.json:
        print(json.dumps(offer, indent=1), file=out)
        return 0
    rows = [[r["name"], r["type"].removeprefix("struct "), r["size"], "yes" if r["bound"] else r["probe"],
             "; ".join(r["flows"]) or "-"]
            for r in offer["instances"] if args.all or r["bound"] or r["flows"]]
    print(f"-- {args.entity}: {offer['note']} (catalogue {offer['catalogue']}) --", file=out)
    print("\n".join(render_grid(["directory", "type", "bytes", "hosted", "flows now"], rows)), file=out)
    return 0
