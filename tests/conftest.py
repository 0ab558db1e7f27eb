"""Which tests `make test` may run two at a time and which must run alone (the Makefile's test-py).

`make test-py` runs pytest twice: first `-m "not serial" -n 2` (pytest-xdist, a test file to a worker), then
`-m serial` in one process. A test is `serial` unless its folder is in PARALLEL (or its file in PARALLEL_FILES):
those hold only tests whose outcome does not depend on how busy the machine is (the generator, compilers and
CMake, the packaged wheel, the bench harness's failure reporting and its simulated-clock figure). Everything
else, rates and deliveries of real processes over a window, fleets, QEMU, the browser, the bridges, stays in
the one-process pass, where nothing else of make test runs beside it. A new folder is serial until it is
listed here.
"""

from __future__ import annotations

from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
PARALLEL = frozenset({"bench", "golden", "integration", "packaging", "realworld", "unit"})
# Single files of a serial folder that time nothing: the command line's error statuses and its seeded fuzz
# loop (a fixed number of iterations, ~10 % of the tools folder's time); the log reader and the log tools on
# files the test writes (a follower waits for its writer's `done`, whatever the pace; `log play` on an injected
# clock; the spy that waits 0.3 s for nothing to come); the C writer's logs and the tables tool over in-process
# memlinks pumped by the test; the bridges' refusals, their MCAP export of a memlink log and a CMake configure.
# Those eight files took 43 s of a one-process run at load 6 (10.8 s of CPU, mostly `uavbus` subprocesses).
PARALLEL_FILES = frozenset({
    "tools/test_cli.py",
    "tools/test_logfile.py", "tools/test_log_tools.py", "tools/test_log_damage_findings.py",
    "tools/test_c_log_and_tables.py", "tools/test_tools_truth.py",
    "bridges/test_bridge_errors.py", "bridges/test_mcap_export.py", "bridges/test_mavbridge_packaging.py",
})


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "serial: checks timing on this machine; make test runs it with no other test "
                                       "beside it (tests/conftest.py)")


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        try:
            rel = Path(str(item.fspath)).resolve().relative_to(HERE)
        except ValueError:
            rel = Path("")
        parallel = (rel.parts[0] in PARALLEL if rel.parts else False) or rel.as_posix() in PARALLEL_FILES
        if not parallel:
            item.add_marker(pytest.mark.serial)
