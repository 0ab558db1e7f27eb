"""The bench survives faults (issue #28, Build 7): a failed or hung sample is reported, never a hang or a dead run.

Real processes with injected faults: bench/src/loop_bench.c built here from the bench catalogue and the
runtime sources, run with tiny counts and LOOP_BENCH_FAULT (an echo child that exits early, a send that
fails once); bench/tools/sample.sh (the deadline every child of bench/run.sh runs under) on a command that
fails and one that hangs; bench/tables.py's reading of those outputs. No timing is asserted.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SAMPLE = ROOT / "bench" / "tools" / "sample.sh"
sys.path.insert(0, str(ROOT / "bench"))

import tables  # noqa: E402  (bench/tables.py)


@pytest.fixture(scope="session")
def loop_bench(tmp_path_factory: pytest.TempPathFactory, build_bench: Callable[..., Path]) -> Path:
    out = tmp_path_factory.mktemp("loop_bench")
    # its own catalogue code too: loop_bench packs the bench contents itself
    return build_bench(out, "loop_bench", "-Ibench/catalogue", f"-I{out / 'gen'}", str(out / "gen/benchcat.c"))


def kv(line: str) -> dict[str, str]:
    return {k: v.strip('"') for k, v in re.findall(r'(\w+)=("[^"]*"|\S+)', line)}


def run(exe: Path, *args: str, fault: str = "", deadline: str = "20") -> subprocess.CompletedProcess:
    env = dict(os.environ, LOOP_BENCH_DEADLINE_S=deadline, LOOP_BENCH_FAULT=fault)
    # The outer timeout is the test's own guard: loop_bench must end long before it.
    return subprocess.run([str(exe), *args], env=env, capture_output=True, text=True, timeout=60)


@pytest.mark.parametrize("transport", ["tcp", "udp", "raw-udp"])
def test_echo_child_exiting_early_is_a_reported_failure_not_a_hang(loop_bench: Path, transport: str) -> None:
    # The run that hung 12 minutes: rtt tcp, the echo child gone, the pinger waiting for ever.
    r = run(loop_bench, "rtt", transport, "300", "split", fault="echo-exit:5")
    assert r.returncode == 3, r.stderr
    line = kv(r.stdout.strip().splitlines()[-1])
    assert line["status"] == "failed" and line["mode"] == "rtt" and line["transport"] == transport
    assert "exited early" in line["reason"], line
    assert "p50_us" not in line  # no figure for a failed sample


@pytest.mark.parametrize("transport", ["tcp", "udp", "raw-udp"])
def test_receiver_exiting_during_a_blast_is_a_reported_failure(loop_bench: Path, transport: str) -> None:
    r = run(loop_bench, "blast", transport, "100000", "same", fault="echo-exit:50")
    assert r.returncode == 3, r.stderr
    line = kv(r.stdout.strip().splitlines()[-1])
    assert line["status"] == "failed" and "exited early" in line["reason"], line


@pytest.mark.parametrize("transport", ["tcp", "udp", "raw-udp"])
def test_a_send_that_fails_once_is_retried_and_counted(loop_bench: Path, transport: str) -> None:
    # The run that died with "loop_bench: send: Connection refused": one refused send must not end the sample.
    r = run(loop_bench, "blast", transport, "500", "same", fault="send-fail-once")
    assert r.returncode == 0, r.stdout + r.stderr
    line = kv(r.stdout)
    assert line["status"] == "ok" and line["send_errors"] == "1" and line["n"] == "500", line
    assert int(line["received"]) == 500 or transport != "tcp"  # TCP loses nothing; UDP may, and says so


def test_without_faults_samples_finish(loop_bench: Path) -> None:
    for mode, transport in (("rtt", "tcp"), ("rtt", "udp"), ("blast", "tcp")):
        r = run(loop_bench, mode, transport, "300", "same")
        assert r.returncode == 0, r.stdout + r.stderr
        line = kv(r.stdout)
        assert line["status"] == "ok" and line["send_errors"] == "0", line


def test_deadline_ends_a_sample_that_cannot_finish(loop_bench: Path) -> None:
    # 1 s for 50 million round trips: the sample ends at its deadline with a report.
    t0 = time.monotonic()
    r = run(loop_bench, "rtt", "udp", "50000000", "same", deadline="1")
    assert r.returncode == 3
    line = kv(r.stdout.strip().splitlines()[-1])
    assert line["status"] == "failed" and "deadline" in line["reason"], line
    assert time.monotonic() - t0 < 30  # not a timing claim: "it ended", with a wide margin


def test_sample_sh_records_failures_and_timeouts_and_the_run_goes_on(tmp_path: Path, loop_bench: Path) -> None:
    out = tmp_path / "loop.txt"
    env = dict(os.environ, LOOP_BENCH_DEADLINE_S="20", LOOP_BENCH_FAULT="")
    script = (f'set -e\n'
              f'"{SAMPLE}" "{out}" 30 "{loop_bench}" rtt udp 200 same\n'
              f'LOOP_BENCH_FAULT=echo-exit:3 "{SAMPLE}" "{out}" 30 "{loop_bench}" rtt tcp 200 same\n'
              f'"{SAMPLE}" "{out}" 1 sleep 60\n'
              f'"{SAMPLE}" "{out}" 30 "{loop_bench}" blast udp 200 same\n'
              f'echo run-went-on\n')
    r = subprocess.run(["bash", "-c", script], env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and "run-went-on" in r.stdout, r.stderr
    fails = tables.read_failures(tmp_path)
    assert [f["status"] for f in fails] == ["failed", "timeout"], fails
    assert "rtt tcp 200" in fails[0]["cmd"] and "exited early" in fails[0]["reason"]
    assert fails[1]["cmd"] == "sleep 60" and fails[1]["deadline_s"] == "1"
    # tables.py pools only the finished samples and lists the failures in results.md.
    blast, rtt = tables.read_loop(out)
    assert list(rtt) == [("udp", "both cpu0")] and len(rtt[("udp", "both cpu0")]["p50"]) == 1
    assert list(blast) == [("udp", "1", "both cpu0")]
    text = "\n".join(tables.failures_section(fails))
    assert "2 sample(s) of this run failed" in text and "| timeout |" in text and "| failed |" in text
    assert "None" in "\n".join(tables.failures_section([]))


def test_what_holds_a_miss_back_quotes_this_runs_figures_and_labels_the_hand_analysis(tmp_path: Path) -> None:
    goals = [("in-process, 3 hops", ">= 5 M msg/s delivered", "4.03 M msg/s", False, ""),
             ("RAM", "<= 64 KiB static", "40.0 KiB", True, "")]
    notes = tmp_path / "notes.md"
    notes.write_text("# heading\nanalysed-run: the run of 2026-11-23 (12fba5f)\n\n- **3 hops (1.91 M msg/s).**\n")
    text = "\n".join(tables.misses_section(goals, notes))
    generated, hand = text.split("### ", 1)
    assert "in-process, 3 hops**: goal >= 5 M msg/s delivered; measured 4.03 M msg/s" in generated
    assert "RAM" not in generated  # met goals are not misses
    assert "1.91" not in generated  # the hand-kept figure never appears as this run's
    assert hand.startswith("Analysis kept by hand") and "the run of 2026-11-23 (12fba5f)" in hand
    assert "not from this run" in hand and "1.91 M msg/s" in hand
    # The real notes file names the run it analysed.
    real = (ROOT / "bench" / "results_notes.md").read_text()
    assert re.search(r"^analysed-run: .+", real, re.M)


def test_tables_renders_what_ran_and_names_what_did_not(tmp_path: Path) -> None:
    # A run where every figure but the Python one failed: results.md is still written, figure 4 has its
    # tables and goals from this run's samples, every other figure says in one line why it is missing.
    raw = tmp_path / "raw"
    raw.mkdir()
    rows = []
    for case, rate in (("uavbus publish", 900), ("pymavlink encode", 100), ("lcm encode", 300),
                       ("uavbus receive", 500), ("pymavlink decode", 100), ("lcm decode", 600)):
        for m in tables.MSGS:
            rows.append("\t".join([case, m, str(rate), str(rate + 10), str(rate - 10)]))
    rows += [f"calls/msg uavbus receive\t{m}\t0.72" for m in tables.MSGS]  # one count per process
    (raw / "py.txt").write_text("\n".join(rows) + "\n")
    (raw / "failures.txt").write_text('status=timeout exit=124 deadline_s=150 out=loop.txt '
                                      'cmd="loop_bench rtt tcp 10000 split" reason="no result"\n')
    out = tmp_path / "results.md"
    subprocess.run([sys.executable, str(ROOT / "bench" / "tables.py"), str(raw), str(out)], check=True, timeout=60)
    text = out.read_text()
    assert "| timeout | loop.txt | `loop_bench rtt tcp 10000 split` |" in text
    assert "**figure 3: not produced from this run's raw outputs** (FileNotFoundError" in text
    assert "| uavbus publish / pymavlink encode | 9.00x | 9.00x | 9.00x | >= 4x |" in text
    assert "| uavbus receive / lcm decode | 0.83x | 0.83x | 0.83x | >= 1x |" in text
    assert "| uavbus receive | 0.72 | 0.72 | 0.72 |" in text  # calls per message
    misses = text.split("## What holds a miss back", 1)[1]
    assert "**Python receive** (issue #28, figure 4): goal Python receive ≥ 4× pymavlink and ≥ 1× LCM Python " \
           "(3 messages); measured worst 5.00× pymavlink (ATTITUDE), 0.83× LCM Python (ATTITUDE)." in misses


def _dump(d: Path, pid: int, name: str, ir: int) -> None:
    d.mkdir(exist_ok=True)
    (d / f"cg.{pid}").write_text(f"version: 1\ncmd: x\ndesc: Trigger: Client Request: {name}\n\nsummary: {ir}\n"
                                 f"totals: {ir + 999}\n")


def test_core_run_renders_figures_1_to_3_and_the_before_and_after_by_instruction_count(tmp_path: Path) -> None:
    # make bench-core BENCH_BASE=REF: bench/results-core.md has figures 1-3, the base beside this tree by time
    # and by callgrind count, and nothing about figures the core run does not measure.
    raw = tmp_path / "raw"
    raw.mkdir()
    cases = ("ub_frame_build", "mav_pack", "mav_pack_tobuf", "ub_frame_parse", "mav_parse_decode", "ub_pack",
             "ub_unpack", "lcm_encode", "lcm_decode")
    for name, scale in (("codec.tsv", 1.0), ("base_codec.tsv", 0.9)):
        (raw / name).write_text("".join(f"{c}\t{m}\t100\t" + "\t".join(str(scale * (10 + i)) for i in range(3)) + "\n"
                                        for c in cases for m in tables.MSGS))
    for name, rate in (("router.txt", 4e6), ("base_router.txt", 5e6)):
        (raw / name).write_text("".join(f"throughput hops={h} msgs_per_s={rate / h}\nlatency hops={h} p50_ns={100 * h} "
                                        f"p99_ns={300 * h}\n" for h in (1, 3)) + "allocations hops=1 after_init=0\n")
    for name in ("loop.txt", "base_loop.txt"):
        (raw / name).write_text(
            'mode=blast transport=udp placement="both cpu0" batching=1 n=10 received=10 delivered_per_s=2000000 '
            'lost_pct=0.000 offered_per_s=2000000 refused_retried=0 send_errors=0 status=ok\n'
            'mode=rtt transport=udp placement="both cpu0" n=10 p50_us=20.00 p99_us=40.00 send_errors=0 status=ok\n')
    (raw / "base_ref.txt").write_text("681a8a9\n")
    for d, k in (("callgrind", 1.05), ("base_callgrind", 1.0)):
        for i, m in enumerate(tables.MSGS):
            _dump(raw / d, 10 + i, f"ub_frame_build/{m}", int(k * 250 * 20000))
            _dump(raw / d, 20 + i, f"ub_frame_parse/{m}", int(k * 340 * 20000))
        _dump(raw / d, 31, "router/hops=1", int(k * 1800 * tables.ROUTER_CG_FRAMES))
        _dump(raw / d, 33, "router/hops=3", int(k * 4000 * tables.ROUTER_CG_FRAMES))
        _dump(raw / d, 41, "loop/rtt-udp/tx", int(k * 2200 * tables.LOOP_CG_ROUNDTRIPS))
        _dump(raw / d, 42, "loop/rtt-udp/rx", int(k * 2200 * tables.LOOP_CG_ROUNDTRIPS))
    out = tmp_path / "results-core.md"
    subprocess.run([sys.executable, str(ROOT / "bench" / "tables.py"), "--core", str(raw), str(out)], check=True,
                   timeout=60)
    text = out.read_text()
    assert "(figures 1-3 only)" in text and "make bench-core" in text
    assert "## 1. C codecs" in text and "## Before and after" in text
    assert "| 1 | frame build, ATTITUDE: instructions per frame | 262 | 250 | 1.050 |" in text
    assert "| 2 | 3 hop(s): instructions per delivered frame | 4,200 | 4,000 | 1.050 |" in text
    assert "| 3 | RTT udp: user-space instructions per round trip (both processes) | 4,620 | 4,400 | 1.050 |" in text
    assert "| 2 | delivered msg/s, 1 hop(s) |" in text and text.count("| 0.800 |") == 2  # 4 M / 5 M, both hops
    assert "By instruction count (this run's callgrind dumps): this tree / 681a8a9 from 1.050 to 1.050" in text
    # Nothing about figures a core run does not measure: no 'not produced' lines, no hand-kept analysis.
    for absent in ("not produced", "## 4.", "figure 1c", "Analysis kept by hand", "Figures not produced"):
        assert absent not in text, absent


def test_before_after_without_base_counts_says_to_judge_by_time(tmp_path: Path) -> None:
    raw = tmp_path / "raw"
    raw.mkdir()
    for name in ("codec.tsv", "base_codec.tsv"):
        (raw / name).write_text("".join(f"{c}\t{m}\t100\t10\t11\n" for c in ("ub_frame_build", "ub_frame_parse")
                                        for m in tables.MSGS))
    for name in ("router.txt", "base_router.txt"):
        (raw / name).write_text("throughput hops=1 msgs_per_s=5\nlatency hops=1 p50_ns=1 p99_ns=2\n")
    for name in ("loop.txt", "base_loop.txt"):
        (raw / name).write_text("")
    (raw / "base_ref.txt").write_text("abc1234\n")
    text = "\n".join(tables.before_after(raw))
    assert "| 1 | frame build ns, ATTITUDE | 10.5 [10.0 - 11.0] | 10.5 [10.0 - 11.0] | 1.000 |" in text
    assert "instructions per" not in text and "judge by the time rows" in text


@pytest.fixture(scope="session")
def router_hops(tmp_path_factory: pytest.TempPathFactory, loop_bench: Path) -> Path:
    gen = loop_bench.parent / "gen"
    sodium = subprocess.run(["pkg-config", "--libs", "libsodium"], capture_output=True, text=True,
                            check=True).stdout.split()
    exe = loop_bench.parent / "router_hops"
    subprocess.run(["gcc", "-O1", "-std=gnu11", "-Wall", "-Wextra", "-Werror", "-D_POSIX_C_SOURCE=200809L",
                    "-DUB_SECURITY=1", "-Iruntime_c/include", "-Iruntime_c/src", "-Ibench/catalogue", f"-I{gen}",
                    "bench/src/router_hops.c", str(gen / "benchcat.c"),
                    *sorted(str(p.relative_to(ROOT)) for p in (ROOT / "runtime_c/src").glob("*/*.c")),
                    *sodium, "-ldl", "-lm", "-o", str(exe)], check=True, cwd=ROOT)
    return exe


@pytest.mark.parametrize("hops", ["1", "3"])
def test_router_hops_count_mode_carries_every_frame(router_hops: Path, hops: str) -> None:
    # The fixed work figure 2's instruction count is taken over (outside valgrind the dump is a no-op): it
    # fails loudly when a frame is not delivered, so a count never divides by frames that did not arrive.
    r = subprocess.run([str(router_hops), hops, "callgrind"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == f"callgrind hops={hops} frames={tables.ROUTER_CG_FRAMES}"


def test_counts_along_the_history_name_each_commit_and_compare_with_the_first(tmp_path: Path) -> None:
    # BENCH_COUNTS_AT="A B": one column per commit (oldest first) and this tree's, from callgrind dumps only.
    raw = tmp_path / "raw"
    raw.mkdir()
    (raw / "counts_at.txt").write_text("aaaaaaa before the core\nbbbbbbb the core narrowed\n")
    for d, k in ((raw / "at-aaaaaaa", 1.0), (raw / "at-bbbbbbb", 0.99), (raw / "callgrind", 1.05)):
        _dump(d, 1, "router/hops=1", int(k * 1800 * tables.ROUTER_CG_FRAMES))
        _dump(d, 2, "ub_frame_build/ATTITUDE", int(k * 240 * 20000))
    _dump(raw / "callgrind", 3, "router/hops=3", 4000 * tables.ROUTER_CG_FRAMES)  # absent from the refs: no row
    text = "\n".join(tables.history_section(raw))
    assert "| figure | case | aaaaaaa | bbbbbbb | this tree | this tree / aaaaaaa |" in text
    assert "| 2 | 1 hop(s): instructions per delivered frame | 1,800 | 1,782 | 1,890 | 1.050 |" in text
    assert "| 1 | frame build, ATTITUDE: instructions per frame | 240 | 238 | 252 | 1.050 |" in text
    assert "3 hop(s)" not in text and "aaaaaaa before the core; bbbbbbb the core narrowed" in text
    assert tables.history_section(tmp_path) == []  # no BENCH_COUNTS_AT in the run: no section
    # With BENCH_BASE in the same run, its counts are the first column.
    (raw / "base_ref.txt").write_text("0000000\n")
    _dump(raw / "base_callgrind", 1, "router/hops=1", 2000 * tables.ROUTER_CG_FRAMES)
    _dump(raw / "base_callgrind", 2, "ub_frame_build/ATTITUDE", 200 * 20000)
    text = "\n".join(tables.history_section(raw))
    assert "| figure | case | 0000000 (BENCH_BASE) | aaaaaaa | bbbbbbb | this tree | this tree / 0000000 |" in text
    assert "| 2 | 1 hop(s): instructions per delivered frame | 2,000 | 1,800 | 1,782 | 1,890 | 0.945 |" in text


BEFORE_CORE = "681a8a9"  # the last commit before the narrow core (#22): flat runtime_c/src, no ub_origin.h


def test_bench_base_builds_the_base_runtime_and_the_programs_link_against_it(tmp_path: Path, loop_bench: Path) -> None:
    # make bench BENCH_BASE=681a8a9 once stopped at a header the base lacks. The base's runtime from
    # bench/tools/runtime_at.sh (its flat source tree) and figures 2 and 3's programs built against it, as
    # bench/run.sh builds them, and the count mode run over it. (codec_bench needs the peers' generated
    # headers, which only make bench installs; its origin cases are guarded by __has_include the same way.)
    if subprocess.run(["git", "cat-file", "-e", f"{BEFORE_CORE}^{{commit}}"], cwd=ROOT, capture_output=True).returncode:
        pytest.skip(f"{BEFORE_CORE} is not in this clone's history (shallow clone)")
    at = tmp_path / "base"
    subprocess.run([str(ROOT / "bench/tools/runtime_at.sh"), BEFORE_CORE, str(at)], cwd=ROOT, check=True, timeout=600)
    assert (at / "lib/libub.a").stat().st_size > 0 and not (at / "src/runtime_c/include/ub/ub_origin.h").exists()
    gen = loop_bench.parent / "gen"
    sodium = subprocess.run(["pkg-config", "--libs", "libsodium"], capture_output=True, text=True,
                            check=True).stdout.split()
    flags = ["-O1", "-std=gnu11", "-Wall", "-Wextra", "-Werror", "-D_POSIX_C_SOURCE=200809L",
             f"-I{at / 'src/runtime_c/include'}", "-Ibench/catalogue", f"-I{gen}"]
    for prog, extra in (("router_hops", ["-ldl"]), ("loop_bench", [])):
        subprocess.run(["gcc", *flags, f"bench/src/{prog}.c", str(gen / "benchcat.c"), str(at / "lib/libub.a"),
                        *sodium, *extra, "-o", str(tmp_path / prog)], cwd=ROOT, check=True, timeout=300)
    r = subprocess.run([str(tmp_path / "router_hops"), "1", "callgrind"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0 and r.stdout.strip() == f"callgrind hops=1 frames={tables.ROUTER_CG_FRAMES}", r.stderr
    r = run(tmp_path / "loop_bench", "rtt", "udp", "200", "same")
    assert r.returncode == 0 and kv(r.stdout)["status"] == "ok", r.stdout + r.stderr


def test_a_count_that_fails_is_reported_and_the_counts_go_on(tmp_path: Path, router_hops: Path) -> None:
    # bench/tools/counts.sh (figures 1-3 by callgrind): a program that dies is a line of raw/failures.txt and
    # the next count still runs; the script exits 0. Needs valgrind (make bench installs it).
    if shutil.which("valgrind") is None:
        pytest.skip("valgrind is not installed (make bench installs it)")
    raw, bad, good = tmp_path / "raw", tmp_path / "bad", tmp_path / "good"
    raw.mkdir()
    bad.mkdir()
    good.mkdir()
    (bad / "router_hops").write_text("#!/bin/sh\necho 'router_hops: send refused' >&2\nexit 2\n")
    (bad / "router_hops").chmod(0o755)
    (good / "router_hops").symlink_to(router_hops)
    counts = str(ROOT / "bench" / "tools" / "counts.sh")
    r = subprocess.run(["bash", "-c", f'"{counts}" "{bad}" "{raw}/base_callgrind" 2 && '
                                      f'"{counts}" "{good}" "{raw}/callgrind" 2 && echo went-on'],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0 and "went-on" in r.stdout, r.stderr
    fails = tables.read_failures(raw)
    assert [(f["status"], f["out"], f["reason"]) for f in fails] == [
        ("failed", "counts-base_callgrind.log", "router_hops: send refused")] * 2, fails
    assert "router_hops" in fails[0]["cmd"] and fails[0]["cmd"].endswith("1 callgrind")
    vals = tables.instruction_values(raw / "callgrind")
    assert set(vals) == {("2", "1 hop(s): instructions per delivered frame"),
                         ("2", "3 hop(s): instructions per delivered frame")}
    assert 0 < vals[("2", "1 hop(s): instructions per delivered frame")] < vals[("2", "3 hop(s): instructions per delivered frame")]
    assert tables.instruction_rows(raw) == []  # no base counts: the before-and-after judges by time, and says so
