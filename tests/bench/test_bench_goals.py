"""results.md's Goals table states issue #28's goals from the run's raw outputs, and a miss points at a profile.

bench/tables.py run as make bench runs it, over raw directories written here: the figures in the Goals table
are the raw files' (change the file, the row changes), a missing or failed sample is a row that says so and
is never met, and a missed in-process goal links to the profile the same run produced (callgrind dumps read
function by function) or says there is none. No timing is asserted.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "bench"))

import goal_tables  # noqa: E402  (bench/goal_tables.py)
import profile_tables  # noqa: E402
import tables  # noqa: E402

MSGS = tables.MSGS


def render(raw: Path) -> str:
    out = raw.parent / "results.md"
    subprocess.run([sys.executable, str(ROOT / "bench" / "tables.py"), str(raw), str(out)], check=True, timeout=120)
    return out.read_text()


def row(text: str, goal: str) -> list[str]:
    """The cells of the Goals table's row for one of #28's goals."""
    line = next(ln for ln in text.splitlines() if ln.startswith("| ") and f"| {goal} |" in ln)
    return [c.strip() for c in line.strip("|").split(" | ")]


def spec(key: str) -> goal_tables.Spec:
    return next(s for s in goal_tables.SPECS if s.key == key)


def write_raw(raw: Path, *, build_ns: float = 10.0, hops3: float = 6.5e6, delivery: dict[str, float] | None = None,
              rtf: tuple[float, float] = (16, 8), procs_cpu: float = 1.5, prio_p99: float = 20) -> None:
    """One raw file per figure of #28, each with the given figure."""
    raw.mkdir(exist_ok=True)
    codec = {"ub_frame_build": build_ns, "mav_pack": 100.0, "ub_frame_parse": 10.0, "mav_parse_decode": 300.0}
    (raw / "codec.tsv").write_text("".join(f"{c}\t{m}\t100\t{v}\t{v}\t{v}\n" for c, v in codec.items() for m in MSGS))
    (raw / "router.txt").write_text("".join(f"throughput hops={h} msgs_per_s={hops3 * (2 if h == 1 else 1)}\n"
                                            f"latency hops={h} p50_ns=100 p99_ns=200\n" for h in (1, 3)))
    py = {"uavbus publish": 900, "pymavlink encode": 100, "lcm encode": 300, "uavbus receive": 500,
          "pymavlink decode": 100, "lcm decode": 600}
    (raw / "py.txt").write_text("".join(f"{c}\t{m}\t{v}\t{v}\n" for c, v in py.items() for m in MSGS))
    lat = lambda us: [{"n": 10, "p50_us": us, "p99_us": 2 * us}]  # noqa: E731
    (raw / "bridges.json").write_text(
        '{"meta": [{"runs": 1, "affinity": [0], "lat_n": 10, "lat_hz": 1, "blast_mavlink": 1, "blast_uavbus": 1}], '
        '"mav_direct_lat": [], "mav_bridge_lat": [], "mav_direct_ingest": [], "mav_bridge_ingest": [], '
        f'"ub_direct_lat": {lat(100)}, "ub_zenoh_lat": {lat(200)}, '.replace("'", '"') +
        '"ub_direct_tput": [{"sent": 10, "received": 10, "rate": 80000}], '
        '"ub_zenoh_tput": [{"sent": 10, "received": 10, "rate": 60000}]}')
    delivery = {"10": 0.999, "30": 0.998, "100": 0.997} if delivery is None else delivery
    fleet = [f"fleet_inproc n={n} links=10 sim_s=100 wall_s=10 realtime_factor=10.0 failures=10 samples=10 "
             f"delivery_failures={d} cpu_ms_per_vehicle_s=2.0" for n, d in delivery.items()]
    fleet.append(f"fleet_inproc n=1000 links=1900 sim_s={rtf[0]} wall_s={rtf[1]} realtime_factor=0.0 failures=0 "
                 "delivery_quiet=1.0 cpu_ms_per_vehicle_s=0.5")
    fleet.append(f"fleet_procs n=30 links=49 cpu_ms_per_vehicle_s={procs_cpu} cpu_ms_per_gcs_s=3.0")
    (raw / "fleet.txt").write_text("\n".join(fleet) + "\n")
    (raw / "prio.txt").write_text(f"prio\tuavbus compact\t1\t0\t218\t10\t{prio_p99}\t30\n"
                                  "prio\tuavbus compact\t0\t0\t217\t310\t334\t347\n")


def test_every_goal_of_issue_28_is_stated_with_this_runs_figure(tmp_path: Path) -> None:
    raw = tmp_path / "raw"
    write_raw(raw)
    text = render(raw)
    goals = text.split("## Goals", 1)[1].split("Earlier goals still tracked", 1)[0]
    for s in goal_tables.SPECS:  # every goal of #28, in its own words, once
        assert goals.count(f"| {s.goal} |") == 1, s.goal
    assert row(text, spec("frame build").goal)[2:4] == [
        "ATTITUDE 1/10.0; GPS_RAW_INT 1/10.0; HIGHRES_IMU 1/10.0 (time: medians of this run)", "✓"]
    assert row(text, spec("parse").goal)[2:4] == [
        "ATTITUDE 1/30.0; GPS_RAW_INT 1/30.0; HIGHRES_IMU 1/30.0 (time: medians of this run)", "✓"]
    assert row(text, spec("3 hops").goal)[2:4] == ["6.50 M msg/s (median of 1, 6.50 - 6.50)", "✓"]
    assert row(text, spec("Python publish").goal)[2:4] == [
        "worst 9.00× pymavlink (ATTITUDE), 3.00× LCM Python (ATTITUDE)", "✓"]
    assert row(text, spec("Python receive").goal)[2:4] == [
        "worst 5.00× pymavlink (ATTITUDE), 0.83× LCM Python (ATTITUDE)", "✗"]
    assert row(text, spec("Zenoh throughput").goal)[2:4] == ["60.0 k frames/s, median of 1 runs (direct UDP 80.0 k)",
                                                             "✓"]
    assert row(text, spec("Zenoh latency").goal)[3] == "✓" and "100 µs added" in row(text, spec("Zenoh latency").goal)[2]
    assert row(text, spec("fleet delivery").goal)[2:4] == ["10: 99.90 %, 30: 99.80 %, 100: 99.70 %", "✓"]
    # The real-time factor from sim_s / wall_s, not from fleet_bench's one-decimal print (0.0 here).
    assert row(text, spec("1,000 vehicles").goal)[2:4] == [
        "real-time factor 2.000 (16 s simulated in 8 s, 0.500 ms CPU per vehicle per s)", "✓"]
    assert row(text, spec("uavbus_node CPU").goal)[2:4] == ["1.50 ms (30 vehicles, UDP)", "✓"]
    assert row(text, spec("priorities").goal)[2:4] == ["p99 20 ms; without priorities 334 ms", "✓"]
    # The older goals #28 restates are not listed twice, with their old bounds.
    assert "<= 1/8 of MAVLink pack" not in text and ">= 5 M msg/s delivered" not in text


def test_the_figures_follow_the_raw_files(tmp_path: Path) -> None:
    # The same goals over other raw values: every figure and verdict moves with the file, none is typed in.
    raw = tmp_path / "raw"
    write_raw(raw, build_ns=14.0, hops3=5.9e6, delivery={"10": 0.999, "30": 0.99, "100": 0.999}, rtf=(16, 400),
              procs_cpu=14.4, prio_p99=51)
    text = render(raw)
    assert row(text, spec("frame build").goal)[2:4] == [
        "ATTITUDE 1/7.1; GPS_RAW_INT 1/7.1; HIGHRES_IMU 1/7.1 (time: medians of this run)", "✗"]
    assert row(text, spec("3 hops").goal)[2:4] == ["5.90 M msg/s (median of 1, 5.90 - 5.90)", "✗"]
    assert row(text, spec("fleet delivery").goal)[2:4] == ["10: 99.90 %, 30: 99.00 %, 100: 99.90 %", "✗"]
    assert row(text, spec("1,000 vehicles").goal)[2].startswith("real-time factor 0.040 (16 s simulated in 400 s")
    assert row(text, spec("uavbus_node CPU").goal)[2:4] == ["14.40 ms (30 vehicles, UDP)", "✗"]
    assert row(text, spec("priorities").goal)[2:4] == ["p99 51 ms; without priorities 334 ms", "✗"]
    misses = text.split("## What holds a miss back", 1)[1].split("### Analysis kept by hand", 1)[0]
    assert "- **3 hops** (issue #28, figure 2): goal 3 hops in process ≥ 6 M msg/s; measured 5.90 M msg/s" in misses
    assert "- **Python publish**" not in misses  # met


def test_a_missing_or_failed_sample_is_reported_and_never_met(tmp_path: Path) -> None:
    raw = tmp_path / "raw"
    write_raw(raw, delivery={"10": 0.999, "30": 0.999})  # the 100-vehicle sample failed
    (raw / "py.txt").unlink()  # figure 4 died
    (raw / "router.txt").write_text("latency hops=3 p50_ns=100 p99_ns=200\n")  # no throughput sample
    (raw / "bridges.json").unlink()
    (raw / "failures.txt").write_text(
        'status=timeout exit=124 deadline_s=900 out=py.txt cmd="python bench/py_bench.py" reason="no result"\n'
        'status=failed exit=2 deadline_s=1200 out=fleet.txt cmd="fleet_bench 100" reason="learn_full"\n'
        'status=failed exit=1 deadline_s=1800 out=bridges.log cmd="python bench/bridges_bench.py" reason="zenoh"\n')
    text = render(raw)
    for key in ("Python publish", "Python receive"):
        cells = row(text, spec(key).goal)
        assert cells[2].startswith("**no sample in this run** (raw/py.txt missing)") and cells[3] == "✗", cells
        assert "1 sample(s) of py.txt failed or timed out" in cells[2]
    cells = row(text, spec("3 hops").goal)
    assert cells[2].startswith("**no sample in this run**") and cells[3] == "✗", cells
    cells = row(text, spec("fleet delivery").goal)
    assert cells[2].startswith("10: 99.90 %, 30: 99.90 %; 100: no sample") and cells[3] == "✗", cells
    assert "1 sample(s) of fleet.txt failed" in cells[2]
    for key in ("Zenoh throughput", "Zenoh latency"):
        cells = row(text, spec(key).goal)
        assert "no sample in this run" in cells[2] and "bridges.log failed" in cells[2] and cells[3] == "✗", cells
    # Every one of them is a miss in 'What holds a miss back', with its figure as it stands.
    misses = text.split("## What holds a miss back", 1)[1].split("### Analysis kept by hand", 1)[0]
    for key in ("Python publish", "Python receive", "3 hops", "fleet delivery", "Zenoh throughput"):
        assert f"- **{key}** (issue #28" in misses, key
    # No goal of #28 at all in an empty run: every row says so, none is met.
    empty = tmp_path / "empty" / "raw"
    empty.mkdir(parents=True)
    text = render(empty)
    for s in goal_tables.SPECS:
        cells = row(text, s.goal)
        assert cells[2].startswith("**no sample in this run**") and cells[3] == "✗", cells


def _cg(path: Path, body: str, name: str | None, total: int) -> None:
    trig = f"desc: Trigger: Client Request: {name}\n" if name else "desc: Trigger: Program termination\n"
    path.write_text(f"# callgrind format\nversion: 1\npid: 7\npositions: line\nevents: Ir\n{trig}summary: {total}\n\n"
                    + body)


def test_callgrind_dumps_are_read_function_by_function(tmp_path: Path) -> None:
    d = tmp_path / "callgrind"
    d.mkdir()
    # The first dump of the process names the functions; the case's dump refers to them by id only.
    _cg(d / "cg.7", "fn=(1) ub_build_0\n0 1\ncfn=(2) tpl_finish_sse42\ncalls=1 0\n0 5\nfn=(2)\n0 5\n", None, 6)
    _cg(d / "cg.7.1", "fn=(1)\n3 400000\n+1 20000\ncfn=(2)\ncalls=20000 0\n0 1600000\nfn=(2)\n0 1600000\n"
        "fn=(3) benchcat_pack_benchAttitude\n* 360000\n", "ub_frame_build/ATTITUDE", 2380000)
    dumps = profile_tables.dumps_by_name(d)
    assert list(dumps) == ["ub_frame_build/ATTITUDE"]
    total, fns = profile_tables.parse_callgrind(dumps["ub_frame_build/ATTITUDE"])
    assert total == 2380000
    assert fns == {"ub_build_0": [420000, 2020000], "tpl_finish_sse42": [1600000, 1600000],
                   "benchcat_pack_benchAttitude": [360000, 360000]}
    lines: list[str] = []
    profile_tables.callgrind_table(dumps["ub_frame_build/ATTITUDE"], 20000, lines.append)
    text = "\n".join(lines)
    assert "Total 119 instructions per operation" in text
    assert text.index("`tpl_finish_sse42` | 80.0 | 80.0 | 67.2 |") < text.index("`ub_build_0` | 21.0 | 101.0 | 17.6 |")


def test_a_missed_in_process_goal_links_to_this_runs_profile_or_says_there_is_none(tmp_path: Path) -> None:
    raw = tmp_path / "raw"
    write_raw(raw, build_ns=14.0, hops3=5.0e6)
    d = raw / "callgrind"
    d.mkdir()
    for i, m in enumerate(MSGS):
        _cg(d / f"cg.9.{i + 1}", f"fn=(1) ub_build_{i}\n0 2000000\ncfn=(2) tpl_finish_sse42\ncalls=20000 0\n"
            "0 1000000\nfn=(2)\n0 1000000\n", f"ub_frame_build/{m}", 3000000)
        _cg(d / f"cg.9.{i + 4}", "fn=(3) mav_pack\n0 20000000\n", f"mav_pack/{m}", 20000000)
    text = render(raw)
    build = row(text, spec("frame build").goal)
    assert build[3] == "✗" and build[4].startswith("profile: [this run's](#profile-frame-build)")
    assert "instructions 1/6.7" in build[2]  # 1,000 / 150 per operation, from the dumps
    appendix = text.split('<a id="profile-frame-build"></a>', 1)[1]
    assert "**ATTITUDE** (MAVLink's `mav_pack`: 1,000 instructions per operation)" in appendix
    assert "| `ub_build_0` | 100.0 | 150.0 | 66.7 |" in appendix
    # 3 hops missed too, but this run has no router_hops dump: the row says there is no profile.
    hops = row(text, spec("3 hops").goal)
    assert hops[3] == "✗" and hops[4].startswith("**no profile in this run**"), hops
    assert "**No profile in this run**: no `router/hops=3` callgrind dump" in text
    # A met goal points nowhere.
    assert row(text, spec("parse").goal)[4] == "-"


def test_the_notes_hold_a_next_step_for_every_goal_of_issue_28_and_name_their_run() -> None:
    notes = ROOT / "bench" / "results_notes.md"
    assert tables.notes_keys(notes) == {s.key for s in goal_tables.SPECS}
    assert re.search(r"^analysed-run: .+", notes.read_text(), re.M)


def test_python_and_fleet_profiles_are_rendered_per_message_and_linked(tmp_path: Path) -> None:
    # bench/py_profile.py's lines and perf report's flat profile, as make bench writes them.
    raw = tmp_path / "raw"
    write_raw(raw, rtf=(16, 320))  # Python receive misses (0.83x LCM), 1,000 vehicles too
    (raw / "profile_py.txt").write_text("".join(
        f"pyprof\t{m}\t6400\t{name}\t{calls}\t{tot}\t{cum}\n" for m in MSGS for name, calls, tot, cum in (
            ("py_bench.py:92(receive_batch)", 200, 0.0004, 0.0224),
            ("py_bench.py:89(publish_batch)", 200, 0.0002, 0.0080),
            ("node.py:837(rows)", 200, 0.0064, 0.0090),
            ("<built-in method uavbus._ub.ub_memlink_pump>", 400, 0.0032, 0.0032))))
    (raw / "profile_fleet1k.txt").write_text(
        "    18.37%  fleet_bench_1k     [.] route_tick                -      -\n"
        "     1.17%  [kernel.kallsyms]  [k] finish_task_switch.isra.0 -      -\n")
    text = render(raw)
    py = text.split('<a id="profile-python"></a>', 1)[1].split("<a id=", 1)[0]
    assert "**ATTITUDE** (6,400 messages)" in py
    assert "| `node.py:837(rows)` | 0.031 | 1.000 | 1.406 |" in py  # per message: 6.4 ms / 6,400
    # the two sides' totals first, then the functions by own time
    assert py.index("(receive_batch)") < py.index("(rows)") < py.index("ub_memlink_pump")
    fleet = text.split('<a id="profile-fleet-1000"></a>', 1)[1]
    assert "| `route_tick (fleet_bench_1k)` | 18.37 % |" in fleet
    assert "| `finish_task_switch.isra.0 ([kernel.kallsyms])` | 1.17 % |" in fleet
    assert row(text, spec("Python receive").goal)[4].startswith("profile: [this run's](#profile-python)")
    assert row(text, spec("1,000 vehicles").goal)[4].startswith("profile: [this run's](#profile-fleet-1000)")
    assert row(text, spec("1,000 vehicles").goal)[2].startswith("real-time factor 0.050 ")


def test_a_message_missing_from_a_figure_is_no_sample_not_a_partial_verdict(tmp_path: Path) -> None:
    # "3 messages": a run whose HIGHRES_IMU lines are gone must not be judged on the other two.
    raw = tmp_path / "raw"
    write_raw(raw)
    for name in ("py.txt", "codec.tsv"):
        f = raw / name
        f.write_text("".join(ln for ln in f.read_text().splitlines(keepends=True) if "HIGHRES_IMU" not in ln))
    text = render(raw)
    assert row(text, spec("Python publish").goal)[2:4] == [
        "**no sample in this run** (no 'uavbus publish' or 'pymavlink encode' sample for HIGHRES_IMU in py.txt)", "✗"]
    assert row(text, spec("frame build").goal)[2:4] == [
        "**no sample in this run** (no ub_frame_build or mav_pack sample for HIGHRES_IMU in codec.tsv)", "✗"]
