"""`uavbus log info|export|play FILE`: read, export and replay binary logs (docs/log-format.md).

    uavbus log info FILE [--catalogue CAT.json]
    uavbus log export FILE (--csv | --jsonl) [--only NAME[,NAME...]]... [--admin] [--numeric] [-o OUT]
    uavbus log export FILE --mcap OUT [--only NAME[,NAME...]]...
    uavbus log play FILE --into SPEC [--only NAME[,NAME...]]... [--speed X | --fast] [--dir rx|tx|all]
    uavbus log play FILE --to ENTITY --into PORTSPEC [--as NAME | --map SRC=NAME...] [--key FILE [--identity FILE]]
                     [--only ...]

Every subcommand takes `--catalogue CAT.json`: the catalogue to decode with instead of the one embedded in the
log, for a log whose header (both copies) is damaged or that has none.
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
import time
from collections import Counter, defaultdict
from collections.abc import Callable, Iterable
from typing import IO, Any

from uavbus.logfile import LogReader, LogRecord
from uavbus.tools.common import (
    ArgumentParser, Contents, Seen, Stream, admin_name, flatten, human_time, iso_time, jsonable, load_catalogue,
    positive,
)
from uavbus.tools.endpoint import SpecError, open_sink
from uavbus.tools.source import log_unix_ms


def _seen(log: LogReader, rec: LogRecord) -> Seen:
    return Seen(t_ms=rec.t_ms, link=rec.link, dir=rec.dir, header=rec.header, frame=rec.frame,
                unix_ms=log_unix_ms(log.header, rec.t_ms))


class _Copies:
    """Tells the first frame of a (direction, source, sequence) from its copies (redundant links)."""

    def __init__(self) -> None:
        self.streams: dict[tuple[str, str], Stream] = {}

    def first(self, rec: LogRecord) -> bool:
        key = (rec.dir, rec.header.src_id.rstrip(b"\0").decode("ascii", "replace"))
        st = self.streams.setdefault(key, Stream("", key[1]))
        return st.add(rec.t_ms, rec.header.seq, None)


def open_log(path: str, catalogue: str | None) -> LogReader:
    """The log at `path`, decoded with the catalogue file `catalogue` when given (`--catalogue`)."""
    if catalogue is None:
        return LogReader(path)
    try:
        text = open(catalogue, encoding="utf-8").read()  # noqa: SIM115 (read at once)
    except (OSError, UnicodeDecodeError) as exc:
        raise SystemExit(f"{catalogue}: cannot read the catalogue given with --catalogue: {exc}") from None
    return LogReader(path, catalogue_json=text, catalogue_origin=f"--catalogue {catalogue}")


def _open(path: str, catalogue: str | None = None) -> tuple[LogReader, Contents]:
    log = open_log(path, catalogue)
    log.records()
    return log, Contents(load_catalogue(log.header.catalogue_json, f"{path}: {log.header.catalogue_origin}"))


def _check_only(contents: Contents, only: list[str] | None, path: str) -> set[str] | None:
    if not only:
        return None
    only = [name for item in only for name in item.split(",") if name]
    missing = [n for n in only if not contents.known(n)]
    if missing:
        raise SystemExit(f"{path}: --only {' '.join(missing)}: not in the log's catalogue "
                         f"'{contents.catalogue.name}' (names are instance names, e.g. gpsOut)")
    return set(only)


def _truncation_note(log: LogReader) -> str:
    """What the reader skipped (damage, a cut tail) and what the sequence numbers say is missing; "" if none."""
    s = log.stats
    parts = []
    if s.ignored_bytes:
        parts.append(f"ignored {s.ignored_bytes} bytes: {s.ignored_reason}")
    if s.missing_records:
        parts.append(f"{s.missing_records} records missing by their sequence numbers (not written, or lost to damage)")
    return f"{log.path}: " + "; ".join(parts) if parts else ""


def cmd_info(args: argparse.Namespace, out: IO[str]) -> int:
    log, contents = _open(args.file, args.catalogue)
    h, cat, recs = log.header, contents.catalogue, log.records()
    print(f"log:        {log.path} (format {h.version})", file=out)
    if h.header_note():
        print(f"header:     {h.header_note()}", file=out)
    if not h.lost:
        print(f"node:       {h.node}", file=out)
        print(f"started:    {human_time(h.start_unix_ms or None)} (unix ms {h.start_unix_ms}, node clock "
              f"{h.start_t_ms} ms); {'received and sent' if h.record_tx else 'received'} frames recorded", file=out)
    print(f"catalogue:  {cat.name} (id scheme {cat.id_scheme}, {len(cat.types)} types, "
          f"{len(cat.instances)} instances; {h.catalogue_origin})", file=out)
    if h.max_files:
        deleted = f"; starting it deleted file {h.deleted_file}" if h.deleted_file is not None else ""
        print(f"rotation:   file {h.file_index} of a set that keeps {h.max_files} files{deleted}", file=out)
    print("links:      " + (", ".join(f"{k}={v}" for k, v in sorted(h.links.items())) or "none"), file=out)
    print(f"records:    {len(recs)} ({log.stats.record_bytes} bytes)", file=out)
    if recs:
        t0, t1 = recs[0].t_ms, recs[-1].t_ms
        print(f"time span:  {t0} .. {t1} ms ({(t1 - t0) / 1000:.3f} s): "
              f"{human_time(log_unix_ms(h, t0))} .. {human_time(log_unix_ms(h, t1))}", file=out)
    by_link: Counter[tuple[str, str]] = Counter((r.link, r.dir) for r in recs)
    for (link, d), n in sorted(by_link.items()):
        print(f"  {link:<24} {d}  {n}", file=out)
    # A message is one (source, sequence); the same frame again (the copy a 0x11 mask sends over the
    # second link) is a duplicate, counted apart and left out of the rate.
    copies = _Copies()
    groups: dict[tuple[str, str, str], list[int]] = defaultdict(list)
    dups: Counter[tuple[str, str, str]] = Counter()
    for r in recs:
        key = (contents.name(r.header), admin_name(r.header.admin), r.dir)
        if copies.first(r):
            groups[key].append(r.t_ms)
        else:
            dups[key] += 1
            groups.setdefault(key, [])
    if groups:
        print("contents (msgs: unique (source, sequence); dups: copies of them, e.g. over redundant links):",
              file=out)
        print(f"  {'name':<28} {'kind':<12} {'dir':<4} {'msgs':>7} {'rate Hz':>9} {'dups':>7}", file=out)
        for key, times in sorted(groups.items()):
            name, kind, d = key
            span = (times[-1] - times[0]) / 1000.0 if times else 0.0
            rate = f"{(len(times) - 1) / span:9.2f}" if len(times) > 1 and span > 0 else f"{'-':>9}"
            print(f"  {name:<28} {kind:<12} {d:<4} {len(times):>7} {rate} {dups[key]:>7}", file=out)
    if log.stats.bad_frames:
        print(f"bad frames: {log.stats.bad_frames} (record CRC held, frame check failed: {log.stats.by_reason})",
              file=out)
    note = _truncation_note(log)
    print("damage:     " + (note or "none (nothing skipped, nothing missing)"), file=out)
    return 0


def _export_rows(log: LogReader, contents: Contents, only: set[str] | None,
                 admin: bool, numeric: bool) -> Iterable[tuple[LogRecord, str, dict[str, Any] | None, bool]]:
    copies = _Copies()
    for rec in log.records():
        first = copies.first(rec)
        name = contents.name(rec.header)
        if only is not None and name not in only:
            continue
        seen = _seen(log, rec)
        if not seen.is_data and not admin:
            continue
        value = contents.decode(seen)
        yield rec, name, value if numeric else contents.labelled(seen, value), not first


def _meta(log: LogReader, rec: LogRecord, name: str, dup: bool) -> dict[str, Any]:
    h = rec.header
    return {"t_ms": rec.t_ms, "time": iso_time(log_unix_ms(log.header, rec.t_ms)), "link": rec.link, "dir": rec.dir,
            "name": name, "source": h.src_id.rstrip(b"\0").decode("ascii", "replace"),
            "dest": h.dest_id.rstrip(b"\0").decode("ascii", "replace"),
            "seq": h.seq, "kind": admin_name(h.admin), "dup": int(dup)}


def cmd_export(args: argparse.Namespace, out: IO[str]) -> int:
    log, contents = _open(args.file, args.catalogue)
    only = _check_only(contents, args.only, args.file)
    rows = list(_export_rows(log, contents, only, args.admin, args.numeric))
    if args.jsonl:
        for rec, name, value, dup in rows:
            line = _meta(log, rec, name, dup)
            if value is not None:
                line["value"] = jsonable(value)
            out.write(json.dumps(line, separators=(",", ":"), allow_nan=False) + "\n")
    else:
        # One table for every content: the union of the leaf columns, in order of first appearance,
        # empty where a row's content has no such field. Floats are written with repr (exact).
        flat = [dict(flatten(v)) if v is not None else {} for _, _, v, _ in rows]
        columns: dict[str, None] = {}
        for f in flat:
            columns.update(dict.fromkeys(f))
        writer = csv.writer(out, lineterminator="\n")
        base = ["t_ms", "time", "link", "dir", "name", "source", "dest", "seq", "kind", "dup"]
        writer.writerow(base + list(columns))
        for (rec, name, _, dup), f in zip(rows, flat):
            m = _meta(log, rec, name, dup)
            writer.writerow([m[k] for k in base] + [_cell(f.get(c, "")) for c in columns])
    note = _truncation_note(log)
    if note:
        print(note, file=sys.stderr)
    if contents.unknown or contents.layout_mismatch:
        print(f"{args.file}: {contents.unknown} frames of unknown content and {contents.layout_mismatch} "
              "with another layout were exported without values", file=sys.stderr)
    return 0


def _cell(v: Any) -> Any:
    return repr(v) if isinstance(v, float) else jsonable(v)


def cmd_play(args: argparse.Namespace, out: IO[str], sleep: Callable[[float], None] = time.sleep,
             clock: Callable[[], float] = time.monotonic) -> int:
    log, contents = _open(args.file, getattr(args, "catalogue", None))
    only = _check_only(contents, args.only, args.file)
    dirs = {"rx": ("rx",), "tx": ("tx",), "all": ("rx", "tx")}[args.dir]
    chosen = [r for r in log.records()
              if r.dir in dirs and (only is None or contents.name(r.header) in only)]
    if args.to:
        from uavbus.tools.playto import play_to

        return play_to(log, contents, chosen, args, out, clock=clock)
    if args.as_name or args.map or args.key or args.identity:
        raise SystemExit("uavbus log play: --as, --map, --key and --identity go with --to ENTITY (the player as an "
                         "entity); "
                         "without --to the recorded frames are sent as they are")
    try:
        sink = open_sink(args.into)
    except SpecError as exc:
        raise SystemExit(f"uavbus log play: {exc}") from None
    sent = 0
    try:
        start_wall = clock()
        t0 = chosen[0].t_ms if chosen else 0
        for rec in chosen:
            if not args.fast:
                due = start_wall + (rec.t_ms - t0) / 1000.0 / args.speed
                wait = due - clock()
                if wait > 0:
                    sleep(wait)
            sink.send(rec.frame)
            sent += 1
    finally:
        sink.close()
    print(json.dumps({"event": "played", "file": args.file, "into": args.into, "frames": sent,
                      "skipped": len(log.records()) - sent, "ignored_bytes": log.stats.ignored_bytes}), file=out)
    return 0


def add_catalogue_arg(p: argparse.ArgumentParser) -> None:
    """The shared `--catalogue` of every log subcommand."""
    p.add_argument("--catalogue", metavar="CAT.json",
                   help="decode with this catalogue (<name>.catalogue.json) instead of the log's embedded one: "
                        "for a log whose header is damaged (both copies) or that has no catalogue")


def build_parser() -> argparse.ArgumentParser:
    p = ArgumentParser(prog="uavbus log", description="read, export and replay uavbus binary logs")
    sub = p.add_subparsers(dest="cmd", required=True)
    info = sub.add_parser("info", help="node, catalogue, links, records by link and content, truncated tail")
    info.add_argument("file")
    add_catalogue_arg(info)
    exp = sub.add_parser("export", help="decoded values as CSV or JSON lines (to stdout or -o)")
    exp.add_argument("file")
    add_catalogue_arg(exp)
    fmt = exp.add_mutually_exclusive_group(required=True)
    fmt.add_argument("--csv", action="store_true")
    fmt.add_argument("--jsonl", action="store_true")
    fmt.add_argument("--mcap", metavar="OUT", help="an MCAP file for Foxglove and PlotJuggler (tools/mcap_export.py)")
    exp.add_argument("--only", action="append", metavar="NAME[,NAME...]",
                     help="only these contents (instance names); repeat it or separate names with commas")
    exp.add_argument("--admin", action="store_true", help="also export administrative frames (no values)")
    exp.add_argument("-o", "--output", help="write here instead of stdout")
    exp.add_argument("--numeric", action="store_true",
                     help="enum members as numbers (default: their constants' names, from the catalogue)")
    play = sub.add_parser("play", help="send the recorded frames, as they are, into a node")
    play.add_argument("file")
    add_catalogue_arg(play)
    play.add_argument("--into", required=True, metavar="SPEC",
                      help="udp:peer=HOST:PORT[,bind=HOST:PORT] | tcp:connect=HOST:PORT | serial:device=PATH[,baud=N]. "
                           "Over UDP the frames come from an ephemeral port (or bind=): the receiving port must "
                           "accept them, i.e. have no fixed peer (udp:bind=HOST:PORT, it learns its peers) or "
                           "accept=any; a fixed-peer port refuses them and says so once")
    play.add_argument("--only", action="append", metavar="NAME[,NAME...]",
                      help="only frames of these contents; repeat it or separate names with commas")
    pace = play.add_mutually_exclusive_group()
    pace.add_argument("--speed", type=positive(float), default=1.0, help="time scale (2 = twice as fast; default 1)")
    pace.add_argument("--fast", action="store_true", help="as fast as possible, no pacing")
    play.add_argument("--dir", choices=("rx", "tx", "all"), default="rx",
                      help="which recorded direction to send (default rx: what the node received)")
    play.add_argument("--to", metavar="ENTITY",
                      help="deliver the recorded directories to ENTITY: the player is an entity of its own and sends "
                           "each DATA record again, from itself to ENTITY, at the recorded time; --into is then its "
                           "port (udp:bind=H:P,peer=H:P | tcp:connect=H:P | serial:device=PATH), as a node's")
    play.add_argument("--as", dest="as_name", metavar="NAME",
                      help="with --to: play every recorded source as this one entity (default: each as itself)")
    play.add_argument("--map", action="append", metavar="SRC=NAME",
                      help="with --to: play the records of recorded source SRC as entity NAME (repeatable; several "
                           "identities need a udp port: each gets its own local port, at most 4)")
    play.add_argument("--identity", metavar="FILE",
                      help="with --to and --key in a fleet with identities (docs/security.md): the player's identity "
                           "file (NAME.id of `uavbus keys`, for the one entity it plays as); authority.pub and "
                           "fleet.certs are taken from the same folder. Its frames then carry origin tags")
    play.add_argument("--key", metavar="FILE",
                      help="with --to on a signed network: sign with this key file as the player's own identity "
                           "(never the recorded tags); its counter is kept in FILE's folder, play-state/")
    return p


def main(argv: list[str] | None = None, out: IO[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if getattr(args, "speed", 1.0) <= 0:
        raise SystemExit("uavbus log play: --speed must be > 0 (use --fast for no pacing)")
    out = out or sys.stdout
    # A damaged or missing log raises LogFormatError / OSError: `uavbus` (cli.run_tool) turns it into
    # one line and its exit status (3 bad input, 4 cannot write the output).
    if args.cmd == "info":
        return cmd_info(args, out)
    if args.cmd == "export":
        if args.mcap:
            from uavbus.tools.mcap_export import cmd_export_mcap

            return cmd_export_mcap(args, out)
        if args.output:
            with open(args.output, "w", encoding="utf-8", newline="") as f:
                return cmd_export(args, f)
        return cmd_export(args, out)
    return cmd_play(args, out)
