"""Turns the raw outputs of bench/run.sh (build-bench/raw/) into bench/results.md.

    python bench/tables.py build-bench/raw bench/results.md
    python bench/tables.py --core build-bench/raw bench/results-core.md   (BENCH_ONLY=core: figures 1-3)

Every figure is median [min - max] over the pooled samples; C codec rows also carry callgrind
instructions per operation; ratios are uavbus / peer on medians of the same run.
"""

from __future__ import annotations

import datetime
import glob
import os
import platform
import re
import statistics
import subprocess
import sys
from collections import defaultdict
from pathlib import Path

import goal_tables  # bench/ is the script's own directory
import profile_tables

MSGS = ["ATTITUDE", "GPS_RAW_INT", "HIGHRES_IMU"]


def band(xs: list[float], fmt: str = "{:.1f}") -> str:
    return f"{fmt.format(statistics.median(xs))} [{fmt.format(min(xs))} - {fmt.format(max(xs))}]"


def kfmt(x: float) -> str:
    return f"{x / 1000:,.0f}k"


def read_dumps(d: Path) -> dict[str, int]:
    """Instructions per callgrind dump in directory d, by the name the program gave it
    (CALLGRIND_DUMP_STATS_AT: "case/MESSAGE", "router/hops=H", "loop/rtt-udp/tx")."""
    ir: dict[str, int] = {}
    for f in glob.glob(str(d / "cg.*")):
        text = Path(f).read_text(errors="replace")
        m = re.search(r"desc: Trigger: Client Request: (\S+)", text)
        t = re.search(r"^summary: (\d+)", text, re.M) or re.search(r"^totals: (\d+)", text, re.M)
        if m and t:
            ir[m.group(1)] = int(t.group(1))
    return ir


def read_codec(raw: Path, name: str = "codec.tsv", cg: str = "callgrind") -> tuple[dict, dict, dict]:
    ns: dict[tuple[str, str], list[float]] = defaultdict(list)
    size: dict[tuple[str, str], int] = {}
    for line in (raw / name).read_text().splitlines():
        parts = line.split("\t")
        ns[(parts[0], parts[1])] += [float(x) for x in parts[3:]]
        size[(parts[0], parts[1])] = int(parts[2])
    ir: dict[tuple[str, str], float] = {}
    for dump, n in read_dumps(raw / cg).items():
        case, _, msg = dump.partition("/")
        if msg in MSGS:
            ir[(case, msg)] = n / 20000  # codec_bench's BENCH_ITERS
    return ns, size, ir


# Fixed work per callgrind dump of figures 2 and 3 (router_hops.c CG_N; bench/run.sh's loop_bench rtt N).
ROUTER_CG_FRAMES = 20000
LOOP_CG_ROUNDTRIPS = 2000


def instruction_values(d: Path) -> dict[tuple[str, str], float]:
    """Figures 1-3 by instruction count from one directory of callgrind dumps: {(figure, what): per operation}."""
    ir = read_dumps(d)
    vals: dict[tuple[str, str], float] = {}
    for case, title in (("ub_frame_build", "frame build"), ("ub_frame_parse", "streaming parse")):
        for m in MSGS:
            if f"{case}/{m}" in ir:
                vals[("1", f"{title}, {m}: instructions per frame")] = ir[f"{case}/{m}"] / 20000
    for h in (1, 3):
        if f"router/hops={h}" in ir:
            vals[("2", f"{h} hop(s): instructions per delivered frame")] = ir[f"router/hops={h}"] / ROUTER_CG_FRAMES
    for t in ("udp", "tcp"):
        tx, rx = f"loop/rtt-{t}/tx", f"loop/rtt-{t}/rx"
        if tx in ir and rx in ir:
            vals[("3", f"RTT {t}: user-space instructions per round trip (both processes)")] = \
                (ir[tx] + ir[rx]) / LOOP_CG_ROUNDTRIPS
    return vals


def instruction_rows(raw: Path) -> list[tuple[str, str, float, float]]:
    """Figures 1-3 by instruction count, this tree and the base: (figure, what, this tree, base) per operation."""
    new, old = instruction_values(raw / "callgrind"), instruction_values(raw / "base_callgrind")
    return [(fig, what, new[(fig, what)], old[(fig, what)]) for fig, what in new if (fig, what) in old]


def history_section(raw: Path) -> list[str]:
    """BENCH_COUNTS_AT=REFS: figures 1-3 by instruction count over the runtime of each ref, oldest first, and
    this tree's: which commit changed the cost of the frame path, read without interleaving (counts do not drift)."""
    order = raw / "counts_at.txt"  # "SHORT subject" per commit, oldest first; its dumps in raw/at-SHORT/
    if not order.exists():
        return []
    refs = [ln.split(None, 1) for ln in order.read_text().splitlines() if ln.strip()]
    cols = [(r[0], instruction_values(raw / f"at-{r[0]}")) for r in refs]
    base = raw / "base_ref.txt"  # BENCH_BASE's counts, first, unless it is one of the refs already
    if base.exists() and (raw / "base_callgrind").is_dir() and base.read_text().strip() not in [r[0] for r in refs]:
        cols.insert(0, (f"{base.read_text().strip()} (BENCH_BASE)", instruction_values(raw / "base_callgrind")))
    cols.append(("this tree", instruction_values(raw / "callgrind")))
    keys = [k for k in cols[-1][1] if all(k in c for _, c in cols)]
    out = ["## Figures 1-3 by instruction count along the history (BENCH_COUNTS_AT)", "",
           "callgrind counts of the same bench programs (this tree's sources, catalogue and peers) linked with the "
           "runtime of each commit, the same fixed work as the before-and-after rows; deterministic, so commits "
           "are compared across the run without interleaving. Last column: this tree / the first column.", "",
           "| figure | case | " + " | ".join(c for c, _ in cols) + f" | this tree / {cols[0][0].split()[0]} |",
           "|---|---|" + "---:|" * (len(cols) + 1)]
    for k in keys:
        out.append(f"| {k[0]} | {k[1]} | " + " | ".join(f"{c[k]:,.0f}" for _, c in cols) +
                   f" | {cols[-1][1][k] / cols[0][1][k]:.3f} |")
    out += ["", "Commits: " + "; ".join(f"{r[0]} {r[1] if len(r) > 1 else ''}".strip() for r in refs) + ".", ""]
    return out


def read_router(path: Path) -> tuple[dict, dict, dict, dict]:
    """Figure 2's samples: msg/s, p50 and p99 ns by hop count, and allocations after init."""
    thr: dict[int, list[float]] = defaultdict(list)
    p50: dict[int, list[float]] = defaultdict(list)
    p99: dict[int, list[float]] = defaultdict(list)
    allocs = {}
    for line in path.read_text().splitlines():
        kv = dict(x.split("=") for x in line.split()[1:])
        h = int(kv["hops"])
        if line.startswith("throughput"):
            thr[h].append(float(kv["msgs_per_s"]))
        elif line.startswith("latency"):
            p50[h].append(float(kv["p50_ns"]))
            p99[h].append(float(kv["p99_ns"]))
        else:
            allocs[h] = int(kv["after_init"])
    return thr, p50, p99, allocs


def read_loop(path: Path) -> tuple[dict, dict]:
    """Figure 3's samples: blast fields by (transport, batching, placement), RTT p50/p99 by (transport, placement)."""
    blast: dict[tuple, dict[str, list[float]]] = defaultdict(lambda: defaultdict(list))
    rtt: dict[tuple, dict[str, list[float]]] = defaultdict(lambda: defaultdict(list))
    for line in path.read_text().splitlines():
        kv = dict((k, v.strip('"')) for k, v in re.findall(r'(\w+)=("[^"]*"|\S+)', line))
        if not kv or kv.get("status", "ok") != "ok":
            continue  # a failed sample (loop_bench's status=failed line) is listed from failures.txt, never pooled
        if kv["mode"] == "blast":
            key = (kv["transport"], kv.get("batching", "0"), kv["placement"])
            for f in ("delivered_per_s", "lost_pct", "offered_per_s", "refused_retried"):
                blast[key][f].append(float(kv[f]))
        else:
            key = (kv["transport"], kv["placement"])
            rtt[key]["p50"].append(float(kv["p50_us"]))
            rtt[key]["p99"].append(float(kv["p99_us"]))
    return blast, rtt


def before_after(raw: Path) -> list[str]:
    """Figures 1-3 with this tree's runtime beside BENCH_BASE's, from the same run (bench/run.sh). A ratio
    above 1 for a time (or below 1 for a rate) is a slowdown; the bands say how far the runs spread."""
    if not (raw / "base_codec.tsv").exists():
        return []
    ref = (raw / "base_ref.txt").read_text().strip()
    out = [f"## Before and after: figures 1-3 with this tree's runtime and with {ref}'s", "",
           f"`BENCH_BASE={ref}`: the same bench programs, catalogue and peers, linked once with this tree's "
           "runtime and once with the runtime of that commit, run interleaved (figure 1: 3 processes each, figure 2: "
           "RUNS processes each, alternating, of 7 samples, figure 3: the uavbus UDP/TCP rows in every round). Median [min - max]; "
           "ratio = this tree / base. The instruction rows come first: callgrind counts of the same programs over a "
           "fixed amount of work (figure 1: 20,000 frames per case; figure 2: 20,000 frames through 1 and 3 hops; "
           "figure 3: 2,000 round trips, user space of both processes, kernel not counted), which a busy machine "
           "does not change (figures 1-2 and UDP are exact; TCP's varies by ~0.3 % with how the kernel splits the "
           "stream into reads); the time rows below them are this run's samples, which it does.", "",
           "| figure | case | this tree | base | ratio |", "|---|---|---:|---:|---:|"]
    irows = instruction_rows(raw)
    if irows:
        out += [f"| {fig} | {what} | {a:,.0f} | {b:,.0f} | {a / b:.3f} |" for fig, what, a, b in irows]
    new_ns, _, _ = read_codec(raw)
    old_ns, _, _ = read_codec(raw, "base_codec.tsv")
    for case, title in (("ub_frame_build", "frame build ns"), ("ub_frame_parse", "streaming parse ns")):
        for m in MSGS:
            a, b = new_ns[(case, m)], old_ns[(case, m)]
            out.append(f"| 1 | {title}, {m} | {band(a)} | {band(b)} | "
                       f"{statistics.median(a) / statistics.median(b):.3f} |")
    new_r, old_r = read_router(raw / "router.txt"), read_router(raw / "base_router.txt")
    for i, title, fmt in ((0, "delivered msg/s", "{:,.0f}"), (1, "latency p50 ns", "{:.0f}")):
        for h in sorted(new_r[i]):
            a, b = new_r[i][h], old_r[i][h]
            out.append(f"| 2 | {title}, {h} hop(s) | {band(a, fmt)} | {band(b, fmt)} | "
                       f"{statistics.median(a) / statistics.median(b):.3f} |")
    new_bl, new_rtt = read_loop(raw / "loop.txt")
    old_bl, old_rtt = read_loop(raw / "base_loop.txt")
    for key, v in sorted(old_bl.items()):
        a, b = new_bl[key]["delivered_per_s"], v["delivered_per_s"]
        out.append(f"| 3 | blast {key[0]}, {key[2]}: delivered msg/s | {band(a, '{:,.0f}')} | {band(b, '{:,.0f}')} | "
                   f"{statistics.median(a) / statistics.median(b):.3f} |")
    for key, v in sorted(old_rtt.items()):
        a, b = new_rtt[key]["p50"], v["p50"]
        out.append(f"| 3 | RTT {key[0]}, {key[1]}: p50 us | {band(a)} | {band(b)} | "
                   f"{statistics.median(a) / statistics.median(b):.3f} |")
    out.append("")
    if irows:
        worst = max(irows, key=lambda r: r[2] / r[3])
        out += [f"By instruction count (this run's callgrind dumps): this tree / {ref} from "
                f"{min(a / b for _f, _w, a, b in irows):.3f} to {worst[2] / worst[3]:.3f} "
                f"(the most: figure {worst[0]}, {worst[1].split(':')[0]}).", ""]
    else:
        out += ["No instruction counts for the base in this run (raw/base_callgrind missing): judge by the time rows.",
                ""]
    return out


def read_failures(raw: Path) -> list[dict[str, str]]:
    """The samples bench/tools/sample.sh recorded as failed or timed out, one dict per line."""
    f = raw / "failures.txt"
    if not f.exists():
        return []
    return [dict((k, v.strip('"')) for k, v in re.findall(r'(\w+)=("[^"]*"|\S+)', line))
            for line in f.read_text().splitlines() if line.strip()]


def failures_section(fails: list[dict[str, str]]) -> list[str]:
    out = ["## Failed or timed-out samples", ""]
    if not fails:
        return out + ["None: every sample of this run finished and is in the tables below.", ""]
    out += [f"{len(fails)} sample(s) of this run failed or passed their deadline; they are not in the tables "
            "(a figure pools only the samples that finished, and says how many rounds it has). The run went on.", "",
            "| status | raw file | command | exit | deadline s | reason |", "|---|---|---|---:|---:|---|"]
    for f in fails:
        reason = f.get("reason", "").replace("|", "/")
        out.append(f"| {f.get('status', '?')} | {f.get('out', '?')} | `{f.get('cmd', '?')}` | {f.get('exit', '?')} | "
                   f"{f.get('deadline_s', '?')} | {reason} |")
    return out + [""]


def notes_keys(notes: Path | None) -> set[str]:
    """The goals of issue #28 the hand-kept notes have an item for: a line "- **KEY..." (case ignored)."""
    if notes is None or not notes.exists():
        return set()
    text = notes.read_text()
    return {s.key for s in goal_tables.SPECS
            if re.search(r"^- \*\*" + re.escape(s.key), text, re.M | re.I)}


def upper_first(text: str) -> str:
    return text[:1].upper() + text[1:]


def misses_section(goals: list, notes: Path | None, g28: list | None = None,
                   profiles: set[str] | frozenset[str] = frozenset()) -> list[str]:
    """"What holds a miss back": the misses with this run's figures (generated), issue #28's each with a link to
    its profile in this run's appendix and to its next step in the notes, then the hand-kept analysis labelled
    with the run it analysed: its figures are that run's, never presented as this one's."""
    out = ["## What holds a miss back", "", "Goals missed in this run, with this run's figures (generated):", ""]
    keys = notes_keys(notes)
    for r in g28 or []:
        if not r.met:
            out.append(f"- **{r.spec.key}** (issue #28, figure {r.spec.figure}): goal {r.spec.goal}; measured "
                       f"{r.measured}{goal_tables.failed_note(r)}. {upper_first(goal_tables.explain(r, keys, profiles))}.")
    missed = [g for g in goals if not g[3]]
    out += [f"- **{fig}**: goal {goal}; measured {measured}." for fig, goal, measured, _ok, _note in missed]
    if out[-1] == "":
        out.append("- none")
    out.append("")
    if notes is not None and notes.exists():
        text = notes.read_text().rstrip().splitlines()
        m = next((re.match(r"^analysed-run:\s*(.+)$", ln) for ln in text if ln.startswith("analysed-run:")), None)
        body = [ln for ln in text if not ln.startswith("analysed-run:") and not ln.startswith("# ")]
        run = m.group(1) if m else "an unnamed earlier run"
        out += ['<a id="notes"></a>', "", f"### Analysis kept by hand (bench/results_notes.md), written for {run}", "",
                f"*The profiles and figures below are from {run}, not from this run; this run's figures are the "
                "tables above and the list just above.*", ""] + body + [""]
    return out


# Goals of the figures that issue #28 restates (its table rows replace them); "issue 28" in a figure's own goal
# or note marks the others.
SUPERSEDED = ("frame build", "frame parse", "in-process, 3 hops", "Python receive", "Python publish", "11 priorities")


def earlier_goals(goals: list) -> list:
    return [g for g in goals if g[0] not in SUPERSEDED and "issue 28" not in g[1] and "issue 28" not in g[4]]


class section:  # noqa: N801 - used as `with section(...)`, a statement about a block
    """One figure of results.md: if its raw outputs are missing or incomplete (every sample failed, a
    program died), the figure says so in one line and the other figures still render (issue #28)."""

    skip: tuple[str, ...] | None = None  # titles a core run (--core) renders; None: every figure

    def __init__(self, out: list[str], broken: list[str], title: str) -> None:
        self.out, self.broken, self.title = out, broken, title

    def __enter__(self) -> None:
        self.start = len(self.out)
        return None

    def __exit__(self, kind: type | None, exc: BaseException | None, tb: object) -> bool:
        if section.skip is not None and self.title not in section.skip:
            del self.out[self.start:]  # a core run did not measure this figure: nothing to say about it
            return kind is None or issubclass(kind, Exception)
        if kind is None or not issubclass(kind, Exception):
            return False
        why = f"{kind.__name__}: {exc}"
        self.out += ["", f"**{self.title}: not produced from this run's raw outputs** ({why}); see 'Failed or "
                     "timed-out samples'.", ""]
        self.broken.append(f"{self.title} ({why})")
        return True


def tree() -> str:
    """The commit the bench ran on (and whether the work tree had changes), so the file names what it measured."""
    head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                          cwd=Path(__file__).parent).stdout.strip() or "?"
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], capture_output=True, text=True,
                           cwd=Path(__file__).parent).stdout.strip()
    return f"{head}{' with uncommitted changes' if dirty else ''}"


def machine() -> str:
    cpu = "?"
    for line in Path("/proc/cpuinfo").read_text().splitlines():
        if line.startswith("model name"):
            cpu = line.split(":", 1)[1].strip()
            break
    gcc = subprocess.run(["gcc", "-dumpversion"], capture_output=True, text=True).stdout.strip()
    load = os.getloadavg()[0]
    return (f"{datetime.date.today()}, {os.cpu_count()} vCPUs ({cpu}), kernel {platform.release()}, gcc {gcc}, "
            f"Python {platform.python_version()}; load average at the end {load:.2f}")


CORE_FIGURES = ("figure 1", "figure 1b: signing", "figure 2", "figure 3", "before and after (BENCH_BASE)",
                "instruction counts along the history (BENCH_COUNTS_AT)")


def main() -> None:
    args = sys.argv[1:]
    core = "--core" in args  # BENCH_ONLY=core (make bench-core): figures 1-3 and their before-and-after only
    args = [a for a in args if a != "--core"]
    raw, out_path = Path(args[0]), Path(args[1])
    out: list[str] = []
    goals: list[tuple[str, str, str, bool, str]] = []  # figure, goal, measured, ok, note
    broken: list[str] = []  # figures whose raw outputs were missing or incomplete
    w = out.append

    w("# uavbus benchmark results: side by side with MAVLink, LCM and the floors" +
      (" (figures 1-3 only)" if core else ""))
    w("")
    w(f"Written by `make {'bench-core' if core else 'bench'}` (bench/run.sh, then bench/tables.py) on {machine()}, "
      f"tree {tree()}.")
    w("All peers ran in the same run on the same machine; compare the **ratios**, not absolute values")
    w("(figures drift between runs and machines; ../shared/anchors/peers.md has the method and earlier peer")
    w("figures). Each figure is median [min - max] over repeated, interleaved samples.")
    w("")
    out.extend(failures_section(read_failures(raw)))
    section.skip = CORE_FIGURES if core else None

    with section(out, broken, "figure 1"):
        # ---- figure 1 ----
        ns, size, ir = read_codec(raw)

        def med(case: str, msg: str) -> float:
            return statistics.median(ns[(case, msg)])

        w("## 1. C codecs (ns per message; callgrind instructions per message)")
        w("")
        w("gcc -O2, pinned to CPU 0 (`taskset -c 0`), 3 processes x 11 samples round-robin across all cases "
          "(calibrated to ~10 ms each); instruction counts from one callgrind run, 20,000 operations per case.")
        w("uavbus frames are 64-byte header + payload (92/116/127 bytes) checked by CRC-32C (hardware path);")
        w("MAVLink v2 frames are 40/64/75 bytes with CRC-16/MCRF4XX; LCM encodings 36/60/71 bytes, no check.")
        w("")
        w("| case | " + " | ".join(MSGS) + " |")
        w("|---|" + "---:|" * len(MSGS))
        rows = [
            ("uavbus frame build: generated pack + the row's header template (ub_frame_tpl_finish: header + both checks)",
             "ub_frame_build"),
            ("the same without a template: generated pack + ub_frame_finish", "ub_frame_build_finish"),
            ("MAVLink mavlink_msg_X_encode -> _pack (incl. finalize + CRC)", "mav_pack"),
            ("MAVLink pack + mavlink_msg_to_send_buffer", "mav_pack_tobuf"),
            ("uavbus streaming parse: ub_decoder_feed (sync + verify) + generated unpack", "ub_frame_parse"),
            ("the same with a foreign-traffic handler set (mixed-stream decoder), pure uavbus stream",
             "ub_frame_parse_foreign"),
            ("MAVLink mavlink_parse_char over the frame + mavlink_msg_X_decode", "mav_parse_decode"),
            ("uavbus generated pack (payload only)", "ub_pack"),
            ("uavbus generated unpack (payload only)", "ub_unpack"),
            ("LCM C encode (lcm-gen)", "lcm_encode"),
            ("LCM C decode (lcm-gen)", "lcm_decode"),
            ("floor: memcpy of the payload (libc, size at run time)", "floor_memcpy"),
            ("floor: CRC-32C over the uavbus frame - 4 bytes", "floor_crc32c"),
            ("floor: MAVLink CRC-16 over the MAVLink frame - 3 bytes", "floor_x25"),
        ]
        for title, case in rows:
            cells = []
            for m in MSGS:
                if (case, m) not in ns:
                    cells.append("-")
                    continue
                c = band(ns[(case, m)], "{:.1f}")
                if (case, m) in ir:
                    c += f" ({ir[(case, m)]:.0f} Ir)"
                cells.append(c)
            w(f"| {title} | " + " | ".join(cells) + " |")
        w("")
        w("Ratios (uavbus / peer, medians of this run; instruction ratio in brackets):")
        w("")
        w("| ratio | " + " | ".join(MSGS) + " | goal |")
        w("|---|" + "---:|" * (len(MSGS) + 1))

        def ratio_row(title: str, num: list[str], den: list[str], goal: str, limit: float) -> list[float]:
            cells, rs = [], []
            for m in MSGS:
                a = sum(med(c, m) for c in num)
                b = sum(med(c, m) for c in den)
                ia = sum(ir.get((c, m), 0) for c in num)
                ib = sum(ir.get((c, m), 0) for c in den)
                rs.append(a / b)
                # No instruction ratio when a count is missing (the callgrind sample failed: see failures).
                icell = (f" ({ia / ib:.3f})" if a < b else f" ({ia / ib:.2f}x)") if ia and ib else ""
                cells.append(f"{a / b:.3f} = 1/{b / a:.1f}{icell}" if a < b else f"{a / b:.2f}x{icell}")
            w(f"| {title} | " + " | ".join(cells) + f" | {goal} |")
            return rs

        r_build = ratio_row("frame build / MAVLink pack", ["ub_frame_build"], ["mav_pack"], "<= 1/8", 1 / 8)
        ratio_row("frame build / MAVLink pack + to_send_buffer", ["ub_frame_build"], ["mav_pack_tobuf"], "-", 0)
        r_parse = ratio_row("frame parse / MAVLink parse + decode", ["ub_frame_parse"], ["mav_parse_decode"], "<= 1/20", 1 / 20)
        r_pu = ratio_row("pack + unpack / LCM encode + decode", ["ub_pack", "ub_unpack"], ["lcm_encode", "lcm_decode"],
                         "<= 1.5x", 1.5)
        r_mixed = (ratio_row("mixed-stream parse (foreign handler set) / parse, pure uavbus stream",
                             ["ub_frame_parse_foreign"], ["ub_frame_parse"], "<= 1.05x", 1.05)
                   if ("ub_frame_parse_foreign", MSGS[0]) in ns else [])
        w("")
        goals.append(("frame build", "<= 1/8 of MAVLink pack", ", ".join(f"1/{1 / r:.1f}" for r in r_build),
                      max(r_build) <= 1 / 8, "see 'What holds a miss back'"))
        goals.append(("frame parse", "<= 1/20 of MAVLink parse + decode", ", ".join(f"1/{1 / r:.1f}" for r in r_parse),
                      max(r_parse) <= 1 / 20, ""))
        goals.append(("pack + unpack", "<= 1.5x LCM encode + decode", ", ".join(f"{r:.2f}x" for r in r_pu),
                      max(r_pu) <= 1.5, ""))
        if r_mixed:  # issue #24: a link that may carry foreign traffic pays at most 5 % on a pure uavbus stream
            # Judged on callgrind's instruction counts when the run has them: deterministic, where two medians of
            # ~20 ns on a shared machine spread by more than the 5 % being judged (the ns ratio is in the row).
            ir_mixed = [ir[("ub_frame_parse_foreign", m)] / ir[("ub_frame_parse", m)] for m in MSGS
                        if ("ub_frame_parse_foreign", m) in ir and ("ub_frame_parse", m) in ir]
            judged = ir_mixed if len(ir_mixed) == len(MSGS) else r_mixed
            goals.append(("mixed-stream decoding", "<= 5 % over figure 1's parse, same run",
                          ", ".join(f"{r:.3f}x" for r in judged) + (" (instructions)" if judged is ir_mixed else " (ns)"),
                          max(judged) <= 1.05, "the handler is looked at once per run between frames, never per byte"))

    with section(out, broken, "figure 1b: signing"):
        # ---- figure 1b: signing ----
        if ("ub_sign", MSGS[0]) in ns:
            w("## 1b. Signed and encrypted frames vs MAVLink 2 signing (ns per frame; callgrind instructions)")
            w("")
            w("Same program and method as figure 1; one 32-byte key on both sides. uavbus SIGNED: SipHash-2-4 "
              "(libsodium) under a KDF-derived 128-bit subkey, 64-bit tag, +11 bytes; ENCRYPTED: XChaCha20-Poly1305, 128-bit tag, +19 bytes. MAVLink 2: "
              "SHA-256 over key + frame truncated to 48 bits, +13 bytes (mavgen C headers, `mavlink_sign_packet`, "
              "`mavlink_signature_check`). uavbus verify includes the replay window; MAVLink's check its stream table.")
            w("")
            w("| case | " + " | ".join(MSGS) + " |")
            w("|---|" + "---:|" * len(MSGS))
            sign_rows = [
                ("uavbus tag: ub_sec_protect of a packed payload (tag + trailer + header + CRC)", "ub_sign"),
                ("MAVLink tag: mavlink_sign_packet", "mav_sign_packet"),
                ("uavbus verify: ub_sec_verify + replay window", "ub_verify"),
                ("MAVLink verify: mavlink_signature_check", "mav_signature_check"),
                ("uavbus signed frame build: generated pack + ub_sec_protect", "ub_signed_build"),
                ("MAVLink signed pack + mavlink_msg_to_send_buffer", "mav_signed_pack_tobuf"),
                ("uavbus signed parse: ub_decoder_feed + verify + window + unpack", "ub_signed_parse"),
                ("MAVLink signed mavlink_parse_char + decode", "mav_signed_parse_decode"),
                ("uavbus ENCRYPTED frame build: pack + ub_sec_protect (AEAD)", "ub_aead_build"),
                ("uavbus ENCRYPTED parse: feed + decrypt + window + unpack", "ub_aead_parse"),
                ("floor: libsodium SipHash-2-4 alone over the same tag input", "floor_siphash24"),
                ("uavbus SIGNED|ORIGIN build: pack + origin tag (pairwise key) + ub_sec_protect", "ub_origin_build"),
                ("uavbus SIGNED|ORIGIN parse: feed + hop tag + origin tag + window + unpack", "ub_origin_parse"),
            ]
            for title, case in sign_rows:
                cells = []
                for m in MSGS:
                    if (case, m) not in ns:
                        cells.append("-")
                        continue
                    c = band(ns[(case, m)], "{:.1f}") + f" / {size[(case, m)]} B"
                    if (case, m) in ir:
                        c += f" ({ir[(case, m)]:.0f} Ir)"
                    cells.append(c)
                w(f"| {title} | " + " | ".join(cells) + " |")
            w("")
            w("Ratios (uavbus / MAVLink, medians of this run; instruction ratio in brackets):")
            w("")
            w("| ratio | " + " | ".join(MSGS) + " | goal |")
            w("|---|" + "---:|" * (len(MSGS) + 1))
            r_sb = ratio_row("signed frame build / MAVLink signed pack + to_send_buffer", ["ub_signed_build"],
                             ["mav_signed_pack_tobuf"], "<= 1/2", 0.5)
            r_sp = ratio_row("signed frame parse + verify / MAVLink signed parse + decode", ["ub_signed_parse"],
                             ["mav_signed_parse_decode"], "<= 1/2", 0.5)
            r_tag = ratio_row("tag alone / mavlink_sign_packet", ["ub_sign"], ["mav_sign_packet"], "-", 0)
            ratio_row("verify alone / mavlink_signature_check", ["ub_verify"], ["mav_signature_check"], "-", 0)
            ratio_row("ENCRYPTED build / MAVLink signed pack + to_send_buffer", ["ub_aead_build"],
                      ["mav_signed_pack_tobuf"], "-", 0)
            ratio_row("ENCRYPTED parse / MAVLink signed parse + decode", ["ub_aead_parse"], ["mav_signed_parse_decode"],
                      "-", 0)
            r_org = []
            if ("ub_origin_build", MSGS[0]) in ns:
                r_org = ratio_row("origin build + parse / MAVLink signed pack + parse (issue 23)",
                                  ["ub_origin_build", "ub_origin_parse"],
                                  ["mav_signed_pack_tobuf", "mav_signed_parse_decode"], "<= 1/4", 0.25)
            w("")
            w("The tag is SipHash-2-4, a PRF made for authenticating short messages: one pass over the 68-byte "
              "signing header and the payload, no key block (the subkey is derived once per key), against MAVLink's "
              "two or three SHA-256 compressions. The floor row is the hash alone; ub_sign adds the signing header, "
              "the trailer, the header check and the CRC.")
            w("")
            fmt = lambda rs: ", ".join(f"{r:.2f}" for r in rs)  # noqa: E731
            goals.append(("signed build", "<= 1/2 of MAVLink signed pack + to_send_buffer, tag >= 64 bit", fmt(r_sb),
                          max(r_sb) <= 0.5, "64-bit tag vs MAVLink's 48; tag alone " + fmt(r_tag)))
            goals.append(("signed parse + verify", "<= 1/2 of MAVLink signed parse + decode", fmt(r_sp),
                          max(r_sp) <= 0.5, ""))
            if r_org:
                goals.append(("origin-authenticated build + verify", "<= 1/4 of MAVLink signed pack + parse", fmt(r_org),
                              max(r_org) <= 0.25, "pair derivation and RAM: figure 1c"))

    with section(out, broken, "figure 1c: origin authentication"):
        # ---- figure 1c: origin authentication (issue 23 item 2; bench/src/origin_bench.c) ----
        if (raw / "origin.tsv").exists():
            ons: dict[str, list[float]] = defaultdict(list)
            osize: dict[str, int] = {}
            ram: dict[str, int] = {}  # the same in every sample
            for line in (raw / "origin.tsv").read_text().splitlines():
                parts = line.split("\t")
                if parts[0] == "ram":
                    ram[parts[1]] = int(parts[2])
                    continue
                ons[parts[0]] += [float(x) for x in parts[2:]]
                osize[parts[0]] = int(parts[1])
            if ram and "pair_derive" in ons:
                w("## 1c. Origin authentication: per-frame cost, pairwise derivation, RAM")
                w("")
                w("bench/src/origin_bench.c, GPS_RAW_INT-sized payload (52 bytes), 3 processes x 11 samples. Origin: "
                  "SipHash-2-4 under a cached pairwise key (docs/security.md, 'Origin authentication'); the hop tag "
                  "of an ORIGIN frame also covers the hop limit and the block. Pair derivation: X25519 + BLAKE2b + "
                  "2 KDF subkeys, once per (entity, peer) and cached. The ratio to MAVLink is figure 1b's.")
                w("")
                w("| case | ns per frame | frame bytes |")
                w("|---|---:|---:|")
                for case in ("signed_build", "signed_verify", "signed_build_verify", "origin_build", "origin_verify",
                             "origin_build_verify", "origin_forward", "pair_derive"):
                    if case in ons:
                        w(f"| {case} | {band(ons[case])} | {osize[case] or '-'} |")
                w("")
                w("| RAM | bytes |")
                w("|---|---:|")
                for what, n in ram.items():
                    w(f"| {what} | {n:,} |")
                w("")
                sb, ob = statistics.median(ons["signed_build_verify"]), statistics.median(ons["origin_build_verify"])
                goals.append(("origin authentication", "handshake cost per pair; RAM for 64 known peers",
                              f"{statistics.median(ons['pair_derive']) / 1000:.1f} us per pair; "
                              f"{next(iter(ram.values())):,} B host, "
                              f"{next((v for k, v in ram.items() if 'Cortex-M4' in k), 0):,} B Cortex-M4; "
                              f"{ob / sb:.2f}x the signed path",
                              True, "measured, no goal beyond figure 1b's ratio"))

    with section(out, broken, "figure 2"):
        # ---- figure 2 ----
        thr, p50, p99, allocs = read_router(raw / "router.txt")
        w("## 2. Router in-process (memlinks, one thread, CPU 0)")
        w("")
        w("Nodes in a line N0 -> ... -> Nh joined by memlinks; N0 originates benchBlob64 (64-byte payload, 128-byte")
        w("frame) to the entity on Nh; the nodes between forward it (verify + dedup + hop-limit rewrite + send).")
        w("msg/s: batches of 32 originated then every memlink pumped, ~50 ms per sample; latency: one frame at a time,")
        w("send to deliver hook. 7 samples each. No peer does in-process routing; MAVLink/LCM have no router.")
        w("")
        w("| hops | delivered msg/s | latency p50 ns | latency p99 ns | allocations after init |")
        w("|---:|---:|---:|---:|---:|")
        for h in sorted(thr):
            w(f"| {h} | {band(thr[h], '{:,.0f}')} | {band(p50[h], '{:.0f}')} | {band(p99[h], '{:.0f}')} | {allocs.get(h)} |")
        w("")
        t3 = statistics.median(thr[3]) if 3 in thr else 0
        goals.append(("in-process, 3 hops", ">= 5 M msg/s delivered", f"{t3 / 1e6:.2f} M msg/s", t3 >= 5e6,
                      "see 'What holds a miss back'"))

    with section(out, broken, "figure 3"):
        # ---- figure 3 ----
        blast, rtt = read_loop(raw / "loop.txt")
        names = {("udp", "1"): "uavbus UDP (ub_udp, batching: sendmmsg/recvmmsg, multi-frame datagrams)",
                 ("tcp", "1"): "uavbus TCP (ub_tcp, batching: multi-frame writes)",
                 ("udp", "0"): "uavbus UDP, batching off (one sendto per frame)",
                 ("raw-udp", "0"): "raw C UDP sockets, 64-byte datagrams (floor)",
                 ("lcm-udpm", "0"): "LCM C udpm ttl=0, stock"}
        w("## 3. Loopback between 2 processes (64-byte payloads)")
        w("")
        w("Inside `unshare -rn` (a private network namespace whose only interface is lo; 224.0.0.0/4 routed to lo).")
        w("Placement by sched_setaffinity: **split** = receiver/echo on CPU 1, sender/pinger on CPU 0; **same** = both")
        w("on CPU 0. Blast: uavbus 1,000,000 frames (300,000 without batching), raw UDP 300,000, LCM 200,000;")
        w("delivered/s = (received-1)/(t_last-t_first) at the receiver, lost % = 1 - received/sent. uavbus sockets")
        w("ask for 4 MiB SO_RCVBUF/SO_SNDBUF, as does the raw floor; LCM is stock. A frame the driver refuses")
        w("(UB_ERR_AGAIN) is retried by the sender after poll(POLLOUT): push back, not loss. RTT: ping-pong of")
        w("single messages, both ends blocking in poll(), 10,000 round trips, first 5 % dropped as warm-up.")
        w(f"uavbus frames carry the 64-byte payload plus the 64-byte header (128 bytes); rounds: "
          f"{max((len(v['delivered_per_s']) for v in blast.values()), default=0)}, interleaved.")
        w("")
        w("| transport | placement | delivered msg/s | lost % | sender refusals retried | ratio to raw UDP | ratio to LCM |")
        w("|---|---|---:|---:|---:|---:|---:|")
        order = [("udp", "1"), ("tcp", "1"), ("udp", "0"), ("raw-udp", "0"), ("lcm-udpm", "0")]
        best = {}
        for pl in ("rx/echo cpu1, tx cpu0", "both cpu0"):
            for t, b in order:
                v = blast.get((t, b, pl))
                if not v:
                    continue
                d = statistics.median(v["delivered_per_s"])
                best[(t, b, pl)] = (d, statistics.median(v["lost_pct"]), max(v["lost_pct"]))
                rawd = statistics.median(blast[("raw-udp", "0", pl)]["delivered_per_s"]) if ("raw-udp", "0", pl) in blast else 0
                lcmd = statistics.median(blast[("lcm-udpm", "0", pl)]["delivered_per_s"]) if ("lcm-udpm", "0", pl) in blast else 0
                r_raw = f"{d / rawd:.1f}x" if rawd else "-"
                r_lcm = f"{d / lcmd:.1f}x" if lcmd else "-"
                w(f"| {names[(t, b)]} | {'split' if 'cpu1' in pl else 'same'} | {band(v['delivered_per_s'], '{:,.0f}')} | "
                  f"{band(v['lost_pct'], '{:.2f}')} | {statistics.median(v['refused_retried']):,.0f} | {r_raw} | {r_lcm} |")
        w("")
        w("| transport | RTT p50 us, same | RTT p99 us, same | RTT p50 us, split | RTT p99 us, split |")
        w("|---|---:|---:|---:|---:|")
        for t, label in (("udp", "uavbus UDP"), ("tcp", "uavbus TCP"), ("raw-udp", "raw C UDP"), ("lcm-udpm", "LCM C udpm")):
            s, x = rtt.get((t, "both cpu0")), rtt.get((t, "rx/echo cpu1, tx cpu0"))
            if s and x:
                w(f"| {label} | {band(s['p50'])} | {band(s['p99'])} | {band(x['p50'])} | {band(x['p99'])} |")
        w("")
        w("Cross-core RTT on this VM is dominated by waking a halted vCPU (~30 us per wake-up, peers.md); same-core")
        w("RTT shows the software path.")
        w("")
        for t, label in (("udp", "UDP"), ("tcp", "TCP")):
            key = (t, "1", "rx/echo cpu1, tx cpu0")
            if key in best:
                d, lost, worst = best[key]
                goals.append((f"loopback {label} (split)", ">= 2 M msg/s with 0 loss", f"{d / 1e6:.2f} M msg/s, "
                              f"lost {lost:.2f} % (worst run {worst:.2f} %)", d >= 2e6 and worst == 0, ""))
            key = (t, "1", "both cpu0")
            if key in best:
                d, lost, worst = best[key]
                goals.append((f"loopback {label} (same core)", ">= 2 M msg/s with 0 loss", f"{d / 1e6:.2f} M msg/s, "
                              f"lost {lost:.2f} % (worst run {worst:.2f} %)", d >= 2e6 and worst == 0,
                              "one vCPU does both ends' work"))

    with section(out, broken, "figure 4"):
        # ---- figure 4 ----
        py: dict[tuple[str, str], list[float]] = defaultdict(list)
        if (raw / "py.txt").exists():
            for line in (raw / "py.txt").read_text().splitlines():
                parts = line.split("\t")
                py[(parts[0], parts[1])] += [float(x) for x in parts[2:]]
        w("## 4. Python (messages/s)")
        w("")
        w("bench/py_bench.py, pinned to CPU 0, 3 processes x 5 samples round-robin. uavbus publish = `Publisher.send_many()`")
        w("of 32 timestamps per call (per frame in C: the field written into the bound wire image + header + CRC-32C +")
        w("memlink); receive = the receiving Node's memlink pump + `service(dispatch=False)` (C verify + dedup + one record")
        w("per delivery into the delivery ring, ub_rxring.h) + `receive().rows(inst)`: one drain call, every field of every")
        w("delivery decoded into a tuple. The per-message paths beside them: `send()` each (timestamp attribute + one cffi")
        w("call per frame) and a `Message` per delivery to an on_data callback. Peers: pymavlink `msg.pack(mav)` /")
        w("`mav.decode(frame)`; LCM Python `obj.encode()` / `T.decode(bytes)` (lcm-gen -p), one message per call.")
        w("")
        w("| case | " + " | ".join(MSGS) + " |")
        w("|---|" + "---:|" * len(MSGS))
        for case in ("uavbus publish", "uavbus publish, send() each", "pymavlink encode", "lcm encode", "uavbus receive",
                     "uavbus receive, Message each", "pymavlink decode", "lcm decode", "uavbus catalogue encode",
                     "uavbus catalogue decode"):
            if all((case, m) in py for m in MSGS):
                w(f"| {case} | " + " | ".join(band(py[(case, m)], "{:,.0f}") for m in MSGS) + " |")
        w("")
        if py:
            w("| ratio | " + " | ".join(MSGS) + " | goal |")
            w("|---|" + "---:|" * (len(MSGS) + 1))
            worst: dict[tuple[str, str], float] = {}
            for ours, peer, goal in (("uavbus publish", "pymavlink encode", ">= 4x"), ("uavbus receive", "pymavlink decode", ">= 4x"),
                                     ("uavbus publish", "lcm encode", ">= 1x"), ("uavbus receive", "lcm decode", ">= 1x"),
                                     ("uavbus publish, send() each", "pymavlink encode", "-"),
                                     ("uavbus receive, Message each", "pymavlink decode", "-"),
                                     ("uavbus publish, send() each", "lcm encode", "-"),
                                     ("uavbus receive, Message each", "lcm decode", "-")):
                if not all((ours, m) in py and (peer, m) in py for m in MSGS):
                    continue
                rs = [statistics.median(py[(ours, m)]) / statistics.median(py[(peer, m)]) for m in MSGS]
                worst[(ours, peer)] = min(rs)
                w(f"| {ours} / {peer} | " + " | ".join(f"{r:.2f}x" for r in rs) + f" | {goal} |")
            w("")
            counted = [c for c in ("uavbus publish", "uavbus receive", "uavbus publish, send() each",
                                   "uavbus receive, Message each", "pymavlink encode", "pymavlink decode",
                                   "lcm encode", "lcm decode") if all((f"calls/msg {c}", m) in py for m in MSGS)]
            if counted:
                w("Python-level calls per message (py_bench, sys.setprofile over one warm batch of 32: Python functions")
                w("and builtins, cffi's included): a count the machine's load cannot move.")
                w("")
                w("| calls per message | " + " | ".join(MSGS) + " |")
                w("|---|" + "---:|" * len(MSGS))
                for c in counted:
                    w(f"| {c} | " + " | ".join(f"{statistics.median(py[(f'calls/msg {c}', m)]):.2f}" for m in MSGS) + " |")
                w("")
            rx_mav, rx_lcm = worst[("uavbus receive", "pymavlink decode")], worst[("uavbus receive", "lcm decode")]
            tx_mav, tx_lcm = worst[("uavbus publish", "pymavlink encode")], worst[("uavbus publish", "lcm encode")]
            goals.append(("Python receive", ">= 4x pymavlink decode and >= 1x LCM decode",
                          f"worst {rx_mav:.2f}x pymavlink, {rx_lcm:.2f}x LCM", rx_mav >= 4 and rx_lcm >= 1,
                          "see 'What holds a miss back'"))
            goals.append(("Python publish", ">= 4x pymavlink encode and >= 1x LCM encode",
                          f"worst {tx_mav:.2f}x pymavlink, {tx_lcm:.2f}x LCM", tx_mav >= 4 and tx_lcm >= 1,
                          "see 'What holds a miss back'"))
        else:
            w("TODO: the Python figure did not run (no uavbus.Node yet).")
            w("")

    with section(out, broken, "figure 5"):
        # ---- figure 5 ----
        gen: dict[int, list[float]] = defaultdict(list)
        for line in (raw / "gen.txt").read_text().splitlines():
            kv = dict(x.split("=") for x in line.split()[1:])
            gen[int(kv["n"])].append(int(kv["ns"]) / 1e9)
        w("## 5. Generator (`uavbus gen`, whole process, synthetic headers)")
        w("")
        w("bench/tools/gen_synth.py writes 20 struct types (4-12 scalars, a nested struct and an array each) and N")
        w("`extern` instances; `uavbus gen` parses (libclang), checks, and writes C, JSON and Python. 3 runs each.")
        w("")
        w("| instances | seconds | ms per instance above the 100-instance run |")
        w("|---:|---:|---:|")
        ns_sorted = sorted(gen)
        base = statistics.median(gen[ns_sorted[0]])
        slopes = []
        for n in ns_sorted:
            m = statistics.median(gen[n])
            slope = (m - base) / (n - ns_sorted[0]) * 1e3 if n != ns_sorted[0] else float("nan")
            if n != ns_sorted[0]:
                slopes.append(slope)
            w(f"| {n:,} | {band(gen[n], '{:.2f}')} | {slope:.3f} |" if n != ns_sorted[0] else f"| {n:,} | {band(gen[n], '{:.2f}')} | - |")
        w("")
        t700 = statistics.median(gen.get(700, [0]))
        linear = len(slopes) >= 2 and max(slopes[1:]) <= 1.5 * max(min(slopes[1:]), 1e-9) and slopes[-1] <= 2 * max(slopes[1], 1e-9)
        goals.append(("generator", "<= 5 s at 700 instances, linear growth",
                      f"{t700:.2f} s at 700; {', '.join(f'{s:.3f}' for s in slopes)} ms/instance", t700 <= 5 and linear, ""))

        scale = [dict(x.split("=") for x in line.split()[1:]) for line in
                 (raw / "scale.txt").read_text().splitlines()] if (raw / "scale.txt").exists() else []
        if scale:
            w("### 5b. Generator and selftest at scale (tests/corpus/big/make_big.py: N instances of N/4 types)")
            w("")
            w("`uavbus gen` and `uavbus selftest` (generate, build the split C test at -O0 on every CPU, run C and")
            w("Python) as whole processes, one run each.")
            w("")
            w("| instances | gen s | selftest s | selftest ok |")
            w("|---:|---:|---:|---|")
            for kv in scale:
                w(f"| {int(kv['n']):,} | {int(kv['gen_ns']) / 1e9:.1f} | {int(kv['selftest_ns']) / 1e9:.1f} | "
                  f"{'yes' if kv['ok'] == '1' else 'NO'} |")
            w("")
            s1k = next((int(kv["selftest_ns"]) / 1e9 for kv in scale if kv["n"] == "1000"), float("nan"))
            goals.append(("selftest at scale", "1,000 instances / 250 types <= 60 s (issue #13)", f"{s1k:.1f} s",
                          s1k <= 60 and all(kv["ok"] == "1" for kv in scale), ""))

    with section(out, broken, "figure 6"):
        # ---- figure 6 ----
        ram = (raw / "ram.txt").read_text()
        sizes = {m.group(1): int(m.group(2)) for m in re.finditer(r"sizeof (\w+) (\d+)", ram)}
        sz = re.search(r"size\s+(\d+)\s+(\d+)\s+(\d+)", ram)
        text, data, bss = (int(sz.group(i)) for i in (1, 2, 3)) if sz else (0, 0, 0)
        static = sizes.get("ub_node_t", 0) + sizes.get("ub_admin_t", 0) + data + bss
        cfg = re.search(r"^config (.*)$", ram, re.M)
        w("## 6. Memory (reference configuration)")
        w("")
        w(f"Runtime compiled with `{cfg.group(1) if cfg else '?'}` (16 entities x 8 links, 4 local entities x 64")
        w("publish/subscribe rows = 256 table entries). libub has no malloc (ub_noalloc_nm test: no allocator symbol in")
        w("the library); the router_hops program interposes malloc/calloc/realloc and counts 0 calls in the runtime after")
        w(f"init (figure 2: {', '.join(f'{h} hop(s): {a}' for h, a in sorted(allocs.items()))}).")
        w("")
        w("| item | bytes |")
        w("|---|---:|")
        for k in ("ub_node_t", "ub_admin_t", "ub_link_t", "ub_udp_t", "ub_tcp_t", "ub_serial_t", "ub_memlink_t"):
            if k in sizes:
                w(f"| sizeof {k}{' (inside ub_node_t)' if k == 'ub_link_t' else ''} | {sizes[k]:,} |")
        w(f"| libub .text / .data / .bss (`size -t`) | {text:,} / {data:,} / {bss:,} |")
        w(f"| **static RAM of a node: ub_node_t + ub_admin_t + .data + .bss** | **{static:,} ({static / 1024:.1f} KiB)** |")
        w("")
        w("Transports are per link and caller-owned on top of that: a UDP link (ub_udp_t, with its batching slots) or a")
        w("TCP link (ub_tcp_t); a memlink is a simulation device (2 x 64 queued frames).")
        w("")
        goals.append(("RAM", "<= 64 KiB static", f"{static / 1024:.1f} KiB (node + admin + .data/.bss), 0 allocations after init",
                      static <= 64 * 1024, "transports extra, per link"))

    with section(out, broken, "figure 6b: the core on a microcontroller"):
        # ---- figure 6b: the core on a microcontroller ----
        if (raw / "mcu.txt").exists():
            mcu = (raw / "mcu.txt").read_text()
            fw = re.search(r"^firmware\s+(\d+)\s+(\d+)\s+(\d+)", mcu, re.M)
            lib = re.search(r"^libub\s+(\d+)\s+(\d+)\s+(\d+)", mcu, re.M)
            ram_syms = [(int(m.group(1), 16), m.group(2)) for m in
                        re.finditer(r"^sym [0-9a-f]+ ([0-9a-f]+) [bBdD] (\S+)$", mcu, re.M)]
            big = sorted(ram_syms, reverse=True)[:3]
            caps_m = re.search(r"^caps (.*)$", mcu, re.M)
            caps = {k: int(v) for k, v in (kv.split("=") for kv in caps_m.group(1).split())} if caps_m else {}
            vehicle = {"entities": 16, "node_links": 4, "links_per_entity": 4, "pubsub_rows": 32}   # issue 25
            caps_ok = bool(caps) and all(caps.get(k, 0) >= v for k, v in vehicle.items())
            w("## 6b. The core on a microcontroller")
            w("")
            w("`examples/mcu/firmware.c`: the firmware `make test` and `make demo` boot in QEMU (mps2-an386): one node")
            w("hosting fcs20, one UART link, the entity table fixed at build time, the imu.h/gps.h catalogue, the flight")
            w("model; cross-compiled with Debian's arm-none-eabi-gcc for a Cortex-M4F, `-Os`, newlib-nano,")
            w("`--gc-sections`, POSIX parts off, security on: libsodium 1.0.18 cross-built from its sources, the group")
            w("key's signing and origin tags from the authority's provisioned pairs (docs/security.md, 'Microcontrollers').")
            w("Capacities of a vehicle (`examples/mcu/mcu_ub_config.h`, recorded in the ELF's `fw_capacities`): 16 entities,")
            w("4 links, 32 publish/subscribe rows (no administration table on the board: a ground station's sets its flows")
            w("up), 8 provisioned pairs. `.bss` includes the 16 KiB stack the linker script reserves, whose regions are the")
            w("budget (124 KiB code + the 4 KiB PROVISION sector, 64 KiB RAM): a firmware that outgrows it fails to link.")
            w("")
            w("| item | code (.text) | .data | .bss |")
            w("|---|---:|---:|---:|")
            if lib:
                w(f"| libub.a, core only (`size -t`) | {int(lib.group(1)):,} | {int(lib.group(2)):,} | {int(lib.group(3)):,} |")
            if fw:
                w(f"| firmware.elf (what the board flashes / needs in RAM) | {int(fw.group(1)):,} | {int(fw.group(2)):,} | "
                  f"{int(fw.group(3)):,} |")
            w("")
            if caps:
                w("Capacities as the ELF records them (`fw_capacities`, read by `uavbus.sim.qemu.firmware_capacities`): "
                  + ", ".join(f"{k} {v}" for k, v in caps.items()) + ".")
                w("")
            if big:
                w("Largest RAM objects: " + ", ".join(f"`{name}` {size:,} B" for size, name in big) + ".")
                w("The node is the application's static storage (no configuration text is parsed on the board);")
                w("smaller capacities in `mcu_ub_config.h` (each a -D) shrink it.")
                w("")
            if fw:
                flash, ram = int(fw.group(1)) + int(fw.group(2)), int(fw.group(2)) + int(fw.group(3))
                # A common Cortex-M4 part has 128-256 KiB of flash and 64 KiB of RAM or more.
                built = (f"{caps['entities']} entities, {caps['node_links']} links, {caps['pubsub_rows']} rows "
                         "(from the ELF)" if caps else "capacities not recorded in the ELF")
                goals.append(("MCU", "the core and a node with >= 16 entities, 4 links, 32 rows fit a Cortex-M4: "
                              "<= 128 KiB flash, <= 64 KiB RAM",
                              f"firmware {flash / 1024:.1f} KiB flash, {ram / 1024:.1f} KiB RAM; {built}",
                              flash <= 128 * 1024 and ram <= 64 * 1024 and caps_ok,
                              "stack included; boots in QEMU (tests/hitl)"))

    with section(out, broken, "figure 7: bridges (bench/bridges_tables.py)"):
        # ---- figure 7: bridges (bench/bridges_tables.py) ----
        from bridges_tables import bridges_section, mavdoor_section  # bench/ is the script's own directory

        bridges_section(raw, w)
        mavdoor_section(raw, w)

    with section(out, broken, "figure 8: fleets (bench/fleet_tables.py)"):
        # ---- figure 8: fleets (bench/fleet_tables.py) ----
        from fleet_tables import render as fleet_section  # bench/ is the script's own directory

        fleet_section(raw, w, goals)

    with section(out, broken, "figure 9: the wire for real radios (bench/wire_tables.py)"):
        # ---- figure 9: the wire for real radios (bench/wire_tables.py) ----
        from wire_tables import render as wire_section

        wire_section(raw, w, goals)

    with section(out, broken, "figure 10: remote inspection (bench/inspect_tables.py)"):
        # ---- figure 10: remote inspection (bench/inspect_tables.py) ----
        from inspect_tables import render as inspect_section  # bench/ is the script's own directory

        inspect_section(raw, w, goals)

    with section(out, broken, "figure 11: priorities on slow links (bench/prio_tables.py)"):
        # ---- figure 11: priorities on a 57,600-baud radio (bench/prio_tables.py) ----
        from prio_tables import render as prio_section  # bench/ is the script's own directory

        prio_section(raw, w, goals)

    with section(out, broken, "before and after (BENCH_BASE)"):
        out.extend(before_after(raw))
    with section(out, broken, "instruction counts along the history (BENCH_COUNTS_AT)"):
        out.extend(history_section(raw))

    # ---- goals: issue #28's, each from this run's raw outputs, then the earlier ones still tracked ----
    notes = None if core else Path(__file__).with_name("results_notes.md")
    g28 = [r for r in goal_tables.measure(raw, read_failures(raw)) if not core or r.spec.figure in ("1", "2")]
    profiles: set[str] = set()
    if not core:  # the appendix is written at the end; which profiles it has is known now
        profile_lines: list[str] = []
        with section(profile_lines, broken, "profiles of the in-process goals"):
            profiles = profile_tables.render(raw, profile_lines.append)
    w("## Goals")
    w("")
    w("Issue #28's goals, each measured from this run's raw outputs (bench/goal_tables.py); a goal whose samples "
      "failed or are missing is reported as such and not met. A miss links to its profile in this run's appendix "
      "and its next step in the hand-kept notes.")
    w("")
    goal_tables.render(g28, notes_keys(notes), profiles, w)
    w("")
    w("Earlier goals still tracked (from the figures above):")
    w("")
    w("| figure | goal | measured (this run) | met |")
    w("|---|---|---|:---:|")
    for fig, goal, measured, ok, note in earlier_goals(goals):
        w(f"| {fig} | {goal} | {measured} | {'✓' if ok else '✗'} |")
    if not earlier_goals(goals):
        w("| - | none measured in this run (no figure above produced one) | - | - |")
    w("")
    if broken:
        w("## Figures not produced in this run")
        w("")
        w("".join(f"- {b}\n" for b in broken))
    # The hand-kept analysis is about full runs; a core run lists its misses only.
    out.extend(misses_section(earlier_goals(goals), notes, g28, profiles))

    # ---- commands and raw internals ----
    w("## Exact commands")
    w("")
    w("```")
    w(f"make {'bench-core  # = BENCH_ONLY=core' if core else 'bench       # ='} bench/run.sh (setup: pip install -e "
      "'.[bench]' (pymavlink, lcm); apt valgrind if missing)")
    w((raw / "commands.txt").read_text().rstrip() if (raw / "commands.txt").exists() else "(no commands.txt)")
    w("```")
    w("")
    for title, f in (("Frame codec internals (ub_frame_bench)", "frame_bench.txt"),
                     ("Router cost per frame (ub_router_bench)", "router_bench.txt"),
                     ("Checksum false-accept rate (ub_far 200000)", "far.txt")):
        if (raw / f).exists():
            w(f"## Appendix: {title}")
            w("")
            w("```")
            w((raw / f).read_text().rstrip())
            w("```")
            w("")
    if not core:
        out.extend(profile_lines)
    out_path.write_text("\n".join(out) + "\n")


if __name__ == "__main__":
    main()
