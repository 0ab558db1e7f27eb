"""Examples that run as written (issue 14, item 4): every shell and Python block of README.md,
docs/python.md and docs/tutorial.md, verbatim, in order, against the `make demo` build.

tests/docs/run_doc_blocks.py does the running (one bash and one Python session per document, background
jobs stopped at the end); it runs here inside a private network namespace (`unshare -rn`, as bench/run.sh
does), so the fixed ports a reader types (127.0.0.1:5001) can collide with nothing else on the machine.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from uavbus.sim.build import NodeProgramMissing, node_program

REPO = Path(__file__).resolve().parents[2]
DOCS = ["README.md", "docs/python.md", "docs/tutorial.md"]


@pytest.mark.timeout(900)
def test_every_block_runs_as_written() -> None:
    try:
        node_program(build=False)  # the documents run against the build `make demo` / `make test` leave
    except NodeProgramMissing as e:
        pytest.fail(f"the documents need the demo build: {e}")
    unshare = shutil.which("unshare")
    assert unshare, "unshare (util-linux) is needed to give the documents' fixed ports a private network"
    r = subprocess.run([unshare, "-rn", sys.executable, str(REPO / "tests/docs/run_doc_blocks.py"), "--lo-up",
                        *[str(REPO / d) for d in DOCS]], capture_output=True, text=True, timeout=880, cwd=REPO)
    assert r.returncode == 0, (r.stdout[-12000:] + r.stderr[-3000:])
    for doc in DOCS:
        assert f"ok     {REPO / doc}" in r.stdout, r.stdout[-3000:]
    # Every runnable block ran: a document cannot pass by having nothing to run.
    ran = r.stdout.count(" block ") - r.stdout.count("block skipped")
    assert ran >= 12, r.stdout


def test_block_parser_finds_and_skips() -> None:
    sys.path.insert(0, str(REPO / "tests" / "docs"))
    import run_doc_blocks as rdb

    readme = rdb.blocks_of(REPO / "README.md")
    assert readme[0].skip and "make demo" in readme[0].text
    assert [b.lang for b in readme if b.skip is None][:3] == ["sh", "sh", "python"]
