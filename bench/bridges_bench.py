"""Latency and throughput the bridges add (make bench, figure 7; docs/bridges.md).

    python bench/bridges_bench.py --build build-bench --out build-bench/raw/bridges.json [--runs 3]

Side by side in one run, each case against the same path without the bridge:
  - MAVLink: an autopilot's ATTITUDE reaching a Python GCS
      direct:   autopilot UDP -> GCS parsing with pymavlink (what a Python GCS does without uavbus)
      bridged:  autopilot UDP -> uavbus_mavbridge -> uavbus UDP -> Python uavbus Node (subscribed, 1 ms)
    latency = GCS receive time - autopilot send time (one process, one clock), at 200 Hz;
    ingest = of N packets blasted back to back, how many the receiving process took in, and at what
    rate (pymavlink in a Python process vs the bridge's C parser, its `messages_in`); both receive
    sockets ask for a 1 MiB buffer (UB_MAVIO_RCVBUF).
  - Zenoh: a directory between two uavbus nodes
      direct:   node A -> UDP -> node B
      bridged:  node A -> UDP -> uavbus bridge zenoh [gwA] -> Zenoh (tcp) -> [gwB] -> UDP -> node B
    latency at 200 Hz as above; throughput = frames delivered to B per second when A sends N back to
    back, 100 per send_many() (A and B in one process, interleaved: their Python cost is in both columns
    alike). Every site UDP port, direct and bridged, says "batch": true and "rcvbuf": 4 MiB (several frames
    per datagram, docs/config-format.md; `--no-site-batch`: one datagram per frame, default buffers); beside it each
    bridge process's CPU time per frame carried (every thread, Zenoh's included: /proc schedstat) and why
    gwA's batches left (idle, full, aged, woken: ub_ports_drain), figures a busy machine changes far less.
    load-proof: Python-level calls per frame in the two bridges (sys.setprofile, calls and C calls, counted
    around the bridges' loop work only), both bridges in this process with real Zenoh sessions on
    tcp/127.0.0.1; a figure a busy machine does not change.
    Zenoh alone: one-way latency of a plain Zenoh publisher and subscriber in two Python processes at
    the same rate, so "added by the bridges" can be read net of Zenoh's own share. Beside it the loops' CPU time per frame
    (thread CPU time, unprofiled pass; Zenoh's own threads not included).
`--only zenoh` runs the Zenoh part alone (`--blast N`, `--lat-n N` for small counts; `--bridge-arg=ARG`
passes an option to both bridge processes, e.g. `--bridge-arg=--batch-idle-us=0`).
The autopilot role is played by this script (pymavlink's encoder, prebuilt packets). Every loop is
bounded by a count and a deadline; only 127.0.0.1 is used. Output: one JSON document.
"""

from __future__ import annotations

import argparse
import json
import os
import select
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "bridges"))  # bridge_testutil: the topology the bridge test drives
os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import common as mavlink2  # noqa: E402

from bridge_testutil import close_all, two_bridges_config  # noqa: E402
from uavbus import Node  # noqa: E402
from uavbus.sim.portalloc import PortAllocator  # noqa: E402
from uavbus.sim.process import NodeProcess  # noqa: E402

LAT_N, LAT_HZ = 600, 200
BLAST_MAV, BLAST_UB = 100_000, 20_000
BRIDGE_ARGS: list[str] = []  # --bridge-arg: options for both Zenoh bridge processes (e.g. --batch-idle-us 0)
SITE_BATCH = True  # every site UDP port (direct and bridged alike) packs frames into datagrams ("batch": true)
SITE_RCVBUF = 4 << 20  # ...and takes a burst into a 4 MiB receive buffer (net.core.rmem_max caps it)
SEND_CHUNK = 100   # frames per send_many() in the throughput bursts (B is polled between chunks)
HOST = "127.0.0.1"


def pct(xs: list[float], q: float) -> float:
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(q * len(xs)))] if xs else float("nan")


def attitude_packets(n: int) -> list[bytes]:
    mav = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
    out = []
    for k in range(n):
        mav.seq = k & 0xFF
        out.append(mav.attitude_encode(k + 1, 0.1, 0.2, 0.3, 0.0, 0.0, 0.0).pack(mav))
    return out


def udp(port: int = 0) -> socket.socket:
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind((HOST, port))
    s.setblocking(False)
    return s


# ---- MAVLink ------------------------------------------------------------------------------------------

def mav_direct_latency(packets: list[bytes]) -> list[float]:
    ap, gcs = udp(), udp()
    parser = mavlink2.MAVLink(None)
    sent: dict[int, float] = {}
    lat: list[float] = []
    t0 = time.perf_counter() + 0.05
    for k in range(LAT_N):
        due = t0 + k / LAT_HZ
        while True:
            left = due - time.perf_counter()
            r, _, _ = select.select([gcs], [], [], max(0.0, left))
            if r:
                data = gcs.recv(2048)
                now = time.perf_counter()
                for m in parser.parse_buffer(data) or []:
                    lat.append(now - sent[m.time_boot_ms])
            if left <= 0:
                break
        sent[k + 1] = time.perf_counter()
        ap.sendto(packets[k], gcs.getsockname())
    deadline = time.perf_counter() + 0.5
    while time.perf_counter() < deadline and len(lat) < LAT_N:
        if select.select([gcs], [], [], 0.05)[0]:
            now = time.perf_counter()
            for m in parser.parse_buffer(gcs.recv(2048)) or []:
                lat.append(now - sent[m.time_boot_ms])
    ap.close()
    gcs.close()
    return lat


SINK = r"""
import os, socket, sys, time, json
os.environ["MAVLINK20"] = "1"
from pymavlink.dialects.v20 import common as m
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM); s.bind(("127.0.0.1", 0))
s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)  # as uavbus_mavbridge's (UB_MAVIO_RCVBUF)
print(s.getsockname()[1], flush=True)
p = m.MAVLink(None); n = 0; first = last = None
s.settimeout(1.0)
while True:
    try:
        data = s.recv(2048)
    except socket.timeout:
        if n:
            break
        continue
    for msg in p.parse_buffer(data) or []:
        n += 1
        last = time.monotonic()
        first = first or last
print(json.dumps({"received": n, "seconds": (last - first) if n > 1 else 0.0}), flush=True)
"""


def blast(sock: socket.socket, packets: list[bytes], dest: tuple[str, int]) -> float:
    t = time.perf_counter()
    for p in packets:
        while True:
            try:
                sock.sendto(p, dest)
                break
            except BlockingIOError:
                select.select([], [sock], [], 0.01)
    return time.perf_counter() - t


def readline_by(proc: subprocess.Popen, seconds: float, what: str) -> str:
    """One line from a child within a deadline: a child that hangs or exits is a clear failure, never a hang
    (issue #28; bench/run.sh reports the sample as failed and goes on)."""
    r, _, _ = select.select([proc.stdout], [], [], seconds)
    if not r:
        raise SystemExit(f"bridges_bench: {what}: no answer within {seconds:g} s")
    line = proc.stdout.readline()  # unbuffered pipe: select saw these bytes, nothing hides in a buffer
    if not line:
        raise SystemExit(f"bridges_bench: {what}: the child exited (status {proc.wait()}) without an answer")
    return line.decode()


def mav_direct_ingest(packets: list[bytes]) -> dict:
    sink = subprocess.Popen([sys.executable, "-c", SINK], stdout=subprocess.PIPE, bufsize=0)
    try:
        port = int(readline_by(sink, 60, "the MAVLink sink's port"))
        ap = udp()
        secs = blast(ap, packets, (HOST, port))
        out = json.loads(readline_by(sink, 120, "the MAVLink sink's count"))
        ap.close()
    finally:
        sink.kill()
        sink.wait()
    return {"sent": len(packets), "send_s": secs, "received": out["received"],
            "rate": (out["received"] - 1) / out["seconds"] if out["seconds"] else 0.0}


class MavBridge:
    """uavbus_mavbridge + a Python GCS node subscribed to ATTITUDE_30 at 1 ms, the autopilot's socket here."""

    def __init__(self, program: str, catalogue: str, tmp: Path) -> None:
        ports = PortAllocator()
        self.ap = udp(ports.port())
        b, g, m = ports.port(), ports.port(), ports.port()
        cfg = {"system": "mavbench",
               "entities": [{"name": "mavbridge", "links": ["toGcs"], "linktoentity": {"gcs1": [0]}},
                            {"name": "gcs1", "links": ["toBridge"], "linktoentity": {"mavbridge": [0]}}],
               "nodes": {"bridge": ["mavbridge"], "gcs": ["gcs1"]},
               "ports": {"toGcs": {"transport": "udp", "bind": f"{HOST}:{b}", "peer": f"{HOST}:{g}"},
                         "toBridge": {"transport": "udp", "bind": f"{HOST}:{g}", "peer": f"{HOST}:{b}"}}}
        path = tmp / "mavbench.json"
        path.write_text(json.dumps(cfg))
        self.mav_port = m
        self.proc = NodeProcess([program, "--config", str(path), "--node", "bridge", "--stats-ms", "0",
                                 "--mavlink", f"udp:bind={HOST}:{m},peer={HOST}:{self.ap.getsockname()[1]}"],
                                "mavbridge").start()
        self.proc.wait_ready(10)
        self.gcs = Node(catalogue, config=path, node="gcs")
        self.gcs.open_ports_from_config()
        self.got: list[tuple[float, int]] = []
        self.gcs.on_data(lambda msg: self.got.append((time.perf_counter(), msg.value["time_boot_ms"]))
                         if msg.name == "ATTITUDE_30" else None)
        hb = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
        self.ap.sendto(hb.heartbeat_encode(2, 3, 0, 0, 4, 3).pack(hb), (HOST, m))
        self.proc.wait_event(lambda e: e.get("event") == "autopilot", 5, what="autopilot connected")
        self.gcs.subscribe("gcs1", "ATTITUDE_30", source="mavbridge", period_ms=1)
        warm = attitude_packets(1)
        deadline = time.monotonic() + 5
        while not self.got and time.monotonic() < deadline:
            self.ap.sendto(warm[0], (HOST, m))
            self.gcs.poll(0.02)
        if not self.got:
            raise RuntimeError("mavbridge bench: no ATTITUDE reached the GCS")

    def latency(self, packets: list[bytes]) -> list[float]:
        self.got.clear()
        sent: dict[int, float] = {}
        t0 = time.perf_counter() + 0.05
        for k in range(LAT_N):
            due = t0 + k / LAT_HZ
            while time.perf_counter() < due:
                self.gcs.poll(max(0.0, min(0.002, due - time.perf_counter())))
            sent[k + 1] = time.perf_counter()
            self.ap.sendto(packets[k], (HOST, self.mav_port))
        deadline = time.perf_counter() + 0.5
        while time.perf_counter() < deadline:
            self.gcs.poll(0.005)
        return [t - sent[b] for t, b in self.got if b in sent]

    def ingest(self, packets: list[bytes]) -> dict:
        before = self.proc.request_stats()["mavlink"]["messages_in"]
        secs = blast(self.ap, packets, (HOST, self.mav_port))
        t_end = time.perf_counter() + 3
        last, stable_since = -1, time.perf_counter()
        while time.perf_counter() < t_end:
            n = self.proc.request_stats()["mavlink"]["messages_in"] - before
            if n != last:
                last, stable_since = n, time.perf_counter()
            elif time.perf_counter() - stable_since > 0.3:
                break
            self.gcs.poll(0.05)
        return {"sent": len(packets), "send_s": secs, "received": last, "rate": last / secs if secs else 0.0}

    def close(self) -> None:
        self.gcs.close()
        self.proc.stop()
        self.ap.close()


# ---- Zenoh ----------------------------------------------------------------------------------------------

def zenoh_config(tmp: Path, bridged: bool) -> tuple[Path, int]:
    ports = PortAllocator()
    a = {k: ports.port() for k in ("A", "B", "gwA", "gwB")}

    def udp_port(bind: str, peer: str) -> dict:
        port = {"transport": "udp", "bind": f"{HOST}:{a[bind]}", "peer": f"{HOST}:{a[peer]}"}
        return {**port, "batch": True, "rcvbuf": SITE_RCVBUF} if SITE_BATCH else port

    if not bridged:
        cfg = {"system": "zbench",
               "entities": [{"name": "srcA", "links": ["l"], "linktoentity": {"dstB": [0]}},
                            {"name": "dstB", "links": ["l"], "linktoentity": {"srcA": [0]}}],
               "nodes": {"A": ["srcA"], "B": ["dstB"]},
               "ports": {"srcA:l": udp_port("A", "B"), "dstB:l": udp_port("B", "A")}}
    else:
        # the one topology the Zenoh bridge test drives (tests/bridges/bridge_testutil.py), with these ports
        cfg = two_bridges_config("zbench", a, HOST, batch=SITE_BATCH,
                                 rcvbuf=SITE_RCVBUF if SITE_BATCH else 0)
    path = tmp / ("zbridged.json" if bridged else "zdirect.json")
    path.write_text(json.dumps(cfg))
    return path, ports.port()


class UbPair:
    """Node A sends gpsOut to node B (solutionCount = index), directly or through two Zenoh bridges."""

    def __init__(self, catalogue: str, tmp: Path, bridged: bool) -> None:
        self.cfg, zport = zenoh_config(tmp, bridged)
        self.procs: list[NodeProcess] = []
        if bridged:
            for name, zargs in (("gwA", ["--listen", f"tcp/{HOST}:{zport}"]), ("gwB", ["--connect", f"tcp/{HOST}:{zport}"])):
                p = NodeProcess([sys.executable, "-m", "uavbus.cli", "bridge", "zenoh", "--config", str(self.cfg),
                                 "--node", name, "--catalogue", catalogue, *zargs, *BRIDGE_ARGS], name).start()
                p.wait_ready(15)
                self.procs.append(p)
        self.a = Node(catalogue, config=self.cfg, node="A")
        self.b = Node(catalogue, config=self.cfg, node="B")
        for n in (self.a, self.b):
            n.open_ports_from_config()
        self.pub = self.a.publisher("srcA", "gpsOut", to="dstB")
        self.b.bind("gpsOut")
        self.got: list[tuple[float, int]] = []
        # The index from the delivered image (msg.value), not the bound storage: one poll may deliver many.
        self.b.on_data(lambda m: self.got.append((time.perf_counter(), m.value["solutionCount"])))
        deadline = time.monotonic() + 10
        while not self.got and time.monotonic() < deadline:  # Zenoh routes and sessions up
            self.pub.directory.solutionCount = 0
            self.pub.send()
            self.b.poll(0.02)
        if not self.got:
            raise RuntimeError("zenoh bench: nothing crossed")

    def latency(self) -> list[float]:
        self.got.clear()
        sent: dict[int, float] = {}
        t0 = time.perf_counter() + 0.05
        for k in range(1, LAT_N + 1):
            due = t0 + k / LAT_HZ
            while time.perf_counter() < due:
                self.b.poll(max(0.0, min(0.002, due - time.perf_counter())))
            self.pub.directory.solutionCount = k
            sent[k] = time.perf_counter()
            self.pub.send()
        deadline = time.perf_counter() + 0.5
        while time.perf_counter() < deadline:
            self.b.poll(0.005)
        return [t - sent[k] for t, k in self.got if k in sent]

    def throughput(self) -> dict:
        self.got.clear()
        before = [p.request_stats()["zenoh"] for p in self.procs]  # flush_* absent before ub_ports_drain: 0
        cpu0 = [proc_cpu_s(p.pid) for p in self.procs]
        t0 = time.perf_counter()
        for k in range(1, BLAST_UB + 1, SEND_CHUNK):  # A's burst: frames k.. in one send_many() (C), B polled
            self.pub.send_many(range(k, min(k + SEND_CHUNK, BLAST_UB + 1)), field="solutionCount")
            self.b.poll(0)
        deadline = time.perf_counter() + 3
        last, since = -1, time.perf_counter()
        while time.perf_counter() < deadline:
            self.b.poll(0.01)
            if len(self.got) != last:
                last, since = len(self.got), time.perf_counter()
            elif time.perf_counter() - since > 0.3:
                break
        got = {k for _, k in self.got}
        t_last = max((t for t, _ in self.got), default=t0)
        out = {"sent": BLAST_UB, "received": len(got), "rate": len(got) / (t_last - t0) if t_last > t0 else 0.0}
        if self.procs:  # where frames went: into gwA, over Zenoh, out of gwB (the rest: UDP socket buffers)
            a, b = (p.request_stats() for p in self.procs)
            out.update(gw_in=a["links"]["site"]["frames_in"], zenoh_published=a["zenoh"]["published"],
                       zenoh_received=b["zenoh"]["received"], gw_out=b["links"]["site"]["frames_out"],
                       zenoh_samples=b["zenoh"]["samples_in"])
            # CPU time of each bridge process (all its threads, Zenoh's included) per frame it carried: a
            # figure a busy machine changes far less than the rates (getrusage's clock, from /proc)
            cpu = [proc_cpu_s(p.pid) - c for p, c in zip(self.procs, cpu0)]
            carried = max(1, b["zenoh"]["received"])
            out.update(gw_cpu_us_per_frame=[c / carried * 1e6 for c in cpu])
            # why gwA's batches left (ub_drain_end_t) and how many samples carried the burst
            out.update(gwA_ends={k: a["zenoh"].get(k, 0) - before[0].get(k, 0)
                                 for k in ("flush_idle", "flush_full", "flush_aged", "flush_woken", "samples_out", "published")})
        return out

    def close(self) -> None:
        self.a.close()
        self.b.close()
        for p in self.procs:
            p.stop()


ZENOH_SUB = r"""
import json, sys, threading, time, zenoh
c = zenoh.Config()
c.insert_json5("mode", '"peer"')
c.insert_json5("listen/endpoints", json.dumps([sys.argv[1]]))
c.insert_json5("scouting/multicast/enabled", "false")
s = zenoh.open(c)
lat, done = [], threading.Event()
def on(sample):
    t = time.perf_counter_ns()  # CLOCK_MONOTONIC: one clock for both processes
    sent = int(sample.payload.to_bytes())
    if sent == 0:
        done.set()
    else:
        lat.append((t - sent) / 1e9)
sub = s.declare_subscriber("zbench/alone", on)
print("ready", flush=True)
done.wait(120)
print(json.dumps(lat), flush=True)
sub.undeclare()
s.close()
"""


def zenoh_alone_latency() -> list[float]:
    """One-way latency of plain Zenoh between two Python processes (express, tcp/127.0.0.1), at the
    latency test's rate: the part of the bridged latency that is Zenoh's, not the bridges'."""
    import zenoh

    from uavbus.bridges.zenoh_bridge import zenoh_config as zconf

    endpoint = f"tcp/{HOST}:{PortAllocator().port()}"
    sub = subprocess.Popen([sys.executable, "-c", ZENOH_SUB, endpoint], stdout=subprocess.PIPE, bufsize=0)
    try:
        readline_by(sub, 60, "the Zenoh subscriber's start")
        session = zenoh.open(zconf("peer", [], [endpoint]))
        try:
            pub = session.declare_publisher("zbench/alone", express=True,
                                            congestion_control=zenoh.CongestionControl.BLOCK)
            time.sleep(0.5)  # the sessions meet and the subscription propagates
            t0 = time.perf_counter() + 0.05
            for k in range(LAT_N):
                while time.perf_counter() < t0 + k / LAT_HZ:
                    time.sleep(0.0005)
                pub.put(str(time.perf_counter_ns()))
            time.sleep(0.2)
            pub.put("0")
            lat = json.loads(readline_by(sub, 60, "the Zenoh subscriber's latencies"))
            pub.undeclare()
        finally:
            session.close()
    finally:
        sub.kill()
        sub.wait()
    return lat


def zenoh_calls_per_frame(catalogue: str, tmp: Path, n: int = 2000) -> dict:
    """Python-level calls (function calls + C calls) the two bridges make per frame of a burst (module doc)."""
    import zenoh

    from uavbus.bridges.zenoh_bridge import ZenohBridge, zenoh_config as zconf

    cfg, zport = zenoh_config(tmp, True)
    endpoint = f"tcp/{HOST}:{zport}"
    closers: list = []
    calls = [0]

    def count(frame, event, arg) -> None:
        if event in ("call", "c_call"):
            calls[0] += 1

    try:
        nodes = {}
        for name in ("A", "B", "gwA", "gwB"):
            nodes[name] = Node(catalogue, config=cfg, node=name)
            closers.append(nodes[name].close)
            nodes[name].open_ports_from_config()
        sa = zenoh.open(zconf("peer", [endpoint], []))
        closers.append(sa.close)
        sb = zenoh.open(zconf("peer", [], [endpoint]))
        closers.append(sb.close)
        bridges = {"gwA": ZenohBridge(nodes["gwA"], "zenoh", sa, "uavbus/zbench"),
                   "gwB": ZenohBridge(nodes["gwB"], "zenoh", sb, "uavbus/zbench")}
        closers += [b.close for b in bridges.values()]
        pub = nodes["A"].publisher("srcA", "gpsOut", to="dstB")
        nodes["B"].bind("gpsOut")
        got = [0]
        nodes["B"].on_data(lambda m: got.__setitem__(0, got[0] + 1))

        cpu = [0.0]
        turns = [0]

        def turn(profiled: bool) -> None:
            turns[0] += 1
            if profiled:
                sys.setprofile(count)
            t = time.thread_time()
            for name, bridge in bridges.items():
                if hasattr(bridge, "turn"):
                    bridge.turn()
                else:  # a bridge before ub_ports_drain (BENCH_BASE comparisons): its pump/service/pump
                    now = nodes[name].now()
                    bridge.pump(now)
                    nodes[name].service(now, dispatch=False)
                    bridge.pump(now)
            cpu[0] += time.thread_time() - t
            if profiled:
                sys.setprofile(None)
            nodes["B"].poll(0)

        deadline = time.monotonic() + 10
        while not got[0] and time.monotonic() < deadline:
            pub.send()
            turn(False)
            time.sleep(0.005)
        if not got[0]:
            raise RuntimeError("zenoh calls bench: nothing crossed")
        for _ in range(50):
            turn(False)
            time.sleep(0.001)
        def burst(profiled: bool) -> dict:
            """n frames from A in turns of 25 (one send_many(), within the UDP sockets' buffers), until all crossed gwB (what
            B's socket then drops on a busy machine is not the bridges' work)."""
            got[0] = calls[0] = turns[0] = 0
            cpu[0] = 0.0
            base = bridges["gwB"].counters["received"]
            base_samples = bridges["gwB"].counters.get("samples_in", 0)
            t0 = time.perf_counter()
            for k in range(n // 25):
                pub.send_many(range(25 * k, 25 * k + 25), field="solutionCount")
                turn(profiled)
            deadline = time.monotonic() + 10
            while bridges["gwB"].counters["received"] - base < n and time.monotonic() < deadline:
                turn(profiled)
                time.sleep(0.0005)
            crossed = bridges["gwB"].counters["received"] - base
            wall = time.perf_counter() - t0
            for _ in range(5):
                turn(False)
            return {"crossed": crossed, "samples": bridges["gwB"].counters.get("samples_in", 0) - base_samples,
                    "turns": turns[0],
                    "calls": calls[0], "cpu_s": cpu[0], "wall_s": wall}

        counted, timed = burst(True), burst(False)
        return {"frames": n, "crossed": counted["crossed"], "samples": counted["samples"], "calls": counted["calls"],
                "turns": counted["turns"],
                "calls_per_frame": counted["calls"] / counted["crossed"] if counted["crossed"] else float("nan"),
                "loop_cpu_us_per_frame": timed["cpu_s"] / timed["crossed"] * 1e6 if timed["crossed"] else float("nan"),
                "in_process_rate": timed["crossed"] / timed["wall_s"] if timed["wall_s"] else 0.0}
    finally:
        close_all(closers)


def proc_cpu_s(pid: int | None) -> float:
    """CPU seconds process `pid` has run so far, every thread (Zenoh's included): the sum of
    /proc/PID/task/*/schedstat's first field (ns; /proc/PID/stat's utime+stime tick at 10 ms, too coarse
    for a burst of a few thousand frames). Threads that already ended are not in it: the bridges' live for
    the process."""
    if pid is None:
        return 0.0
    total = 0
    for task in Path(f"/proc/{pid}/task").iterdir():
        try:
            total += int((task / "schedstat").read_text().split()[0])
        except (OSError, IndexError, ValueError):
            pass  # a thread that ended meanwhile
    return total / 1e9


def lat_summary(xs: list[float]) -> dict:
    return {"n": len(xs), "p50_us": pct(xs, 0.5) * 1e6, "p99_us": pct(xs, 0.99) * 1e6}


def main() -> int:
    global LAT_N, BLAST_UB, BRIDGE_ARGS, SITE_BATCH
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--only", choices=("zenoh",), help="run only the Zenoh part (figure 7's last tables)")
    ap.add_argument("--blast", type=int, help=f"frames per uavbus throughput sample (default {BLAST_UB:,})")
    ap.add_argument("--lat-n", type=int, help=f"messages per latency sample (default {LAT_N})")
    ap.add_argument("--bridge-arg", action="append", default=[], metavar="ARG",
                    help="an option for both Zenoh bridge processes, e.g. --bridge-arg=--batch-idle-us=0")
    ap.add_argument("--no-site-batch", action="store_true",
                    help="one datagram per frame and the default receive buffer on the site UDP links (as before "
                         "\"batch\" and \"rcvbuf\"; for comparisons)")
    args = ap.parse_args()
    LAT_N, BLAST_UB, BRIDGE_ARGS = args.lat_n or LAT_N, args.blast or BLAST_UB, args.bridge_arg
    SITE_BATCH = not args.no_site_batch
    build = Path(args.build)
    flightsw = str(build / "examples" / "uavbus" / "flightsw" / "flightsw.catalogue.json")
    res: dict[str, list] = {k: [] for k in ("mav_direct_lat", "mav_bridge_lat", "mav_direct_ingest", "mav_bridge_ingest",
                                           "ub_direct_lat", "ub_zenoh_lat", "ub_direct_tput", "ub_zenoh_tput",
                                           "zenoh_alone_lat", "zenoh_calls")}
    if not args.only:
        info = json.loads((build / "mavbridge.json").read_text())
        packets = attitude_packets(max(LAT_N, BLAST_MAV))
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        for run in range(args.runs):
            if not args.only:
                res["mav_direct_lat"].append(lat_summary(mav_direct_latency(packets)))
                res["mav_direct_ingest"].append(mav_direct_ingest(packets[:BLAST_MAV]))
                br = MavBridge(info["program"], info["catalogue"], tmp)
                try:
                    res["mav_bridge_lat"].append(lat_summary(br.latency(packets)))
                    res["mav_bridge_ingest"].append(br.ingest(packets[:BLAST_MAV]))
                finally:
                    br.close()
            for bridged, lat_key, tput_key in ((False, "ub_direct_lat", "ub_direct_tput"),
                                               (True, "ub_zenoh_lat", "ub_zenoh_tput")):
                pair = UbPair(flightsw, tmp, bridged)
                try:
                    res[lat_key].append(lat_summary(pair.latency()))
                    res[tput_key].append(pair.throughput())
                finally:
                    pair.close()
            res["zenoh_alone_lat"].append(lat_summary(zenoh_alone_latency()))
            res["zenoh_calls"].append(zenoh_calls_per_frame(flightsw, tmp))
            print(f"bridges bench: run {run + 1}/{args.runs} done", file=sys.stderr)
    res["meta"] = [{"lat_n": LAT_N, "lat_hz": LAT_HZ, "blast_mavlink": BLAST_MAV, "blast_uavbus": BLAST_UB,
                    "runs": args.runs, "only": args.only, "affinity": sorted(os.sched_getaffinity(0)),
                    "site_batch": SITE_BATCH, "site_rcvbuf": SITE_RCVBUF if SITE_BATCH else 0, "send_chunk": SEND_CHUNK,
                    "bridge_args": BRIDGE_ARGS,
                    "loadavg": os.getloadavg()}]
    Path(args.out).write_text(json.dumps(res, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
