"""Bridge tests (docs/bridges.md): real peers from PyPI (pymavlink as an autopilot, eclipse-zenoh
sessions, the mcap reader), real processes, 127.0.0.1 only, ports from the project's allocator.

The MAVLink bridge program and its catalogue come from the CMake build `make test` runs first
(<$UAVBUS_BUILD_DIR or build/>/mavbridge.json names them); pytest never builds. A missing build fails
the tests with how to make it, never skips them: a skipped acceptance test would look green.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from uavbus.sim.build import REPO, NodeProgramMissing, node_program
from uavbus.sim.process import ProcessGroup

def build_dir() -> Path:
    return Path(os.environ.get("UAVBUS_BUILD_DIR") or REPO / "build")


@pytest.fixture(scope="session")
def mavbridge() -> dict[str, str]:
    """{"program": uavbus_mavbridge, "catalogue": mavcat.catalogue.json, "dialect": ...}."""
    info = build_dir() / "mavbridge.json"
    if not info.exists():
        pytest.fail(f"{info} is missing: the MAVLink bridge is not built. Run `make test-c` (or "
                    f"`cmake --build {build_dir()} --target uavbus_mavbridge`) first; it needs pymavlink "
                    "in the build's Python (make setup)")
    data = json.loads(info.read_text())
    for key in ("program", "catalogue"):
        if not Path(data[key]).exists():
            pytest.fail(f"{data[key]} (from {info}) does not exist: build target uavbus_mavbridge")
    return data


@pytest.fixture(scope="session")
def uavbus_node() -> Path:
    try:
        return node_program(build=False)
    except NodeProgramMissing as e:
        pytest.fail(f"uavbus_node not available: {e}")


@pytest.fixture
def group():
    with ProcessGroup() as g:
        yield g

