#!/usr/bin/env python3
"""`make demo`: the paper's scenarios end to end on one machine (issue 6), signed (issue 11).

1. HITL configuration (paper Table 2, figure 11) on 127.0.0.1: rmax1ob1, rmax1ob2 and fcs20 as C
   `uavbus_node` processes, gcs1 as the Python GCS in this process; gcs1<->rmax1ob1 over UDP plus a pty
   "wireless serial" link, rmax1ob1<->rmax1ob2 over TCP, rmax1ob1<->fcs20 over a pty serial link. Every
   entity has its own identity, certified by a fleet authority made at run time (`uavbus keys fleet`:
   demo-out/identities, never committed): every frame is signed with the group key (hop tag) and carries an
   origin tag its destination checks.
2. From the GCS's global administration table, the paper's two tests: a publication of gpsOut from
   rmax1ob1 to gcs1, and a subscription of gcs1 to imuOut on the backup computer fcs20 (2 hops).
3. kill -9 rmax1ob1 and restart it: the subscription heals by itself.
4. The Table 1 / figure 9 configuration in this process over in-memory links.
   Then the variable browser over the bus (browser_step.py): a directory read from fcs20 that no flow
   publishes, and a publication rate changed from the GCS.
   Then the GPS step (gps_step.py, issue #24): a simulated COTS GPS (pynmea2) on fcs20's serial port
   becomes the directory gpsNmea at gcs1, two hops away, with uavbus frames on the same wire.
5. The attacker step (attack_step.py): issue 11's attacks against the signed Table 2; each is a check.
6. A fleet: twelve vehicles and two ground stations with automatic routes (examples/demo/fleet_step.py;
   skipped by --short unless --fleet).
7. Hardware in the loop (examples/demo/firmware_step.py): the Cortex-M4 firmware boots in QEMU and is fcs20
   in an unsigned Table 2 over its emulated UART; gcs1 subscribes to its imuOut 2 hops away, reads and
   writes its directories, changes its rate; flash and RAM from the ELF (skipped by --short unless --firmware).
8. The insider step (insider_step.py, issue 23): a captured vehicle (rmax1ob2) with its own valid keys and the
   group key attacks a Table 2 where every node checks origin tags, then the operator revokes it; each
   attack is a check (skipped by --short unless --insider; tests/system/test_insider_campaign.py runs it).

Prints a summary table and writes demo-out/summary.json (with "security": {"attacks": [...]}), demo-out/gcs1.ublog (the GCS's binary log)
and demo-out/imu.png. Exits 0 only if every check held; each failed check names itself and says why.
Every process it starts is stopped on success, on failure and on Ctrl-C.

    .venv/bin/python examples/demo/hitl_demo.py [--short] [--out demo-out]
"""

from __future__ import annotations

import argparse
import signal
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[2]

from attack_step import attacker_part, signed_table2  # noqa: E402  (beside this file)
from browser_step import browser_part  # noqa: E402
from gps_step import gps_part  # noqa: E402
from uavbus.sim.build import node_program  # noqa: E402
from uavbus.sim.hitl import Hitl, HitlOptions, timetag_latency_ms  # noqa: E402
from uavbus.sim.metrics import (  # noqa: E402
    StreamMeter, SummaryRow, largest_gap, render_table, transport_latencies, write_summary,
)

GPS_MS, IMU_MS = 100, 20            # 10 Hz publication, 50 Hz subscription
RENEW_S = 1.0                       # ub_pubsub/ub_admin default renew period
RATE_TOLERANCE = 0.10


@dataclass
class Check:
    name: str
    ok: bool
    why: str


class Checks:
    def __init__(self) -> None:
        self.items: list[Check] = []

    def __call__(self, name: str, ok: bool, why: str) -> bool:
        self.items.append(Check(name, bool(ok), why))
        print(f"  [{'ok' if ok else 'FAILED'}] {name}: {why}", flush=True)
        return bool(ok)

    @property
    def failed(self) -> list[Check]:
        return [c for c in self.items if not c.ok]


def say(text: str) -> None:
    print(text, flush=True)


def drops_of(counters: dict[str, Any]) -> dict[str, int]:
    """Frames dropped on one link, by reason, from a node's link counters (C stats event or Python)."""
    out: dict[str, int] = {}
    for group in ("drops", "bad_frames"):
        d = counters.get(group)
        if isinstance(d, dict):
            out.update({str(k): int(v) for k, v in d.items() if isinstance(v, (int, float)) and v})
    impair = (counters.get("port") or {}).get("impair") if isinstance(counters.get("port"), dict) else None
    if isinstance(impair, dict):
        out.update({f"impair_{k}": int(v) for k, v in impair.items() if k in ("lost", "queue_full") and v})
    for k, v in counters.items():
        if k not in ("drops", "bad_frames") and isinstance(v, (int, float)) and v and ("drop" in k or k.startswith("bad")
                                                                   or k in ("tx_errors", "backpressure")):
            out.setdefault(k, int(v))
    return out


TABLE2_ENTITY = {"gcs": "gcs1", "primary": "rmax1ob1", "secondary": "rmax1ob2", "backup": "fcs20"}


def link_drops(h: Hitl, stats: dict[str, dict[str, Any]], path: list[tuple[str, str]]) -> dict[str, dict[str, int]]:
    """{"entity:link": {reason: frames}} for the links a stream crosses."""
    out: dict[str, dict[str, int]] = {}
    gcs_links = h.gcs.link_counters() if h.gcs is not None else {}
    for node, link in path:
        counters = gcs_links.get(link, {}) if node == "gcs" else stats.get(node, {}).get("links", {}).get(link, {})
        out[f"{TABLE2_ENTITY[node]}:{link}"] = drops_of(counters or {})
    return out


def sent_times(logs: list[Path]) -> dict[tuple[str, int], float]:
    """(source, seq) -> when the node first sent that frame (ms, CLOCK_MONOTONIC), from its transmit logs."""
    from uavbus.logfile import LogReader

    out: dict[tuple[str, int], float] = {}
    for path in logs:
        try:
            log = LogReader(path)
            for rec in log.records():   # a log cut by kill -9 reads up to its last whole record
                if rec.dir == "tx":
                    key = (rec.header.src_id.rstrip(b"\0").decode("ascii", "replace"), rec.header.seq)
                    # The log's clock has 1 ms steps: the send happened somewhere in [t_ms, t_ms + 1).
                    out.setdefault(key, rec.t_ms + 0.5)
        except (OSError, ValueError):
            continue
    return out


def copies_per_link(log: Path) -> dict[tuple[str, str, str], int]:
    """(content, source, link) -> frames that repeated a (source, seq) already received: the second copies,
    per stream and link, from the GCS's log (it records every verified frame, before duplicate suppression)."""
    from uavbus.logfile import LogReader

    reader = LogReader(log)
    cat = reader.catalogue()
    seen: set[tuple[bytes, int]] = set()
    out: dict[tuple[str, str, str], int] = {}
    for rec in reader.records():
        if rec.dir != "rx" or rec.header.admin != 0:
            continue
        key = (bytes(rec.header.src_id), rec.header.seq)
        if key in seen:
            inst = cat.find(bytes(rec.header.dir_id))
            k = (inst.name if inst else "?", rec.header.src_id.rstrip(b"\0").decode(), rec.link)
            out[k] = out.get(k, 0) + 1
        seen.add(key)
    return out


def redundant_links(config: Path) -> set[str]:
    """"entity:link" of the links that carry every frame twice: those of a mask with more than one link
    (Table 2's 0x00000011 between rmax1ob1 and gcs1), so their `duplicate` drops are expected, not losses."""
    from uavbus.config import load_config

    cfg = load_config(config)
    out: set[str] = set()
    for e in cfg.entities:
        for mask in e.masks:
            if bin(mask).count("1") > 1:
                out |= {f"{e.name}:{e.links[i]}" for i in range(len(e.links)) if mask >> i & 1}
    return out


def identity_table2(out: Path) -> Path:
    """Table 2 with an identity per entity, certified by a fleet authority made for this run (`uavbus keys
    fleet`: out/{entity}.id mode 0600, never committed), and the group key for the hop tags: every process
    signs, and checks the origin tag of every frame to its entities (docs/security.md)."""
    import shutil

    from uavbus import keys

    shutil.rmtree(out, ignore_errors=True)      # a new authority and new identities every run
    cfg, _roles = keys.fleet(str(REPO / "examples" / "configs" / "table2.json"), str(out), days=1)
    return cfg


def hitl_part(args: argparse.Namespace, check: Checks, rows: list[SummaryRow], extra: dict[str, Any]) -> dict[str, Any]:
    measure_s, outage_s, after_s = (1.5, 0.7, 1.0) if args.short else (4.0, 1.5, 2.5)
    log = args.out / "gcs1.ublog"
    if log.exists():
        log.unlink()
    say("\n== HITL configuration (paper Table 2, figure 11): 3 C processes + the Python GCS on 127.0.0.1")
    say(f"  every entity its own identity (uavbus keys fleet, made at run time: {args.identity_config.parent}); "
        "every frame signed and origin-tagged")
    opts = HitlOptions(program=args.program, config=args.identity_config, record=log, stats_ms=500,
                       node_logs=args.out / "nodes")
    with Hitl(opts) as h:
        assert h.topo is not None
        for node in ("gcs", "primary", "secondary", "backup"):
            pid = h.group[node].pid if node in h.group.procs else "this process"
            say(f"  {node:9s} pid {pid}: " + ", ".join(f"{k}={v}" for k, v in h.topo.specs(node).items()))

        say("\n-- GCS administration table: the paper's two tests")
        gps = h.add_row("publication", "gpsOut", "rmax1ob1", "gcs1", GPS_MS)
        imu = h.add_row("subscription", "imuOut", "fcs20", "gcs1", IMU_MS)
        for label, row in (("gpsOut rmax1ob1 -> gcs1 publication", gps), ("imuOut fcs20 -> gcs1 subscription", imu)):
            try:
                h.wait_status(row, "active", 5.0)
                check(f"admin row active: {label}", True, f"status {h.admin.status(row)['status']}")
            except TimeoutError as e:
                check(f"admin row active: {label}", False, str(e))
        h.run_for(0.3)   # let both streams settle before measuring
        t0 = h.mark("measure")
        h.run_for(measure_s)
        t1 = h.mark("kill -9 rmax1ob1")

        gps_m, imu_m = h.meter("gpsOut", "rmax1ob1"), h.meter("imuOut", "fcs20")
        say(f"\n-- kill -9 rmax1ob1 (pid {h.group['primary'].pid}), {outage_s} s outage, restart")
        h.kill("primary")
        h.run_for(outage_s)
        t_up = h.restart("primary")["_rx_mono"]   # when its `ready` line arrived
        h.marks.append((t_up, "rmax1ob1 restarted"))
        for m in (gps_m, imu_m):
            try:
                h.wait_data(m.name, m.source, 1, 2 * RENEW_S + 1.0, since=t_up)
                back = m.window(t_up)[0] - t_up
                check(f"heals after restart: {m.name}", back <= 2 * RENEW_S,
                      f"data back {back:.2f} s after the restart (limit: two renewal periods, {2 * RENEW_S:.0f} s)")
            except TimeoutError as e:
                check(f"heals after restart: {m.name}", False, str(e))
        t_after = time.monotonic()
        h.run_for(after_s)
        for m in (gps_m, imu_m):
            start, length = largest_gap(m.times)
            check(f"gap visible: {m.name}", m.count(t1 + 0.2, t_up) == 0 and length >= outage_s,
                  f"no data for {length:.2f} s from t={start - h.t0:.2f} s (outage {outage_s} s)")

        stats: dict[str, dict[str, Any]] = {}
        for node in ("primary", "secondary", "backup"):
            try:
                stats[node] = h.child_stats(node)
            except Exception as e:   # noqa: BLE001 - reported as a failed check
                check(f"stats from {node}", False, str(e))
        gps_path = [("primary", "onboardPortDatalink1"), ("primary", "onboardPortDatalink2"),
                    ("gcs", "gcsPortDatalink1"), ("gcs", "gcsPortDatalink2")]
        imu_path = [("backup", "onboardPortDatalink1"), ("primary", "onboardPortRelay"), *gps_path]
        # Transport latency: the GCS's arrival of each message against the source's own transmit log.
        sent = sent_times(h.node_logs("primary") + h.node_logs("backup"))
        arrivals = {(name, source): [(source, seq, t * 1000.0) for t, n, source2, seq, _ in h.messages
                                     if n == name and source2 == source and t0 <= t <= t1]
                    for name, source in (("gpsOut", "rmax1ob1"), ("imuOut", "fcs20"))}
        pair = redundant_links(h.opts.config)
        for meter, path, src_node, hz in ((gps_m, gps_path, "primary", 1000 / GPS_MS),
                                          (imu_m, imu_path, "backup", 1000 / IMU_MS)):
            transport = transport_latencies(arrivals[(meter.name, meter.source)], sent)
            rows.append(SummaryRow.from_meter(meter, hops=h.topo.hops(src_node, "gcs"), requested_hz=hz, t0=t0, t1=t1,
                                              dropped=link_drops(h, stats, path), transport_ms=transport,
                                              redundant=pair))
            check(f"transport latency measured: {meter.name}", len(transport) >= 0.9 * meter.count(t0, t1),
                  f"{len(transport)} of {meter.count(t0, t1)} messages matched to the source's transmit log")
        copies = copies_per_link(log)  # recorded by the GCS before its duplicate window: every copy
        for r in rows[-2:]:
            r.duplicates = {f"gcs1:{link}": n for (name, source, link), n in copies.items()
                            if (name, source) == (r.name, r.source) and f"gcs1:{link}" in pair}
        for r in rows[-2:]:
            check(f"rate: {r.name} {r.source} -> {r.destination}", r.rate_ok(RATE_TOLERANCE),
                  f"{r.achieved_hz:.2f} Hz for {r.requested_hz:g} Hz requested (tolerance {RATE_TOLERANCE:.0%})")
        check("hops: imuOut fcs20 -> gcs1", rows[-1].hops == 2, f"{rows[-1].hops} hops (gcs1 - rmax1ob1 - fcs20)")
        after_hz = imu_m.rate_hz(t_after, None)
        check("rate after healing: imuOut", abs(after_hz - 1000 / IMU_MS) <= 0.15 * 1000 / IMU_MS,
              f"{after_hz:.1f} Hz after the restart")
        plot = {"t0": h.t0, "times": list(imu_m.times), "values": list(imu_m.values),
                "gap": (t1, t_up), "restart": t_up}
        extra["browser"] = browser_part(h, gps, check, say)
        status = h.close()
    check("all C nodes exit cleanly", all(s == 0 for s in status.values()),
          ", ".join(f"{n}: exit {s}" for n, s in status.items()))
    check("GCS binary log written", log.exists() and log.stat().st_size > 64,
          f"{log} ({log.stat().st_size if log.exists() else 0} bytes)")
    return plot


def table1_part(args: argparse.Namespace, check: Checks, rows: list[SummaryRow]) -> None:
    from uavbus import Catalogue
    from uavbus.sim.hitl import catalogue_for
    from uavbus.sim.memnet import MemNet

    say("\n== Table 1 / figure 9: four entities in this process over in-memory links (injected clock)")
    cat = Catalogue.load(str(catalogue_for(args.program)))
    sim_s = 2.0 if args.short else 5.0
    with MemNet(cat, REPO / "examples/configs/table1.json") as net:
        e2, e0, e3 = net.of("entity2"), net.of("entity0"), net.of("entity3")
        imu_dir, gps_dir = e2.bind("imuOut"), e0.bind("gpsOut")
        e3.bind("imuOut")
        e3.bind("gpsOut")
        meters = {("imuOut", "entity2"): StreamMeter("imuOut", "entity2", "entity3"),
                  ("gpsOut", "entity0"): StreamMeter("gpsOut", "entity0", "entity3")}

        def on_data(msg: Any) -> None:
            now_s = net.now_ms / 1000.0
            value = msg.value.to_dict() if hasattr(msg.value, "to_dict") else msg.value
            m = meters.get((msg.name, msg.source))
            if m is not None:
                m.add(now_s, timetag_latency_ms(value, now_s))

        e3.on_data(on_data)
        # Copies per stream and link at entity3 (every verified frame passes its tap before duplicate
        # suppression): the expected duplicates of the two parallel links, per stream.
        from uavbus._bindings.ub_frame import ub_frame_parse

        first_seen: set[tuple[bytes, int]] = set()
        copies: dict[tuple[str, str, str], int] = {}

        def on_frame(link: str, direction: str, frame: bytes, t_ms: int) -> None:
            h = ub_frame_parse(frame)
            if direction != "rx" or h.admin != 0:
                return
            key = (bytes(h.src_id), h.seq)
            if key in first_seen:
                inst = cat.find(bytes(h.dir_id))
                k = (inst.name if inst else "?", h.src_id.rstrip(b"\0").decode(), link)
                copies[k] = copies.get(k, 0) + 1
            first_seen.add(key)

        e3.on_frame(on_frame)
        adm = e3.admin("entity3")
        sub = adm.add(content="imuOut", source="entity2", destination="entity3", period_ms=IMU_MS,
                      kind="subscription")
        pub = adm.add(content="gpsOut", source="entity0", destination="entity3", period_ms=GPS_MS,
                      kind="publication")
        adm.activate(sub)
        adm.activate(pub)

        def update(now_ms: int) -> None:   # the sources' directories change every ms, stamped with sim time
            for d in (imu_dir, gps_dir):
                d.time.seconds, d.time.microseconds = now_ms // 1000, (now_ms % 1000) * 1000

        net.run(1000, each=update)         # requests, acknowledgements, first data
        t0 = net.now_ms / 1000.0
        net.run(int(sim_s * 1000), each=update)
        t1 = net.now_ms / 1000.0
        for row, label in ((sub, "imuOut entity2 -> entity3 subscription"), (pub, "gpsOut entity0 -> entity3 publication")):
            st = adm.status(row)["status"]
            check(f"Table 1 admin row active: {label}", st == "active", f"status {st}")
        hops = {"imuOut": 3, "gpsOut": 1}   # entity3 - entity0 - entity1 - entity2; entity0 - entity3 (2 links)
        for (name, _src), m in meters.items():
            req = 1000 / (IMU_MS if name == "imuOut" else GPS_MS)
            pair_links = {e_link.split(":", 1)[1] for e_link in redundant_links(REPO / "examples/configs/table1.json")}
            r = SummaryRow.from_meter(m, hops=hops[name], requested_hz=req, t0=t0, t1=t1,
                                      dropped={f"{n}:{link}": drops_of(c) for n, node in net.nodes.items()
                                               for link, c in node.link_counters().items()},
                                      redundant={f"{n}:{link}" for n, node in net.nodes.items()
                                                 for link in node.link_counters() if link in pair_links})
            r.dropped = {k: v for k, v in r.dropped.items() if v}
            r.duplicates = {f"C:{link}": n for (cname, source, link), n in copies.items()
                            if (cname, source) == (name, m.source)}
            rows.append(r)
            check(f"Table 1 rate: {name} {m.source} -> {m.destination}", r.rate_ok(RATE_TOLERANCE),
                  f"{r.achieved_hz:.2f} Hz for {req:g} Hz requested ({r.hops} hops, simulated time)")


def make_plot(args: argparse.Namespace, check: Checks, plot: dict[str, Any]) -> None:
    from uavbus.sim.plot import plot_series

    t0 = plot["t0"]
    t = [x - t0 for x in plot["times"]]
    values = [v for v in plot["values"] if isinstance(v, dict)]
    series: dict[str, list[float]] = {}
    for axis in ("p", "q", "r"):
        ys = [float(v.get(axis, 0.0)) for v in values]
        if ys and max(ys) != min(ys):          # a steady turn has constant body rates: nothing to see
            series[f"imuOut.{axis} (rad/s)"] = ys
    ylabel = "angular rate (rad/s)"
    if not series:   # the counter of IMU samples taken on fcs20: keeps rising through the outage
        series["imuOut.sampleCount (fcs20 IMU samples)"] = [float(v.get("sampleCount", 0)) for v in values]
        ylabel = "IMU samples taken on fcs20"
    g0 = plot["gap"][0]
    first_after = next((x for x in plot["times"] if x >= plot["restart"]), plot["restart"])
    path = args.out / "imu.png"
    try:
        plot_series(path, t, series, title="imuOut from fcs20 received at gcs1 (2 hops via rmax1ob1)",
                    gaps=[(g0 - t0, first_after - t0, "rmax1ob1 killed -> restarted")], ylabel=ylabel)
        check("plot written", path.exists(), str(path))
    except ImportError as e:
        check("plot written", False, f"matplotlib missing ({e}); run `make setup` (installs .[test,demo])")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--short", action="store_true", help="shorter measurement windows (for make test)")
    ap.add_argument("--out", type=Path, default=REPO / "demo-out", help="output directory (default demo-out/)")
    ap.add_argument("--program", type=Path, default=None, help="uavbus_node (default: build/ or $UAVBUS_NODE)")
    ap.add_argument("--fleet", action=argparse.BooleanOptionalAction, default=None,
                    help="run the fleet step (default: yes, except with --short)")
    ap.add_argument("--firmware", action=argparse.BooleanOptionalAction, default=None,
                    help="run the firmware-in-QEMU step (default: yes, except with --short)")
    ap.add_argument("--insider", action=argparse.BooleanOptionalAction, default=None,
                    help="run the insider step (default: yes, except with --short)")
    args = ap.parse_args(argv)
    args.fleet = not args.short if args.fleet is None else args.fleet
    args.firmware = not args.short if args.firmware is None else args.firmware
    args.insider = not args.short if args.insider is None else args.insider
    args.out.mkdir(parents=True, exist_ok=True)
    # SIGTERM (e.g. from make or a CI timeout) unwinds like Ctrl-C, so every `with` stops its processes.
    signal.signal(signal.SIGTERM, lambda *_: (_ for _ in ()).throw(KeyboardInterrupt()))
    started = time.monotonic()
    check = Checks()
    rows: list[SummaryRow] = []
    extra: dict[str, Any] = {}
    try:
        args.program = args.program or node_program()
        args.config = signed_table2(args.out / "secure", fresh=True)    # the group-key mode: the attacker step's
        args.identity_config = identity_table2(args.out / "identities")  # an identity per entity: the HITL part's
        plot = hitl_part(args, check, rows, extra)
        table1_part(args, check, rows)
        make_plot(args, check, plot)
        extra["gps"] = gps_part(args.out, args.program, check, say, short=args.short)
        extra["security"] = attacker_part(args, check, say)
        if args.fleet:
            from fleet_step import fleet_part

            extra["fleet"] = fleet_part(args.out, args.program, check, say)
    except KeyboardInterrupt:
        say("\ninterrupted: every process the demo started has been stopped")
        return 130
    except Exception as e:  # noqa: BLE001 - a crash is a failed check with its reason
        check("demo ran to the end", False, f"{type(e).__name__}: {e}")
    if args.firmware:   # its own board and network: it runs whatever happened to the steps before
        from firmware_step import firmware_part

        try:
            extra["firmware"] = firmware_part(args.program, rows, check, say, short=args.short)
        except KeyboardInterrupt:
            say("\ninterrupted: every process the demo started has been stopped")
            return 130
        except Exception as e:  # noqa: BLE001
            check("firmware step ran to the end", False, f"{type(e).__name__}: {e}")
    if args.insider and args.program is not None:   # its own network, keys and identities, like the firmware's
        from insider_step import insider_part

        try:
            extra["insider"] = insider_part(args, check, say)
        except KeyboardInterrupt:
            say("\ninterrupted: every process the demo started has been stopped")
            return 130
        except Exception as e:  # noqa: BLE001
            check("insider step ran to the end", False, f"{type(e).__name__}: {e}")
    if rows:
        write_summary(args.out / "summary.json", rows, {"checks": [c.__dict__ for c in check.items],
                                                        "short": args.short, **extra})
        say("\n== Summary\n" + render_table(rows))
        say(f"\nwrote {args.out / 'summary.json'}, {args.out / 'gcs1.ublog'}, {args.out / 'imu.png'}")
    took = time.monotonic() - started
    if check.failed:
        say(f"\nDEMO FAILED ({took:.1f} s): " + "; ".join(f"{c.name}: {c.why}" for c in check.failed))
        return 1
    say(f"\ndemo passed: {len(check.items)} checks held ({took:.1f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
