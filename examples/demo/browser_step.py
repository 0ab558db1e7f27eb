"""`make demo`, browser step (issue 16): the variable browser over the bus, on the running Table 2.

Run inside the HITL part while its C processes run. Each is a check:
 - read, from the GCS, a directory of fcs20 (two hops away) that no flow publishes: fcs20's table says no
   row carries it, and its whole value comes back in one INSPECT request (round-trip time reported);
 - change a publication rate from the GCS: gpsOut rmax1ob1 -> gcs1, 100 ms -> 50 ms. The publication's
   row at rmax1ob1 changes at once (Remote.set_period); its administration row at gcs1 is changed in place
   too (set_admin_row), since the row's renewals carry the administration row's period (docs/inspect.md);
   gcs1 then receives about 20 Hz.

Returns the `"browser"` section of demo-out/summary.json.

    from browser_step import browser_part
    browser = browser_part(h, gps_row, check, say)
"""

from __future__ import annotations

import time
from typing import Any, Callable

CONTENT, TARGET = "airData", "fcs20"            # catalogued, defined by fcs20's program, published by no flow
RATE_FROM_MS, RATE_TO_MS = 100, 50
RATE_TOLERANCE = 0.15

Check = Callable[[str, bool, str], bool]


def browser_part(h: Any, gps_row: Any, check: Check, say: Callable[[str], None]) -> dict[str, Any]:
    say(f"\n-- variable browser over the bus: read {CONTENT} from {TARGET}, change a publication rate")
    out: dict[str, Any] = {}
    fcs = h.gcs.remote(TARGET)
    flows = [r for r in fcs.table("pubsub") if r["content"] == CONTENT]
    t = time.perf_counter()
    value = fcs.get(CONTENT)
    rtt_ms = (time.perf_counter() - t) * 1000.0
    out["read"] = {"entity": TARGET, "content": CONTENT, "hops": h.topo.hops("gcs", "backup"),
                   "fields": sorted(value), "rtt_ms": round(rtt_ms, 2), "rows_publishing_it": len(flows)}
    check(f"browser: read {CONTENT} from {TARGET}", not flows and "staticPressurePa" in value,
          f"{len(value)} fields in {rtt_ms:.1f} ms over {out['read']['hops']} hops; "
          f"{len(flows)} publish/subscribe rows of {TARGET} carry it")

    rmax = h.gcs.remote("rmax1ob1")
    (row,) = [r for r in rmax.table("pubsub") if r["content"] == "gpsOut" and r["peer"] == "gcs1"]
    changed = rmax.set_period(row["row"], RATE_TO_MS)
    h.gcs.remote("gcs1").set_admin_row(int(gps_row), period_ms=RATE_TO_MS)
    h.run_for(0.3)  # the next message at the new rate
    t0 = h.mark(f"gpsOut every {RATE_TO_MS} ms")
    h.run_for(1.2)  # across one renewal (1 s): the rate holds
    hz = h.meter("gpsOut", "rmax1ob1").rate_hz(t0, None)
    (after,) = [r["period_ms"] for r in rmax.table("pubsub") if r["row"] == row["row"]]
    want = 1000.0 / RATE_TO_MS
    out["rate"] = {"entity": "rmax1ob1", "content": "gpsOut", "row": row["row"], "period_ms": [row["period_ms"], after],
                   "achieved_hz": round(hz, 2), "requested_hz": want}
    check("browser: change a publication rate", changed and row["period_ms"] == RATE_FROM_MS and after == RATE_TO_MS
          and abs(hz - want) <= RATE_TOLERANCE * want,
          f"gpsOut rmax1ob1 -> gcs1: {row['period_ms']} ms -> {after} ms, {hz:.1f} Hz received for {want:g} Hz")
    return out
