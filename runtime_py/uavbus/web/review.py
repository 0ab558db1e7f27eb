"""Log review in the console (`uavbus web --log FILE`): a `.ublog` opened, a time slider, the same plots and map.

The log carries its own catalogue (docs/log-format.md): every DATA record is decoded once, duplicates (the
same source and sequence number again, e.g. over a second link) left out as the live tools do. The page asks
for the points of chosen fields between two times, and for each entity's position at a time (the last value
of its position directory at or before it: the console's position file, or any directory with a position).
"""

from __future__ import annotations

import bisect
import math
from pathlib import Path
from typing import Any

from uavbus.tools.common import Contents, Seen, entity_name
from uavbus.web.console import _field, _position, numeric_fields

_AUTO_POSITION = ("navFilterState.positionNed", "gpsOut")


class LogReview:
    def __init__(self, path: str | Path, positions: dict[str, str] | None = None) -> None:
        from uavbus.logfile import LogReader
        from uavbus.tools.common import load_catalogue

        self.path = Path(path)
        log = LogReader(path)
        self.header = log.header
        self.catalogue = load_catalogue(log.header.catalogue_json, f"{path}: embedded catalogue")
        contents = Contents(self.catalogue)
        self.positions_spec = dict(positions or {})
        # (content, source) -> sorted times (unix s) and decoded values
        self.flows: dict[tuple[str, str], tuple[list[float], list[Any]]] = {}
        seen: set[tuple[bytes, int]] = set()
        self.duplicates = self.undecodable = 0
        h = log.header
        for rec in log.records():
            if rec.header.admin != 0:
                continue
            key = (bytes(rec.header.src_id), rec.header.seq)
            if key in seen:
                self.duplicates += 1
                continue
            seen.add(key)
            unix = (h.start_unix_ms + rec.t_ms - h.start_t_ms) / 1000.0
            value = contents.decode(Seen(t_ms=rec.t_ms, link=rec.link, dir=rec.dir, header=rec.header, frame=rec.frame))
            if value is None:
                self.undecodable += 1
                continue
            ts, vs = self.flows.setdefault((contents.name(rec.header), entity_name(rec.header.src_id)), ([], []))
            ts.append(unix)
            vs.append(value)
        for ts, vs in self.flows.values():  # records are in file order; keep time order for bisect
            order = sorted(range(len(ts)), key=ts.__getitem__)
            ts[:] = [ts[i] for i in order]
            vs[:] = [vs[i] for i in order]
        times = [t for ts, _ in self.flows.values() for t in (ts[0], ts[-1])]
        self.t0, self.t1 = (min(times), max(times)) if times else (h.start_unix_ms / 1000.0,) * 2

    def info(self) -> dict[str, Any]:
        from uavbus.units import units_of

        flows = []
        for (content, source), (ts, vs) in sorted(self.flows.items()):
            span = ts[-1] - ts[0]
            units = units_of(self.catalogue, self.catalogue.instance(content).type) if \
                self.catalogue.find(content) is not None else {}
            flows.append({"content": content, "source": source, "messages": len(ts),
                          "rate_hz": round((len(ts) - 1) / span, 2) if span > 0 else None,
                          "fields": numeric_fields(vs[-1]),
                          "units": {k: v["unit"] for k, v in units.items() if v.get("unit")}})
        return {"mode": "review", "log": self.path.name, "node": self.header.node, "catalogue": self.catalogue.name,
                "t0": self.t0, "t1": self.t1, "flows": flows, "duplicates": self.duplicates,
                "undecodable": self.undecodable}

    def series(self, keys: list[tuple[str, str, str]], t0: float, t1: float) -> dict[str, Any]:
        out: dict[str, list[tuple[float, float]]] = {}
        for content, source, fld in keys:
            ts, vs = self.flows.get((content, source), ([], []))
            lo, hi = bisect.bisect_left(ts, t0), bisect.bisect_right(ts, t1)
            pts = []
            for t, v in zip(ts[lo:hi], vs[lo:hi]):
                x = _field(v, fld)
                if isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(float(x)):
                    pts.append((round(t, 4), float(x)))
            out[f"{content}@{source}:{fld}"] = pts
        return {"series": out, "t0": t0, "t1": t1}

    def positions(self, t: float) -> dict[str, Any]:
        """Each source's position at time `t`: the last value at or before it of its position directory."""
        sources = sorted({s for _, s in self.flows})
        out = []
        for src in sources:
            spec = self.positions_spec.get(src, self.positions_spec.get("*"))
            specs = [spec] if spec else ([] if spec == "" else list(_AUTO_POSITION))
            for sp in specs:
                content, _, fld = sp.partition(".")
                ts, vs = self.flows.get((content, src), ([], []))
                k = bisect.bisect_right(ts, t)
                if k == 0:
                    continue
                value = _field(vs[k - 1], fld) if fld else vs[k - 1]
                try:
                    pos = _position(value, sp)
                except ValueError:
                    continue
                out.append({"name": src, "state": "alive" if t - ts[k - 1] <= 2.0 else "stale", "local": False,
                            "position": pos, "age_s": round(t - ts[k - 1], 2)})
                break
        return {"me": self.header.node, "t": t, "entities": out}
