#!/usr/bin/env python3
"""Figure 10 of bench/results.md: a one-shot remote read (issue 16) over 1 and 2 hops, round-trip time.

Table 2 on 127.0.0.1 (uavbus.sim.hitl): the Python GCS (gcs1) and three `uavbus_node` processes;
gcs1 -> rmax1ob1 over UDP (and the pty serial link: mask 0x00000011, both carry every frame),
rmax1ob1 -> fcs20 over a pty serial link. Each sample is one `Remote.get("airData")`: an INSPECT READ and its
INSPECT_VALUE, the C requester polled by the Python node, timed with perf_counter around the call. The floor
is a Python UDP echo on loopback (the same socket path without the router). Reads alternate between the
targets so load drifts hit both alike. Prints one line per series for bench/inspect_tables.py.

    .venv/bin/python bench/inspect_bench.py [--program build/programs/node/uavbus_node] [--n 300]
"""

from __future__ import annotations

import argparse
import socket
import statistics
import threading
import time
from pathlib import Path

from uavbus._bindings import ub_inspect
from uavbus.sim.hitl import Hitl, HitlOptions

CONTENT = "airData"


def pct(xs: list[float], q: float) -> float:
    s = sorted(xs)
    return s[min(len(s) - 1, int(q * len(s)))]


def line(kind: str, xs: list[float], **kw: object) -> str:
    extra = " ".join(f"{k}={v}" for k, v in kw.items())
    return (f"{kind} {extra} n={len(xs)} p50_ms={statistics.median(xs):.3f} p99_ms={pct(xs, 0.99):.3f} "
            f"min_ms={min(xs):.3f} max_ms={max(xs):.3f}")


def udp_echo_floor(n: int) -> list[float]:
    srv = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    srv.bind(("127.0.0.1", 0))
    stop = threading.Event()

    def echo() -> None:
        srv.settimeout(0.2)
        while not stop.is_set():
            try:
                data, addr = srv.recvfrom(2048)
            except socket.timeout:
                continue
            srv.sendto(data, addr)

    th = threading.Thread(target=echo, daemon=True)
    th.start()
    cli = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    cli.settimeout(1.0)
    payload = bytes(64 + 12 + 40)  # a frame header, the INSPECT_VALUE head and a small directory
    out = []
    try:
        for _ in range(n):
            t = time.perf_counter()
            cli.sendto(payload, srv.getsockname())
            cli.recvfrom(2048)
            out.append((time.perf_counter() - t) * 1000.0)
    finally:
        stop.set()
        th.join()
        cli.close()
        srv.close()
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--program", type=Path, default=None)
    ap.add_argument("--n", type=int, default=300)
    args = ap.parse_args()
    series: dict[str, list[float]] = {"rmax1ob1": [], "fcs20": []}
    with Hitl(HitlOptions(program=args.program)) as h:
        assert h.topo is not None
        hops = {"rmax1ob1": h.topo.hops("gcs", "primary"), "fcs20": h.topo.hops("gcs", "backup")}
        remotes = {name: h.gcs.remote(name) for name in series}
        for r in remotes.values():
            r.get(CONTENT)  # warm up: routes, caches
        size = len(remotes["fcs20"].read_raw(CONTENT))
        for _ in range(args.n):
            for name, r in remotes.items():
                t = time.perf_counter()
                r.get(CONTENT)
                series[name].append((time.perf_counter() - t) * 1000.0)
        k = ub_inspect.ub_inspect_counters(h.gcs._inspector())
        retries = k["sent"] - k["done"] - k["failed"]  # every request was answered: the rest are resends
    for name, xs in series.items():
        print(line("inspect_read", xs, target=name, hops=hops[name], bytes=size))
    print(line("udp_echo", udp_echo_floor(args.n), target="python-loopback", hops=0, bytes=116))
    print(f"inspect_note requests={k['done'] + k['failed']} retries={retries} failed={k['failed']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
