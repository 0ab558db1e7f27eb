"""Issue #28's goals for bench/results.md's Goals table, each measured from this run's raw outputs.

Called by bench/tables.py with the raw directory and the failures bench/tools/sample.sh recorded. Every goal is
computed here from the raw files themselves (codec.tsv, router.txt, py.txt, bridges.json, fleet.txt, prio.txt),
independently of the figure that renders them, so the table states exactly #28's goals whatever a figure's own
wording; a goal whose samples are missing or failed is a row that says so and is never met.
"""

from __future__ import annotations

import json
import re
import statistics
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

MSGS = ["ATTITUDE", "GPS_RAW_INT", "HIGHRES_IMU"]
CODEC_CG_ITERS = 20000  # codec_bench's BENCH_ITERS (the callgrind count per case)


@dataclass(frozen=True)
class Spec:
    key: str  # the item of bench/results_notes.md that holds its next step, and of the profile appendix
    figure: str
    goal: str  # issue #28's wording
    raw: tuple[str, ...]  # the raw files its figure comes from (failures.txt names them in out=)
    profile: str | None  # anchor of its generated profile in results.md (in-process goals), else None
    breakdown: str = ""  # without a CPU profile: where this run's figure breaks the miss down


SPECS = (
    Spec("frame build", "1", "frame build ≤ 1/8 of MAVLink pack (ATTITUDE, GPS_RAW_INT, HIGHRES_IMU)",
         ("codec.tsv",), "profile-frame-build"),
    Spec("parse", "1", "parse ≤ 1/20 of MAVLink parse + decode (ATTITUDE, GPS_RAW_INT, HIGHRES_IMU)",
         ("codec.tsv",), "profile-parse"),
    Spec("3 hops", "2", "3 hops in process ≥ 6 M msg/s", ("router.txt",), "profile-3-hops"),
    Spec("Python publish", "4", "Python publish ≥ 4× pymavlink and ≥ 1× LCM Python (3 messages)", ("py.txt",),
         "profile-python"),
    Spec("Python receive", "4", "Python receive ≥ 4× pymavlink and ≥ 1× LCM Python (3 messages)", ("py.txt",),
         "profile-python"),
    Spec("Zenoh throughput", "7", "Zenoh bridge ≥ 50 k frames/s", ("bridges.log",), None,
         "figure 7's per-frame calls, loop CPU and where the frames went"),
    Spec("Zenoh latency", "7", "Zenoh bridge ≤ 150 µs added at p50", ("bridges.log",), None,
         "figure 7's split of the added p50 between Zenoh alone and the two bridges' hops"),
    Spec("fleet delivery", "8", "delivery ≥ 99.5 % where a path exists with a cut every 6 s at 10/30/100 vehicles",
         ("fleet.txt",), None, "a protocol figure, not CPU: figure 8's detect / route / data times per cut"),
    Spec("1,000 vehicles", "8", "1,000 vehicles + 2 GCS in process at real-time factor ≥ 1 on one core",
         ("fleet.txt",), "profile-fleet-1000"),
    Spec("uavbus_node CPU", "8", "uavbus_node ≤ 2 ms CPU per vehicle per second as processes", ("fleet.txt",), None,
         "figure 8's processes row (CPU from /proc per process, ground stations apart)"),
    Spec("priorities", "11", "command p99 ≤ 50 ms with priorities on a saturated 57,600-baud link", ("prio.txt",),
         None, "figure 11's rows with and without priorities, on the injected clock"),
)


@dataclass(frozen=True)
class Result:
    spec: Spec
    measured: str
    met: bool
    failed: int  # samples of its raw files that failed or timed out in this run


class NoSample(Exception):
    """The goal's figure has no (complete) sample in this run."""


def _med(xs: list[float]) -> float:
    if not xs:
        raise NoSample("no sample")
    return statistics.median(xs)


def _codec(raw: Path) -> tuple[dict[tuple[str, str], list[float]], dict[tuple[str, str], float]]:
    ns: dict[tuple[str, str], list[float]] = defaultdict(list)
    for line in (raw / "codec.tsv").read_text().splitlines():
        p = line.split("\t")
        if len(p) > 3:
            ns[(p[0], p[1])] += [float(x) for x in p[3:]]
    ir: dict[tuple[str, str], float] = {}
    for f in sorted((raw / "callgrind").glob("cg.*")) if (raw / "callgrind").is_dir() else []:
        text = f.read_text(errors="replace")
        m = re.search(r"desc: Trigger: Client Request: (\S+)/(\S+)", text)
        t = re.search(r"^summary: (\d+)", text, re.M)
        if m and t:
            ir[(m.group(1), m.group(2))] = int(t.group(1)) / CODEC_CG_ITERS
    return ns, ir


def _codec_ratio(raw: Path, ours: str, peer: str, limit: float) -> tuple[str, bool]:
    ns, ir = _codec(raw)
    cells, ok = [], True
    for m in MSGS:
        if not ns.get((ours, m)) or not ns.get((peer, m)):
            raise NoSample(f"no {ours} or {peer} sample for {m} in codec.tsv")
        r = _med(ns[(ours, m)]) / _med(ns[(peer, m)])
        ok = ok and r <= limit
        by_ir = f", instructions 1/{ir[(peer, m)] / ir[(ours, m)]:.1f}" if (ours, m) in ir and (peer, m) in ir else ""
        cells.append(f"{m} 1/{1 / r:.1f}{by_ir}")
    return "; ".join(cells) + " (time: medians of this run)", ok


def _router(raw: Path) -> tuple[str, bool]:
    thr = [float(re.search(r"msgs_per_s=(\S+)", ln).group(1)) for ln in (raw / "router.txt").read_text().splitlines()
           if ln.startswith("throughput") and re.search(r"\bhops=3\b", ln)]
    if not thr:
        raise NoSample("no 3-hop throughput sample in router.txt")
    t = _med(thr)
    return f"{t / 1e6:.2f} M msg/s (median of {len(thr)}, {min(thr) / 1e6:.2f} - {max(thr) / 1e6:.2f})", t >= 6e6


def _python(raw: Path, ours: str, mav: str, lcm: str) -> tuple[str, bool]:
    py: dict[tuple[str, str], list[float]] = defaultdict(list)
    for line in (raw / "py.txt").read_text().splitlines():
        p = line.split("\t")
        if len(p) > 2 and not p[0].startswith("calls/msg"):
            py[(p[0], p[1])] += [float(x) for x in p[2:]]
    worst: dict[str, tuple[float, str]] = {}
    for peer in (mav, lcm):
        for m in MSGS:
            if not py.get((ours, m)) or not py.get((peer, m)):
                raise NoSample(f"no '{ours}' or '{peer}' sample for {m} in py.txt")
            r = _med(py[(ours, m)]) / _med(py[(peer, m)])
            if peer not in worst or r < worst[peer][0]:
                worst[peer] = (r, m)
    (rm, mm), (rl, ml) = worst[mav], worst[lcm]
    return (f"worst {rm:.2f}× pymavlink ({mm}), {rl:.2f}× LCM Python ({ml})", rm >= 4 and rl >= 1)


def _bridges(raw: Path) -> dict:
    d = json.loads((raw / "bridges.json").read_text())
    return d


def _zenoh_tput(raw: Path) -> tuple[str, bool]:
    d = _bridges(raw)
    z = _med([r["rate"] for r in d.get("ub_zenoh_tput", [])])
    direct = [r["rate"] for r in d.get("ub_direct_tput", [])]
    ctx = f" (direct UDP {statistics.median(direct) / 1e3:.1f} k)" if direct else ""
    return f"{z / 1e3:.1f} k frames/s, median of {len(d['ub_zenoh_tput'])} runs{ctx}", z >= 50e3


def _zenoh_lat(raw: Path) -> tuple[str, bool]:
    d = _bridges(raw)
    z = _med([r["p50_us"] for r in d.get("ub_zenoh_lat", [])])
    direct = _med([r["p50_us"] for r in d.get("ub_direct_lat", [])])
    return f"{z - direct:.0f} µs added (p50 {z:.0f} µs bridged - {direct:.0f} µs direct, medians of runs)", \
        z - direct <= 150


def _fleet_rows(raw: Path) -> list[dict[str, str]]:
    rows = []
    for line in (raw / "fleet.txt").read_text().splitlines():
        kind, _, rest = line.partition(" ")
        if kind in ("fleet_inproc", "fleet_procs"):
            rows.append({"kind": kind, **dict(kv.split("=", 1) for kv in rest.split() if "=" in kv)})
    return rows


def _fleet_delivery(raw: Path) -> tuple[str, bool]:
    rows = [r for r in _fleet_rows(raw) if r["kind"] == "fleet_inproc" and int(r.get("failures", "0")) > 0]
    cells, ok, missing = [], True, []
    for n in ("10", "30", "100"):
        got = [float(r["delivery_failures"]) for r in rows if r["n"] == n]
        if not got:
            missing.append(n)
            ok = False
            continue
        cells.append(f"{n}: {100 * min(got):.2f} %")
        ok = ok and min(got) >= 0.995
    if not cells:
        raise NoSample("no fleet sample with cuts in fleet.txt")
    return ", ".join(cells) + "".join(f"; {n}: no sample" for n in missing), ok


def _fleet_1000(raw: Path) -> tuple[str, bool]:
    rows = [r for r in _fleet_rows(raw) if r["kind"] == "fleet_inproc" and r["n"] == "1000"]
    if not rows:
        raise NoSample("no 1,000-vehicle sample in fleet.txt")
    r = rows[-1]
    sim, wall = float(r["sim_s"]), float(r["wall_s"])  # the factor from both: fleet_bench prints it to 0.1
    return (f"real-time factor {sim / wall:.3f} ({sim:.0f} s simulated in {wall:.0f} s, "
            f"{float(r['cpu_ms_per_vehicle_s']):.3f} ms CPU per vehicle per s)", sim / wall >= 1.0)


def _procs(raw: Path) -> tuple[str, bool]:
    rows = [r for r in _fleet_rows(raw) if r["kind"] == "fleet_procs"]
    if not rows:
        raise NoSample("no fleet_procs sample in fleet.txt")
    cpu = max(float(r["cpu_ms_per_vehicle_s"]) for r in rows)
    return f"{cpu:.2f} ms ({rows[-1]['n']} vehicles, UDP)", cpu <= 2.0


def _prio(raw: Path) -> tuple[str, bool]:
    rows = []
    for line in (raw / "prio.txt").read_text().splitlines():
        p = line.split("\t")
        if p[0] == "prio" and len(p) >= 7:
            rows.append((p[1], float(p[2]), float(p[3]), float(p[6])))  # label, prio, bulk, p99 ms

    def p99(label: str, prio: float, bulk: float) -> float | None:
        return next((r[3] for r in rows if r[0] == label and r[1] == prio and r[2] == bulk), None)

    on, frag = p99("uavbus compact", 1, 0), p99("uavbus compact", 1, 1)
    if on is None:
        raise NoSample("no 'uavbus compact' row with priorities in prio.txt")
    off, mav = p99("uavbus compact", 0, 0), p99("MAVLink 2", 0, 0)
    worst = max(on, frag if frag is not None else 0.0)
    text = f"p99 {on:.0f} ms" + (f", {frag:.0f} ms with fragments" if frag is not None else "")
    text += "".join(f"; {name} {v:.0f} ms" for name, v in (("without priorities", off), ("MAVLink 2", mav))
                    if v is not None)
    return text, worst <= 50


MEASURE: dict[str, Callable[[Path], tuple[str, bool]]] = {
    "frame build": lambda raw: _codec_ratio(raw, "ub_frame_build", "mav_pack", 1 / 8),
    "parse": lambda raw: _codec_ratio(raw, "ub_frame_parse", "mav_parse_decode", 1 / 20),
    "3 hops": _router,
    "Python publish": lambda raw: _python(raw, "uavbus publish", "pymavlink encode", "lcm encode"),
    "Python receive": lambda raw: _python(raw, "uavbus receive", "pymavlink decode", "lcm decode"),
    "Zenoh throughput": _zenoh_tput,
    "Zenoh latency": _zenoh_lat,
    "fleet delivery": _fleet_delivery,
    "1,000 vehicles": _fleet_1000,
    "uavbus_node CPU": _procs,
    "priorities": _prio,
}


def measure(raw: Path, fails: list[dict[str, str]]) -> list[Result]:
    """One Result per goal of #28, from raw/: a goal without a complete sample is 'no sample', never met."""
    out = []
    for spec in SPECS:
        failed = sum(1 for f in fails if f.get("out") in spec.raw + ("bridges.json",) * (spec.figure == "7"))
        try:
            measured, met = MEASURE[spec.key](raw)
        except FileNotFoundError as e:
            measured, met = f"**no sample in this run** (raw/{Path(e.filename or '?').name} missing)", False
        except (OSError, NoSample, KeyError, ValueError, IndexError, AttributeError, ZeroDivisionError,
                statistics.StatisticsError) as e:
            why = str(e) if isinstance(e, NoSample) else f"{type(e).__name__}: {e}"
            measured, met = f"**no sample in this run** ({why})", False
        out.append(Result(spec, measured, met, failed))
    return out


def render(results: list[Result], notes_keys: set[str], profiles: set[str], w: Callable[[str], None]) -> None:
    """The #28 rows of the Goals table: figure, goal, this run's figure, met, where its profile and next step are."""
    w("| figure | goal (issue #28) | measured (this run) | met | profile, next step |")
    w("|---|---|---|:---:|---|")
    for r in results:
        w(f"| {r.spec.figure} | {r.spec.goal} | {r.measured}{failed_note(r)} | {'✓' if r.met else '✗'} | "
          f"{explain(r, notes_keys, profiles) if not r.met else '-'} |")


def failed_note(r: Result) -> str:
    return (f" ({r.failed} sample(s) of {', '.join(r.spec.raw)} failed or timed out: see 'Failed or timed-out "
            "samples')") if r.failed else ""


def explain(r: Result, notes_keys: set[str], profiles: set[str]) -> str:
    """Where a miss is explained: its profile in this run's appendix, and the next step in the hand-kept notes."""
    s = r.spec
    if s.profile is None:
        prof = f"breakdown: {s.breakdown}"
    elif s.profile in profiles:
        prof = f"profile: [this run's](#{s.profile})"
    else:
        prof = "**no profile in this run** (its profiling sample failed or did not run)"
    step = (f"next step: [notes, '{s.key}'](#notes)" if s.key in notes_keys
            else "**no next step written** (bench/results_notes.md has no item for it)")
    return f"{prof}; {step}"
