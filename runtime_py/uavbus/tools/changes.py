"""Changes an operator makes over the bus, with the truth about what they do (the console and the TUI).

A publish/subscribe row created by an administration row is renewed with that row's period (docs/inspect.md):
changing it at the target lasts only if the administrator's row changes too. So a period change first reads
the target's table to see who keeps the row:
 - nobody (a local row of the target): changed, done;
 - this operator's administration table: both changed, a lasting change;
 - another administrator: changed at the target now, restored at that administrator's next renewal. The
   answer says "temporary change", never "done".

Each function here is a task: a generator that yields `RemoteCall`s and gets their results back (drive it
with `RemoteCall.of_task(task)` in a UI loop, or a console's node thread).
"""

from __future__ import annotations

from collections.abc import Generator
from typing import Any


def g_set_period(node: Any, remote: Any, row: int, period_ms: int, me: str,
                 admin: Any | None) -> Generator[Any, Any, dict[str, Any]]:
    """Sets publish/subscribe row `row` of `remote`'s entity to `period_ms`; returns {"changed", "temporary",
    "owner", "message"}. `admin`: this operator's administration table (uavbus.Admin) on local entity `me`."""
    entity = remote.entity
    rows = yield remote.begin("table", "pubsub")
    mine = [x for x in rows if x["row"] == row]
    if not mine:
        raise LookupError(f"{entity} has no publish/subscribe row {row}")
    x = mine[0]
    changed = yield remote.begin("set_period", row, period_ms)
    owner = x.get("owner")
    if owner and owner != me:
        return {"changed": changed, "temporary": True, "owner": owner,
                "message": f"temporary change: {entity}'s row {row} ({x['content']}) is kept by administrator {owner}; "
                           f"its next renewal (about 1 s) restores {x['period_ms']} ms unless {owner} changes its "
                           "administration row. Not done."}
    if owner == me and admin is not None:
        lasting = [a for a in admin.rows() if a["content"] == x["content"] and
                   entity in (a.get("source"), a.get("destination"))]
        for a in lasting:
            yield node.remote(me, timeout=remote.timeout).begin("set_admin_row", a["row"], period_ms=period_ms)
        return {"changed": changed, "temporary": False, "owner": owner,
                "message": f"{entity}: row {row} every {period_ms} ms; this operator's administration row "
                           f"{', '.join(str(a['row']) for a in lasting) or '(none found)'} too, so it lasts"}
    return {"changed": changed, "temporary": False, "owner": owner,
            "message": f"{entity}: row {row} every {period_ms} ms" if changed else
            f"{entity}: row {row} already every {period_ms} ms"}
