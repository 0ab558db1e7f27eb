"""`uavbus log export FILE --mcap OUT`: a binary log as an MCAP file that Foxglove and PlotJuggler open.

One **channel per directory and source**, topic `/<source entity>/<directory>` (`/rmax1ob1/gpsOut`,
`/mavbridge/ATTITUDE_30`), JSON messages (`message_encoding` "json") whose **JSON Schema** (schema
encoding "jsonschema", one per catalogue type, named after it) is generated from the log's own
catalogue; channel metadata names the source, the directory, its type and the catalogue.
Each DATA frame of the log is one message: log and publish time = the record's time as Unix ns
(`start_unix_ms + t_ms - start_t_ms`, docs/log-format.md), sequence = the frame's sequence number.
A frame recorded twice (received on two links, or received then forwarded: same source and
sequence) is written once. Administrative frames carry no directory value and are not exported, nor
are ENCRYPTED frames (their payload is ciphertext to a log reader; counted). Signed frames are exported
(their payload is in clear; the log holds only frames the node verified).

Values are the catalogue's decoding (uavbus.catalogue), shaped for the tools' JSON Schema readers
(Foxglove's takes one type per field and one array dimension):
  - integers and floats as JSON numbers, bools as JSON booleans, nested structs as objects;
  - arrays as JSON arrays; an array of two or more dimensions is written **row-major as one array**
    (its schema says the dimensions), e.g. `float m[2][3]` as 6 numbers, `m[1][2]` at index 5;
  - a NaN or infinite float has no JSON number: it is written as null and counted
    (`non_finite`); such a message does not validate against its schema, and the export says so.
The catalogue itself is attached (`catalogue.json`), and a metadata record `uavbus` keeps the log's
node, links and start time. Units and descriptions from the headers' comments are in the schemas' property
"description" and "unit". A directory with a latitude and a longitude in degrees (gpsOut) also gets a channel
`/<source>/<directory>/location` in Foxglove's `foxglove.LocationFix` schema, which its map panel shows.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from typing import Any

from uavbus.catalogue import Catalogue, Field, Type
from uavbus.tools.common import entity_name

INT_RANGES = {"u8": (0, 2**8 - 1), "i8": (-(2**7), 2**7 - 1), "u16": (0, 2**16 - 1), "i16": (-(2**15), 2**15 - 1),
              "u32": (0, 2**32 - 1), "i32": (-(2**31), 2**31 - 1), "u64": (0, 2**64 - 1),
              "i64": (-(2**63), 2**63 - 1)}


def topic(source: str, directory: str) -> str:
    return f"/{source}/{directory}"


def _leaf_schema(f: Field, catalogue: Catalogue) -> dict[str, Any]:
    if f.struct is not None:
        return type_schema(catalogue.type(f.struct), catalogue)
    wire = f.wire or ""
    if wire == "bool":
        return {"type": "boolean"}
    if wire in ("f32", "f64"):
        return {"type": "number"}
    lo, hi = INT_RANGES[wire]
    if f.bits is not None:
        lo, hi = (-(1 << (f.bits - 1)), (1 << (f.bits - 1)) - 1) if wire.startswith("i") else (0, (1 << f.bits) - 1)
    return {"type": "integer", "minimum": lo, "maximum": hi}


def type_schema(t: Type, catalogue: Catalogue) -> dict[str, Any]:
    """The JSON Schema of a catalogue type's values as exported (module docstring). A member whose header
    comment gave a unit or a description (docs/catalogue.md#units) says so in its "description" ("[rad/s]
    roll rate, body x") and its "unit"."""
    from uavbus.units import units_of

    units = units_of(catalogue, t)
    props: dict[str, Any] = {}
    for f in t.packed_fields:
        leaf = _leaf_schema(f, catalogue)
        if f.dims:
            n = math.prod(f.dims)
            leaf = {"type": "array", "items": leaf, "minItems": n, "maxItems": n}
            if len(f.dims) > 1:
                leaf["description"] = "row-major " + "".join(f"[{d}]" for d in f.dims)
        said = units.get(f.name)
        if said:
            leaf = dict(leaf)
            text = " ".join(x for x in (f"[{said['unit']}]" if said.get("unit") else "", said.get("doc") or "",
                                         leaf.get("description", "")) if x)
            leaf["description"] = text
            if said.get("unit"):
                leaf["unit"] = said["unit"]
        props[f.name] = leaf
    return {"type": "object", "title": t.name, "properties": props, "required": list(props),
            "additionalProperties": False}


# Foxglove's map panel shows foxglove.LocationFix messages: a directory with a latitude and a longitude (gpsOut)
# gets a second channel `/<source>/<directory>/location` in that schema, beside its own.
LOCATION_SCHEMA = {
    "$schema": "https://json-schema.org/draft/2020-12/schema", "title": "foxglove.LocationFix", "type": "object",
    "properties": {
        "timestamp": {"type": "object", "properties": {"sec": {"type": "integer", "minimum": 0},
                                                       "nsec": {"type": "integer", "minimum": 0}}},
        "frame_id": {"type": "string"},
        "latitude": {"type": "number", "description": "degrees"},
        "longitude": {"type": "number", "description": "degrees"},
        "altitude": {"type": "number", "description": "meters"},
        "position_covariance": {"type": "array", "items": {"type": "number"}, "minItems": 9, "maxItems": 9},
        "position_covariance_type": {"type": "integer", "minimum": 0, "maximum": 3},
    },
}
_LAT, _LON, _ALT = ("latitudeDeg", "latitude", "lat"), ("longitudeDeg", "longitude", "lon"), \
    ("altitudeMsl", "altitude", "alt")


def location_fields(t: Type) -> tuple[str, str, str | None] | None:
    """(latitude, longitude, altitude or None) member names of a type with a position in degrees, else None."""
    names = {f.name for f in t.packed_fields if f.wire in ("f32", "f64") and not f.dims}
    lat = next((n for n in _LAT if n in names), None)
    lon = next((n for n in _LON if n in names), None)
    if lat is None or lon is None:
        return None
    return lat, lon, next((n for n in _ALT if n in names), None)


def location_fix(value: dict[str, Any], fields: tuple[str, str, str | None], t_ns: int, frame: str) -> dict[str, Any]:
    lat, lon, alt = fields
    return {"timestamp": {"sec": t_ns // 1_000_000_000, "nsec": t_ns % 1_000_000_000}, "frame_id": frame,
            "latitude": float(value[lat]), "longitude": float(value[lon]),
            "altitude": float(value[alt]) if alt else 0.0, "position_covariance": [0.0] * 9,
            "position_covariance_type": 0}


def schema_document(t: Type, catalogue: Catalogue) -> dict[str, Any]:
    doc = type_schema(t, catalogue)
    return {"$schema": "https://json-schema.org/draft/2020-12/schema", **doc}


def _flat(value: Any) -> list[Any]:
    if isinstance(value, list):
        return [x for v in value for x in _flat(v)]
    return [value]


@dataclass
class McapStats:
    messages: int = 0
    channels: int = 0
    duplicates: int = 0          # frames recorded twice (same source and sequence)
    not_data: int = 0            # administrative frames
    unknown_content: int = 0     # DATA of a content the log's catalogue does not have
    layout_mismatch: int = 0     # DATA packed from another definition (fingerprint differs)
    non_finite: int = 0          # floats written as null
    encrypted: int = 0           # ENCRYPTED frames: their payload is ciphertext to a log reader without the key
    by_topic: dict[str, int] = field(default_factory=dict)


class _Shaper:
    """Decoded values -> exported JSON values, per type (flattens arrays, nulls non-finite floats)."""

    def __init__(self, catalogue: Catalogue, stats: McapStats) -> None:
        self.catalogue, self.stats = catalogue, stats

    def value(self, t: Type, v: dict[str, Any]) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for f in t.packed_fields:
            x = v[f.name]
            if f.dims:
                out[f.name] = [self.leaf(f, e) for e in (_flat(x) if len(f.dims) > 1 else x)]
            else:
                out[f.name] = self.leaf(f, x)
        return out

    def leaf(self, f: Field, x: Any) -> Any:
        if f.struct is not None:
            return self.value(self.catalogue.type(f.struct), x)
        if isinstance(x, float) and not math.isfinite(x):
            self.stats.non_finite += 1
            return None
        return x


def export_mcap(log: Any, out_path: str, only: set[str] | None = None) -> McapStats:
    """Writes `log` (a uavbus.logfile.LogReader) to `out_path` as MCAP; returns what was written and skipped."""
    from mcap.writer import Writer

    from uavbus import __version__ as version
    from uavbus._bindings.ub_frame import FLAG_ENCRYPTED
    from uavbus._ub import lib

    catalogue: Catalogue = log.catalogue()
    h = log.header
    stats = McapStats()
    shaper = _Shaper(catalogue, stats)
    schemas: dict[str, int] = {}
    location_sid: int | None = None
    channels: dict[tuple[str, str], int] = {}
    seen: set[tuple[bytes, int]] = set()
    with open(out_path, "wb") as f:
        w = Writer(f)
        w.start(profile="", library=f"uavbus {version}")
        w.add_metadata("uavbus", {"node": h.node, "links": json.dumps(h.links), "catalogue": catalogue.name,
                                  "start_unix_ms": str(h.start_unix_ms), "start_t_ms": str(h.start_t_ms)})
        w.add_attachment(create_time=h.start_unix_ms * 1_000_000, log_time=h.start_unix_ms * 1_000_000,
                         name="catalogue.json", media_type="application/json",
                         data=catalogue.json_text.encode("utf-8"))
        for rec in log:
            hd = rec.header
            if hd.admin != lib.UB_ADMIN_DATA:
                stats.not_data += 1
                continue
            if hd.flags & FLAG_ENCRYPTED:
                stats.encrypted += 1
                continue
            inst = catalogue.find(bytes(hd.dir_id))
            if inst is None:
                stats.unknown_content += 1
                continue
            if only is not None and inst.name not in only:
                continue
            if hd.fingerprint != inst.type.fingerprint or hd.payload_size < inst.type.packed_size:
                stats.layout_mismatch += 1
                continue
            key = (bytes(hd.src_id), hd.seq)
            if key in seen:
                stats.duplicates += 1
                continue
            seen.add(key)
            source = entity_name(hd.src_id)
            ch = channels.get((source, inst.name))
            if ch is None:
                sid = schemas.get(inst.type.name)
                if sid is None:
                    sid = schemas[inst.type.name] = w.register_schema(
                        name=inst.type.name, encoding="jsonschema",
                        data=json.dumps(schema_document(inst.type, catalogue)).encode("utf-8"))
                ch = channels[(source, inst.name)] = w.register_channel(
                    topic=topic(source, inst.name), message_encoding="json", schema_id=sid,
                    metadata={"source": source, "directory": inst.name, "type": inst.type.name,
                              "catalogue": catalogue.name})
            value = shaper.value(inst.type, catalogue.decode(inst, rec.payload))
            t_ns = (h.start_unix_ms + rec.t_ms - h.start_t_ms) * 1_000_000
            w.add_message(channel_id=ch, log_time=t_ns, publish_time=t_ns, sequence=hd.seq & 0xFFFFFFFF,
                          data=json.dumps(value, separators=(",", ":"), allow_nan=False).encode("utf-8"))
            stats.messages += 1
            name = topic(source, inst.name)
            stats.by_topic[name] = stats.by_topic.get(name, 0) + 1
            loc = location_fields(inst.type)
            if loc is not None and all(isinstance(value.get(k), (int, float)) for k in loc if k):
                lch = channels.get((source, inst.name + "/location"))
                if lch is None:
                    if location_sid is None:
                        location_sid = w.register_schema(name="foxglove.LocationFix", encoding="jsonschema",
                                                         data=json.dumps(LOCATION_SCHEMA).encode("utf-8"))
                    lch = channels[(source, inst.name + "/location")] = w.register_channel(
                        topic=name + "/location", message_encoding="json", schema_id=location_sid,
                        metadata={"source": source, "directory": inst.name, "type": "foxglove.LocationFix",
                                  "catalogue": catalogue.name})
                w.add_message(channel_id=lch, log_time=t_ns, publish_time=t_ns, sequence=hd.seq & 0xFFFFFFFF,
                              data=json.dumps(location_fix(value, loc, t_ns, source)).encode("utf-8"))
                stats.by_topic[name + "/location"] = stats.by_topic.get(name + "/location", 0) + 1
        w.finish()
    stats.channels = len(channels)
    return stats


def cmd_export_mcap(args: Any, out: Any) -> int:
    """`uavbus log export FILE --mcap OUT [--only NAME...]` (tools/logcmd.py)."""
    import sys

    from uavbus.tools.logcmd import open_log

    if args.output:
        raise SystemExit("uavbus log export: --mcap OUT names the output file; -o is for --csv/--jsonl")
    log = open_log(args.file, getattr(args, "catalogue", None))
    catalogue = log.catalogue()
    only = {n for item in args.only for n in item.split(",") if n} if args.only else None
    missing = sorted(n for n in (only or ()) if catalogue.find(n) is None)
    if missing:
        raise SystemExit(f"{args.file}: --only {' '.join(missing)}: not in the log's catalogue '{catalogue.name}'")
    stats = export_mcap(log, args.mcap, only)
    print(json.dumps({"event": "exported", "file": args.file, "mcap": args.mcap, "messages": stats.messages,
                      "channels": stats.channels, "duplicates": stats.duplicates, "not_data": stats.not_data,
                      "unknown_content": stats.unknown_content, "layout_mismatch": stats.layout_mismatch,
                      "non_finite": stats.non_finite, "encrypted": stats.encrypted, "ignored_bytes": log.stats.ignored_bytes}), file=out)
    if stats.non_finite:
        print(f"{args.mcap}: {stats.non_finite} NaN or infinite floats written as null (JSON has no such number): "
              "those messages do not match their schema's number type", file=sys.stderr)
    if stats.encrypted:
        print(f"{args.file}: {stats.encrypted} ENCRYPTED frames were not exported (their payload is ciphertext here)",
              file=sys.stderr)
    if stats.unknown_content or stats.layout_mismatch:
        print(f"{args.file}: {stats.unknown_content} frames of unknown content and {stats.layout_mismatch} with "
              "another layout were not exported (no schema for them)", file=sys.stderr)
    return 0
