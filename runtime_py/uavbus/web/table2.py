"""Table 2 with the console: the paper's HITL processes (uavbus.sim.hitl) and `uavbus web` as gcs1.

Used by tests/web (the browser acceptance) and `make demo`. The C nodes rmax1ob1, rmax1ob2 and fcs20 run as
`uavbus_node` processes; gcs1 is a `uavbus web` process (the console's node) on the GCS's two links. With
`routing=True` every node runs the routing engine and rmax1ob1 has one more link, `onboardPortSpare`, on
UDP toward a port nobody listens on yet: `start_vehicle()` starts a vehicle there mid-run, which the
console learns by routing (it is in no configuration but its own).

    with ConsoleTable2(tmp_path) as t:
        t.url               # the console's address (with its token when it has one)
        t.start_vehicle("rmax2")
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from uavbus.sim.build import REPO
from uavbus.sim.hitl import Hitl, HitlOptions
from uavbus.sim.portalloc import PortAllocator
from uavbus.sim.process import NodeProcess

TABLE2 = REPO / "examples" / "configs" / "table2.json"
POSITIONS = REPO / "examples" / "configs" / "table2_console.json"
ROUTE = "hello=200,update=1000"
SPARE = "onboardPortSpare"


class ConsoleTable2:
    def __init__(self, out: Path, *, program: Path | None = None, routing: bool = True,
                 security: dict[str, Any] | None = None, node_args: dict[str, list[str]] | None = None,
                 http_host: str = "127.0.0.1", token_file: Path | None = None) -> None:
        self.out = Path(out)
        self.out.mkdir(parents=True, exist_ok=True)
        self.routing, self.http_host, self.token_file = routing, http_host, token_file
        doc = json.loads(TABLE2.read_text())
        if routing:
            doc["entities"][0]["links"].append(SPARE)
        if security is not None:
            doc["security"] = security
        self.config = self.out / "table2_console.json"
        self.config.write_text(json.dumps(doc, indent=1))
        self.alloc = PortAllocator()
        self.spare_here, self.spare_there = self.alloc.addr(), self.alloc.addr()
        extra: dict[str, list[str]] = {}
        for name in ("primary", "secondary", "backup"):
            extra[name] = ["--config", str(self.config)] + (["--route", ROUTE] if routing else [])
            extra[name] += list((node_args or {}).get(name, []))
        if routing:
            extra["primary"] += ["--port", f"{SPARE}=udp:bind={self.spare_here},peer={self.spare_there}"]
        # The topology is Table 2's own (its links checked against table2.json); the nodes read this config.
        self.hitl = Hitl(HitlOptions(program=program, start_gcs=False, node_args=extra, stats_ms=0))
        self.web: subprocess.Popen[bytes] | None = None
        self.vehicles: dict[str, NodeProcess] = {}
        self.url = ""
        self.log = self.out / "web.log"

    def __enter__(self) -> ConsoleTable2:
        try:
            self.start()
        except BaseException:
            self.close()
            raise
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def start(self, timeout: float = 15.0) -> None:
        self.hitl.start()
        assert self.hitl.topo is not None
        url_file = self.out / "web.url"
        if url_file.exists():
            url_file.unlink()
        argv = [sys.executable, "-m", "uavbus.cli", "web", "--config", str(self.config), "--node", "gcs",
                "--catalogue", str(self.hitl.catalogue_path), "--positions", str(POSITIONS),
                "--http", f"{self.http_host}:0", "--url-file", str(url_file)]
        if self.routing:
            argv += ["--route", "on"]
        if self.token_file is not None:
            argv += ["--token-file", str(self.token_file)]
        for link, spec in self.hitl.topo.specs("gcs").items():
            argv += ["--port", f"{link}={spec}"]
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        self._log_fh = open(self.log, "wb")
        self.web = subprocess.Popen(argv, stdout=self._log_fh, stderr=subprocess.STDOUT, cwd=REPO, env=env,
                                    start_new_session=True)
        deadline = time.monotonic() + timeout
        while not url_file.exists():
            if self.web.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"uavbus web did not start: {self.log.read_text(errors='replace')[-2000:]}")
            time.sleep(0.05)
        self.url = url_file.read_text().strip()

    def start_vehicle(self, name: str) -> NodeProcess:
        """A vehicle (C node producing gpsOut, imuOut, navFilterState) on rmax1ob1's spare link, mid-run."""
        doc = {"system": "late-vehicle", "entities": [{"name": name, "links": [f"{name}Radio"]}],
               "nodes": {name: [name]}}
        cfg = self.out / f"{name}.json"
        cfg.write_text(json.dumps(doc))
        argv = [str(self.hitl.program), "--config", str(cfg), "--node", name, "--stats-ms", "0", "--route", ROUTE,
                "--produce", name, "--port", f"{name}Radio=udp:bind={self.spare_there},peer={self.spare_here}"]
        proc = self.hitl.group.spawn(argv, name, ready_timeout=8.0, cwd=REPO)
        self.vehicles[name] = proc
        return proc

    def close(self) -> None:
        if self.web is not None:
            if self.web.poll() is None:
                self.web.terminate()
                try:
                    self.web.wait(5.0)
                except subprocess.TimeoutExpired:
                    self.web.kill()
                    self.web.wait(5.0)
            self.web = None
            self._log_fh.close()
        self.hitl.close()
