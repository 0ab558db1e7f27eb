"""A real package (issue 14, item 1): a wheel built from this checkout, installed into a fresh virtual
environment outside the tree, used from an empty directory: gen, check, selftest, a configuration, a
Python GCS against a C node, `log info` and `log export` on the log it recorded. Nothing may come from
the checkout: the working directory is empty and the package is imported from the venv.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import zipfile
from pathlib import Path

import pytest
from conftest import REPO, Installed

from uavbus.sim.build import NodeProgramMissing, node_program
from uavbus.sim.process import ProcessGroup

pytestmark = pytest.mark.timeout(900)

HEADER = """\
#ifndef PROBE_H
#define PROBE_H
#include <stdint.h>
typedef struct probeState {
    uint32_t tMs;
    float level[3];
    struct { int16_t x, y; } offset;
} probeState_t;
extern probeState_t probeState;
extern probeState_t probeStateBackup;
#endif
"""

GCS = """\
import sys
import uavbus
from uavbus import Node

assert "site-packages" in uavbus.__file__, uavbus.__file__   # the installed package, not the checkout
port = int(sys.argv[1])
gcs = Node("gen/fsw.catalogue.json", config="table2.json", node="gcs")
gcs.open_port("gcsPortDatalink1", f"udp:bind=127.0.0.1:0,peer=127.0.0.1:{port}")
gcs.record("gcs1.ublog")
admin = gcs.admin("gcs1")
row = admin.add(content="gpsOut", source="rmax1ob1", destination="gcs1", period_ms=50, kind="publication")
gcs.bind("gpsOut")
admin.activate(row)
got = 0
for msg in gcs.messages(timeout=5.0):
    got += 1
    if got == 8:
        break
gcs.stop_recording()
print("received", got, admin.status(row)["status"])
gcs.close()
"""


def run(cmd: list, cwd: Path, timeout: int = 300) -> subprocess.CompletedProcess[str]:
    env = {"PATH": "/usr/bin:/bin", "HOME": str(cwd), "LANG": "C.UTF-8"}  # nothing of this checkout
    return subprocess.run([str(c) for c in cmd], cwd=cwd, capture_output=True, text=True, timeout=timeout, env=env)


def ok(res: subprocess.CompletedProcess[str]) -> str:
    assert res.returncode == 0, f"{' '.join(res.args)}: {res.returncode}\n{res.stdout[-3000:]}\n{res.stderr[-3000:]}"
    return res.stdout


def test_wheel_contents_and_clean_build(installed: Installed) -> None:
    names = installed.names()
    for needed in ("uavbus/py.typed", "uavbus/_data/templates/properties.json", "uavbus/_data/templates/c/Catalogue.c.j2",
                   "uavbus/_data/schemas/config.schema.json", "uavbus/_data/runtime_c/include/ub/ub_node.h",
                   "uavbus/_data/runtime_c/src/core/ub_node.c", "uavbus/_cdefs/ub_node.h", "uavbus_gen/frontend.py",
                   # the console's pages: every asset in the wheel, nothing fetched at run time (docs/web.md)
                   "uavbus/web/server.py", "uavbus/web/static/index.html", "uavbus/web/static/app.js",
                   "uavbus/web/static/style.css"):
        assert needed in names, needed
    assert any(n.startswith("uavbus/_ub.") and n.endswith(".so") for n in names)
    assert not any(n.startswith(("tests/", "runtime_c/", "examples/")) for n in names)
    meta_name = next(n for n in names if n.endswith(".dist-info/METADATA"))
    with zipfile.ZipFile(installed.wheel) as z:
        meta = z.read(meta_name).decode()
    assert "License-Expression: MIT" in meta and "Requires-Dist: cffi" in meta
    assert "Requires-Dist: jsonschema" not in meta.split("Provides-Extra")[0]  # a test dependency only
    assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names)
    noisy = [line for line in installed.build_log.splitlines()
             if "deprecat" in line.lower() or "absent from the `packages`" in line or "SetuptoolsWarning" in line]
    assert noisy == [], noisy


def test_installed_package_works_from_an_empty_directory(installed: Installed, tmp_path: Path) -> None:
    try:
        program = node_program(build=False)
    except NodeProgramMissing as e:
        pytest.fail(f"the C node program is needed for the GCS part: {e}")
    work = tmp_path / "empty"
    work.mkdir()
    uavbus, python = installed.uavbus, installed.python

    # gen, check, selftest on a header of our own (selftest compiles against the packaged C runtime).
    (work / "probe.h").write_text(HEADER)
    assert "IDs unique" in ok(run([uavbus, "check", "probe.h"], work))
    ok(run([uavbus, "gen", "probe.h", "--name", "probecat", "-o", "out"], work))
    assert {p.name for p in (work / "out").iterdir()} >= {"probecat.h", "probecat.c", "probecat.catalogue.json",
                                                         "probecat.py"}
    selftest = ok(run([uavbus, "selftest", "probe.h"], work))
    assert "selftest: C 1 types ok" in selftest and "selftest: Python 1 types ok" in selftest
    assert ok(run([uavbus, "--version"], work)).startswith("uavbus ")

    # A configuration, through the packaged C loader: accepted, and refused with the loader's message.
    shutil.copy(REPO / "examples" / "configs" / "table2.json", work / "table2.json")
    hosts = ok(run([python, "-c", "from uavbus.config import load_config; "
                    "print(load_config('table2.json', node='gcs').hosts)"], work))
    assert hosts.strip() == "('gcs1',)"
    (work / "bad.json").write_text('{"entities": [{"name": "a"}], "hosts": ["b"]}\n')
    bad = run([uavbus, "tables", "--static", "--config", "bad.json", "--node", "x"], work)
    assert bad.returncode == 3 and bad.stderr.strip() == "uavbus tables: bad.json:1: field 'hosts[0]': no entity named 'b' in 'entities'"

    # A Python GCS (installed package) against a C node (the checkout's build), on loopback.
    headers = work / "flightsw"
    shutil.copytree(REPO / "examples" / "flightsw", headers, ignore=shutil.ignore_patterns("*.c"))
    ok(run([uavbus, "gen", *sorted(str(h) for h in headers.glob("*.h")), "-I", headers, "--name", "fsw", "-o", "gen"],
           work))
    (work / "gcs.py").write_text(GCS)
    with ProcessGroup() as group:
        vehicle = group.spawn([program, "--config", work / "table2.json", "--node", "primary", "--port",
                               "onboardPortDatalink1=udp:bind=127.0.0.1:0", "--stats-ms", "0"], "vehicle",
                              ready_timeout=8.0)
        port = vehicle.wait_ready()["ports"]["onboardPortDatalink1"]["local_port"]
        assert ok(run([python, "gcs.py", port], work, timeout=60)).strip() == "received 8 active"

    # The log tools on what the GCS recorded.
    info = ok(run([uavbus, "log", "info", "gcs1.ublog"], work))
    gps = next(line.split() for line in info.splitlines() if line.strip().startswith("gpsOut") and " data " in line)
    assert int(gps[3]) >= 8
    csv = ok(run([uavbus, "log", "export", "gcs1.ublog", "--csv", "--only", "gpsOut"], work)).splitlines()
    assert csv[0].startswith("t_ms,time,link,dir,name,source,dest,seq,kind,dup,") and len(csv) >= 9
    jsonl = [json.loads(x) for x in ok(run([uavbus, "log", "export", "gcs1.ublog", "--jsonl"], work)).splitlines()]
    assert {x["source"] for x in jsonl} == {"rmax1ob1"} and all("latitudeDeg" in x["value"] for x in jsonl)
