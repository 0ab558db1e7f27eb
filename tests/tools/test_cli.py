"""A command line with no tracebacks (issue 14, item 7): real `uavbus` processes.

--version; every user error is one line on stderr with what to do and a documented exit status
(uavbus.cli.EXIT_CODES, docs/tools.md); `| head` ends quietly; `--only NAME` leaves the file name alone;
-I/-D have help; a bug is one `internal error` line (UAVBUS_DEBUG=1 shows the traceback); and a short
seeded fuzz run of the command line and the log tools on damaged input finds nothing.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
from pathlib import Path

import pytest
from tools_testutil import ROOT, UAVBUS

from uavbus import __version__, cli

TABLE2 = ROOT / "examples" / "configs" / "table2.json"


def run(*argv: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run([UAVBUS, *argv], capture_output=True, text=True, timeout=60, env=env)


def test_version() -> None:
    for argv in (["--version"], ["spy", "--version"], ["log", "--version"]):
        res = run(*argv)
        assert res.returncode == 0 and res.stdout == f"uavbus {__version__}\n", argv
    assert run("--help").stdout.count("Exit status: 0 ok") == 1


def one_line_error(res: subprocess.CompletedProcess[str], code: int, *says: str) -> None:
    assert res.returncode == code, (res.returncode, res.stderr)
    assert "Traceback" not in res.stderr
    assert res.stderr.count("\n") == 1, f"not one line: {res.stderr!r}"
    for text in says:
        assert text in res.stderr, (text, res.stderr)


def test_user_errors_are_one_line_with_documented_status(tmp_path: Path, sample_log, catalogue_path: Path) -> None:
    log, _, _ = sample_log()
    not_a_log = tmp_path / "notes.txt"
    not_a_log.write_text("hello\n")
    bad_config = tmp_path / "bad.json"
    bad_config.write_text('{"entities": [{"name": "a", "linktoentity": {"b": "0x1"}}]}\n')
    taken = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    taken.bind(("127.0.0.1", 0))
    busy = taken.getsockname()[1]
    live = ["--config", str(TABLE2), "--node", "gcs", "--catalogue", str(catalogue_path), "--duration", "0.1"]
    try:
        cases = [
            (["frob"], 2, "unknown command 'frob'", "uavbus --help"),
            (["hz"], 2, "uavbus hz: the following arguments are required: name", "(see uavbus hz --help)"),
            (["hz", "gpsOut", "--log", str(log), "--window", "-1"], 2, "'-1': give a number above 0"),
            (["log", "info", str(tmp_path / "missing.ublog")], 3, "missing.ublog: No such file or directory"),
            (["log", "info", str(not_a_log)], 3, "not a uavbus log (no UBLOG1/UBLOG2/UBLOG3 magic)"),
            (["log", "export", str(log), "--csv", "--only", "gpsOutt"], 2, "--only gpsOutt: not in the log's catalogue"),
            (["log", "play", str(log), "--into", "udp:host=1"], 2, "'host=1' is not a udp parameter"),
            (["tables", "--static", "--config", str(bad_config), "--node", "x"], 3,
             "bad.json:1: entity 'a', field 'linktoentity.b': no entity named 'b' in 'entities'"),
            (["spy", "--config", str(TABLE2), "--node", "tower", "--catalogue", str(catalogue_path)], 3,
             "no node named 'tower' in 'nodes' (known: primary, secondary, backup, gcs)"),
            (["spy", *live, "--port", "gcsPortDatalink1=udp:bind=nowhere"], 3,
             "port gcsPortDatalink1=udp:bind=nowhere", "dotted IPv4"),
            (["spy", *live, "--port", f"gcsPortDatalink1=udp:bind=127.0.0.1:{busy}"], 4,
             f"cannot open udp:bind=127.0.0.1:{busy}", "Address already in use"),
            (["spy", *live, "--subscribe", "gpsOutt@rmax1ob1/100"], 3, "no instance 'gpsOutt'"),
            (["echo", "gpsOut", "--log", str(log), "--field", "nope"], 2, "has no member 'nope'"),
        ]
        for argv, code, *says in cases:
            one_line_error(run(*argv), code, *says)
    finally:
        taken.close()
    for code in {c for _, c, *_ in cases}:
        assert code in cli.EXIT_CODES


def test_broken_pipe_is_quiet(sample_log) -> None:
    log, _, _ = sample_log(n_gps=400)  # 2,400 records: far more CSV than a pipe holds
    res = subprocess.run(["bash", "-c", f'"{UAVBUS}" log export "{log}" --csv | head -1; exit "${{PIPESTATUS[0]}}"'],
                         capture_output=True, text=True, timeout=60)
    assert res.stdout.startswith("t_ms,time,link,dir,name,source,dest,seq,kind,dup,")
    assert res.stderr == ""
    assert res.returncode == cli.EXIT_BROKEN_PIPE


def test_only_does_not_swallow_the_file_name(sample_log) -> None:
    log, _, _ = sample_log()
    res = run("log", "export", "--csv", "--only", "gpsOut", str(log))
    assert res.returncode == 0, res.stderr
    names = {line.split(",")[4] for line in res.stdout.splitlines()[1:]}
    assert names == {"gpsOut"}
    both = run("log", "export", "--jsonl", "--only", "gpsOut,imuOut", str(log))
    assert both.returncode == 0 and both.stdout.count("\n") == 120


def test_generator_include_and_define_options_have_help() -> None:
    text = " ".join(run("gen", "--help").stdout.split())
    assert "-I DIR add DIR to the include path" in text
    assert "-D NAME[=VAL] define a macro for parsing" in text


def test_a_bug_is_one_line_and_debug_shows_the_traceback(monkeypatch: pytest.MonkeyPatch, capsys) -> None:
    def broken(argv: list[str]) -> int:
        raise ZeroDivisionError("division by zero")

    monkeypatch.setitem(cli.TOOLS, "broken", ("uavbus.tools.live", "spy_main"))
    import uavbus.tools.live as live

    monkeypatch.setattr(live, "spy_main", broken)
    assert cli.main(["broken"]) == cli.EXIT_INTERNAL
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "uavbus broken: internal error: ZeroDivisionError: division by zero" in err
    monkeypatch.setenv("UAVBUS_DEBUG", "1")
    assert cli.main(["broken"]) == cli.EXIT_INTERNAL
    assert "Traceback (most recent call last)" in capsys.readouterr().err


def test_fuzz_the_command_line_and_the_log_tools() -> None:
    """The short deterministic run (`make fuzz` runs the long one): thousands of damaged logs, configs,
    catalogues and argument vectors, each ending in a documented status without a traceback."""
    harness = ROOT / "fuzz" / "python" / "fuzz_cli.py"
    res = subprocess.run([sys.executable, str(harness), "--iterations", "1500", "--seed", "2005"],
                         capture_output=True, text=True, timeout=240, env={**os.environ, "UAVBUS_DEBUG": ""})
    assert res.returncode == 0, res.stderr[-4000:]
    assert "0 finding(s)" in res.stdout
    # The run reached every kind of outcome, so the oracle was exercised, not bypassed.
    for status in ("0:", "2:", "3:", "4:"):
        assert status in res.stdout.split("exit statuses")[1], res.stdout
