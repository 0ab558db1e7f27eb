"""Appendix of bench/results.md: where the in-process goals of issue #28 spend their work, from this run.

Called by bench/tables.py; each profile is read from a raw output of the same `make bench` run:
- frame build and parse: the callgrind dumps figure 1 already takes (codec_bench callgrind: one dump per
  case, 20,000 operations each), read function by function;
- 3 hops: router_hops 3 callgrind (20,000 frames through 3 hops; bench/tools/counts.sh figure 2);
- Python publish and receive: bench/py_profile.py (cProfile over batched publish + receive) -> profile_py.txt;
- 1,000 vehicles: `perf record` (sampling, no call graph) around the 1,000-vehicle sample itself ->
  perf report's flat profile in profile_fleet1k.txt.
Each section has an HTML anchor that the Goals table and "What holds a miss back" link to.
"""

from __future__ import annotations

import re
from collections import defaultdict
from pathlib import Path
from typing import Callable

MSGS = ["ATTITUDE", "GPS_RAW_INT", "HIGHRES_IMU"]
TOP = 8
CODEC_CG_ITERS = 20000  # codec_bench's BENCH_ITERS
ROUTER_CG_FRAMES = 20000  # router_hops.c CG_N


def name_table(path: Path) -> dict[str, str]:
    """Function names by compressed id over every dump of the process that wrote path (cg.PID, cg.PID.N): a
    dump refers by id to names an earlier dump of the same process defined (fn= or cfn=)."""
    pid = re.match(r"(cg\.\d+)", path.name)
    files = sorted(path.parent.glob(pid.group(1) + "*")) if pid else [path]
    names: dict[str, str] = {}
    for f in files:
        for m in re.finditer(r"^c?fn=\((\d+)\) (.+)$", f.read_text(errors="replace"), re.M):
            names[m.group(1)] = m.group(2)
    return names


def parse_callgrind(path: Path, names: dict[str, str] | None = None) -> tuple[int, dict[str, list[int]]]:
    """One callgrind dump: (total Ir, {function: [self Ir, inclusive Ir]}). Inclusive = self + the cost of the
    calls it makes as callgrind records them (a recursive function's is counted once per level)."""
    names = dict(name_table(path) if names is None else names)
    fns: dict[str, list[int]] = defaultdict(lambda: [0, 0])
    npos, col = 1, 0
    total = 0
    fn = "?"
    in_call = False
    for line in path.read_text(errors="replace").splitlines():
        if line.startswith("positions:"):
            npos = len(line.split()) - 1
        elif line.startswith("events:"):
            ev = line.split()[1:]
            col = ev.index("Ir") if "Ir" in ev else 0
        elif line.startswith(("summary:", "totals:")) and total == 0:
            total = int(line.split()[1 + col])
        elif line.startswith("fn="):
            m = re.match(r"fn=(?:\((\d+)\))?\s*(.*)$", line)
            ident, name = m.group(1), m.group(2)
            if ident is not None and name:
                names[ident] = name
            fn = name if ident is None else names.get(ident, name or f"fn#{ident}")
        elif line.startswith("calls="):
            in_call = True
        elif line[:1].isdigit() or line[:1] in "+-*":
            parts = line.split()
            if len(parts) <= npos + col:
                in_call = False
                continue
            ir = int(parts[npos + col])
            if in_call:
                fns[fn][1] += ir
            else:
                fns[fn][0] += ir
                fns[fn][1] += ir
            in_call = False
    return total, dict(fns)


def dumps_by_name(d: Path) -> dict[str, Path]:
    """Callgrind dumps of a directory by the name the program gave them (CALLGRIND_DUMP_STATS_AT)."""
    out = {}
    for f in sorted(d.glob("cg.*")) if d.is_dir() else []:
        with f.open(errors="replace") as fh:
            head = fh.read(4096)
        m = re.search(r"desc: Trigger: Client Request: (\S+)", head)
        if m:
            out[m.group(1)] = f
    return out


def _short(name: str) -> str:
    return name if len(name) <= 60 else name[:57] + "..."


def callgrind_table(path: Path, per: int, w: Callable[[str], None]) -> None:
    total, fns = parse_callgrind(path)
    w(f"Total {total / per:,.0f} instructions per operation (callgrind, {per:,} operations).")
    w("")
    w("| function | self Ir per op | inclusive Ir per op | self % |")
    w("|---|---:|---:|---:|")
    for name, (s, inc) in sorted(((k, v) for k, v in fns.items() if v[0] > 0), key=lambda kv: -kv[1][0])[:TOP]:
        w(f"| `{_short(name)}` | {s / per:,.1f} | {inc / per:,.1f} | {100 * s / total if total else 0:.1f} |")
    w("")


def read_py(raw: Path) -> dict[str, tuple[int, list[tuple[str, float, float, float]]]]:
    """profile_py.txt (bench/py_profile.py): {message: (messages, [(function, calls, tottime s, cumtime s)])}."""
    out: dict[str, tuple[int, list]] = {}
    f = raw / "profile_py.txt"
    if not f.exists():
        return out
    for line in f.read_text().splitlines():
        p = line.split("\t")
        if p[0] == "pyprof" and len(p) == 7:
            n, rows = out.get(p[1], (int(p[2]), []))
            rows.append((p[3], float(p[4]), float(p[5]), float(p[6])))
            out[p[1]] = (n, rows)
    return out


def read_perf(raw: Path) -> list[tuple[float, str]]:
    """profile_fleet1k.txt: perf report --stdio --no-children --sort dso,symbol lines "  12.34%  prog  [.] name"."""
    f = raw / "profile_fleet1k.txt"
    if not f.exists():
        return []
    rows = []
    for line in f.read_text().splitlines():
        m = re.match(r"\s*([\d.]+)%\s+(\S+)\s+\[[.k]\]\s+(\S+)", line)
        if m:
            rows.append((float(m.group(1)), f"{m.group(3)} ({m.group(2)})"))
    return rows


def render(raw: Path, w: Callable[[str], None]) -> set[str]:
    """The profile appendix; returns the anchors of the profiles this run produced."""
    made: set[str] = set()
    cg = dumps_by_name(raw / "callgrind")
    w("## Appendix: profiles of the in-process goals (this run)")
    w("")
    w("Taken in this run from the same bench programs as the figures (method in bench/profile_tables.py). "
      "Instruction counts do not move with the machine's load; a profile that could not be taken says so.")
    w("")
    for anchor, title, case in (("profile-frame-build", "frame build (figure 1): ub_frame_build, callgrind",
                                 "ub_frame_build"),
                                ("profile-parse", "streaming parse (figure 1): ub_frame_parse, callgrind",
                                 "ub_frame_parse")):
        have = [m for m in MSGS if f"{case}/{m}" in cg]
        w(f'<a id="{anchor}"></a>')
        w("")
        w(f"### Profile: {title}")
        w("")
        if not have:
            w(f"**No profile in this run**: no `{case}/*` callgrind dump in raw/callgrind (see 'Failed or timed-out "
              "samples').")
            w("")
            continue
        made.add(anchor)
        peer = "mav_pack" if case == "ub_frame_build" else "mav_parse_decode"
        for m in have:
            ptot = parse_callgrind(cg[f"{peer}/{m}"])[0] / CODEC_CG_ITERS if f"{peer}/{m}" in cg else None
            w(f"**{m}**" + (f" (MAVLink's `{peer}`: {ptot:,.0f} instructions per operation)" if ptot else ""))
            w("")
            callgrind_table(cg[f"{case}/{m}"], CODEC_CG_ITERS, w)

    w('<a id="profile-3-hops"></a>')
    w("")
    w("### Profile: 3 hops in process (figure 2): router_hops 3 callgrind, per delivered frame")
    w("")
    if "router/hops=3" in cg:
        made.add("profile-3-hops")
        if "router/hops=1" in cg:
            one = parse_callgrind(cg["router/hops=1"])[0] / ROUTER_CG_FRAMES
            w(f"1 hop takes {one:,.0f} instructions per delivered frame in the same run.")
            w("")
        callgrind_table(cg["router/hops=3"], ROUTER_CG_FRAMES, w)
    else:
        w("**No profile in this run**: no `router/hops=3` callgrind dump in raw/callgrind.")
        w("")

    w('<a id="profile-python"></a>')
    w("")
    w("### Profile: Python publish and receive (figure 4): cProfile, per message")
    w("")
    py = read_py(raw)
    if py:
        made.add("profile-python")
        w("bench/py_profile.py: figure 4's batched path (`send_many` of 32 + memlink pump + `service(dispatch=False)` "
          "+ `receive().rows()`) under cProfile; `publish_batch`/`receive_batch` are the two sides' totals. cProfile's "
          "own cost per call inflates the times (compare the functions, not with figure 4's rates).")
        w("")
        for m, (n, rows) in py.items():
            w(f"**{m}** ({n:,} messages)")
            w("")
            w("| function | calls per msg | own µs per msg | cumulative µs per msg |")
            w("|---|---:|---:|---:|")
            sides = [r for r in rows if r[0].endswith(("(publish_batch)", "(receive_batch)"))]
            for name, calls, tot, cum in sides + sorted((r for r in rows if r not in sides), key=lambda r: -r[2])[:TOP]:
                w(f"| `{_short(name)}` | {calls / n:.3f} | {1e6 * tot / n:.3f} | {1e6 * cum / n:.3f} |")
            w("")
    else:
        w("**No profile in this run**: raw/profile_py.txt is missing (see 'Failed or timed-out samples').")
        w("")

    w('<a id="profile-fleet-1000"></a>')
    w("")
    w("### Profile: 1,000 vehicles + 2 GCS in process (figure 8): perf record around the sample, flat")
    w("")
    perf = read_perf(raw)
    if perf:
        made.add("profile-fleet-1000")
        w("`perf record -F 199` (user-space samples, no call graph) around the 1,000-vehicle run itself; share of its "
          "samples by function (nodes, memlinks and the harness alike).")
        w("")
        w("| function (object) | share of samples |")
        w("|---|---:|")
        for pct, name in perf[:TOP + 4]:
            w(f"| `{_short(name)}` | {pct:.2f} % |")
        w("")
    else:
        w("**No profile in this run**: raw/profile_fleet1k.txt is missing or empty (perf unavailable, or the "
          "sample failed: see 'Failed or timed-out samples').")
        w("")
    return made
