"""System tests: several processes on 127.0.0.1 (issue 4 acceptance, issue 6 short demo).

They need the C node program (programs/node, on the catalogue uavbus_generate() builds) and the Python
GCS (uavbus.Node). The program is $UAVBUS_NODE, else <$UAVBUS_BUILD_DIR or build/>/programs/node/uavbus_node,
which `make test` builds (test-c) before it runs pytest; pytest itself never runs a build. A missing
program fails the tests (with how to build it) rather than skipping them: a skipped acceptance test
would look green.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from uavbus.sim.build import NodeProgramMissing, node_program
from uavbus.sim.hitl import HitlOptions


@pytest.fixture(scope="session")
def program() -> Path:
    try:
        return node_program(build=False)
    except NodeProgramMissing as e:
        pytest.fail(f"uavbus_node not available: {e}")


@pytest.fixture
def hitl_opts(program: Path) -> HitlOptions:
    return HitlOptions(program=program)


@pytest.fixture
def browser_policy_opts(hitl_opts: HitlOptions, tmp_path: Path) -> HitlOptions:
    """Table 2 with a policy for the browser tests: only rmax1ob2 administers; gcs1 may write fcsSet into
    fcs20 and nothing else; reads are open."""
    cfg = json.loads(Path(hitl_opts.config).read_text())
    cfg["security"] = {"administrators": ["rmax1ob2"], "write": {"fcs20": [{"from": "gcs1", "content": "fcsSet"}]}}
    path = tmp_path / "table2_browser_policy.json"
    path.write_text(json.dumps(cfg))
    hitl_opts.config = path
    return hitl_opts
