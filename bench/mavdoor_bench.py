"""The MAVLink front door's cost (issue 26): a ground station talking to an autopilot through the door over two
uavbus hops, beside the same ground station talking to it directly and through MAVProxy as a router, in one run.

    python bench/mavdoor_bench.py --build build-bench --out build-bench/raw/mavdoor.json [--runs 3]

Paths (the same pymavlink autopilot, tests/bridges/mav_autopilot.py, system 3, and the same pymavlink GCS):
  direct    GCS udpout -> autopilot
  mavproxy  GCS udpout -> mavproxy.py --master udpout:AP --out udpin:P (PyPI MAVProxy, a router) -> autopilot
  door      GCS udpout -> uavbus_mavbridge [door] --gcs udp -> uavbus_node [relay] -> uavbus_mavbridge [mb3] -> autopilot

Figures per path and run:
  - round trip: COMMAND_LONG (arm) -> COMMAND_ACK, one at a time after a warm-up (median, p90, ms);
  - throughput: the GCS asks ATTITUDE at 1 kHz (SET_MESSAGE_INTERVAL; through the door it becomes a flow and the
    vehicle's bridge asks the autopilot); ATTITUDE received per second over 3 s, and the share of what the
    autopilot sent (its own count) that arrived.
The autopilot is a Python process, so its own pace bounds the throughput on every path alike: compare the paths'
ratios, not the absolute rates. mavp2p is not on PyPI or Debian: not compared. Each child runs under the caller's
deadline (bench/tools/sample.sh); everything runs on 127.0.0.1.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "bridges"))
os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402

from bridge_testutil import autopilot_argv  # noqa: E402
from test_mavlink_door import write_config  # noqa: E402
from uavbus.sim.portalloc import PortAllocator  # noqa: E402
from uavbus.sim.process import ProcessGroup  # noqa: E402

M = mavutil.mavlink
SYSID = 3


def pct(xs: list[float], q: float) -> float:
    s = sorted(xs)
    return s[min(len(s) - 1, int(q * (len(s) - 1) + 0.5))] if s else float("nan")


class Gcs:
    def __init__(self, port: int) -> None:
        self.conn = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=250, source_component=190,
                                               dialect="common")
        self.next_hb = 0.0

    def pump(self, on_msg=None) -> None:
        now = time.monotonic()
        if now >= self.next_hb:
            self.conn.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, M.MAV_STATE_ACTIVE)
            self.next_hb = now + 0.5
        while (m := self.conn.recv_msg()) is not None:
            if on_msg is not None:
                on_msg(m)

    def wait(self, pred, seconds: float, on_msg=None) -> bool:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.pump(on_msg)
            if pred():
                return True
            time.sleep(0.0005)
        return False


def measure(g: Gcs, autopilot, rtts: int) -> dict:
    seen = {"hb": 0, "att": 0}
    acks: list[int] = []

    def on(m) -> None:
        if m.get_srcSystem() != SYSID:
            return
        t = m.get_type()
        if t == "HEARTBEAT":
            seen["hb"] += 1
        elif t == "ATTITUDE":
            seen["att"] += 1
        elif t == "COMMAND_ACK" and m.command == M.MAV_CMD_COMPONENT_ARM_DISARM:
            acks.append(m.result)

    if not g.wait(lambda: seen["hb"] >= 1 and seen["att"] >= 10, 30, on):
        raise SystemExit("mavdoor_bench: the vehicle never appeared at the GCS")
    # Round trips, one at a time (the first few warm up the routes).
    samples: list[float] = []
    for k in range(rtts + 10):
        n = len(acks)
        t0 = time.perf_counter()
        g.conn.mav.command_long_send(SYSID, 1, M.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
        if not g.wait(lambda: len(acks) > n, 2.0, on):
            continue  # lost: counted below
        if k >= 10:
            samples.append((time.perf_counter() - t0) * 1000.0)
    # Throughput at 1 kHz asked.
    g.conn.mav.command_long_send(SYSID, 1, M.MAV_CMD_SET_MESSAGE_INTERVAL, 0, M.MAVLINK_MSG_ID_ATTITUDE, 1000, 0, 0, 0, 0, 0)
    g.wait(lambda: False, 1.0, on)
    mark = autopilot.mark()
    autopilot.send("stats")
    before = autopilot.wait_event("stats", 5, since=mark)["sent"].get("ATTITUDE", 0)
    seen["att"] = 0
    t0 = time.monotonic()
    g.wait(lambda: False, 3.0, on)
    dt = time.monotonic() - t0
    mark = autopilot.mark()
    autopilot.send("stats")
    after = autopilot.wait_event("stats", 5, since=mark)["sent"].get("ATTITUDE", 0)
    sent = max(1, after - before)
    return {"rtt_ms": samples, "rtt_lost": rtts - len(samples), "rtt_median_ms": pct(samples, 0.5),
            "rtt_p90_ms": pct(samples, 0.9), "attitude_per_s": seen["att"] / dt, "autopilot_sent_per_s": sent / dt,
            "delivered": min(1.0, seen["att"] / sent)}


def run_direct(tmp: Path, rtts: int) -> dict:
    ports = PortAllocator()
    with ProcessGroup() as group:
        ap_port = ports.port()
        ap = group.spawn(autopilot_argv(ap_port, duration=120, sysid=SYSID), "autopilot", ready_timeout=10)
        g = Gcs(ap_port)
        try:
            return measure(g, ap, rtts)
        finally:
            g.conn.close()


def run_mavproxy(tmp: Path, rtts: int) -> dict:
    ports = PortAllocator()
    exe = Path(sys.executable).with_name("mavproxy.py")
    with ProcessGroup() as group:
        ap_port, out_port = ports.port(), ports.port()
        ap = group.spawn(autopilot_argv(ap_port, duration=120, sysid=SYSID), "autopilot", ready_timeout=10)
        state = tmp / "mavproxy"
        state.mkdir(exist_ok=True)
        proc = subprocess.Popen([sys.executable, str(exe), f"--master=udpout:127.0.0.1:{ap_port}",
                                 f"--out=udpin:127.0.0.1:{out_port}", "--daemon", "--non-interactive",
                                 "--source-system=254", f"--state-basedir={state}", f"--logfile={state / 'm.tlog'}"],
                                stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=state)
        g = Gcs(out_port)
        try:
            return measure(g, ap, rtts)
        finally:
            g.conn.close()
            proc.kill()
            proc.wait(5)


def run_door(tmp: Path, rtts: int, build: Path) -> dict:
    info = json.loads((build / "mavbridge.json").read_text())
    node = build / "programs" / "node" / "uavbus_node"
    ports = PortAllocator()
    cfg = tmp / "door.json"
    write_config(cfg, ports)
    with ProcessGroup() as group:
        ap_port, bind, gcs_port = ports.port(), ports.port(), ports.port()
        ap = group.spawn(autopilot_argv(ap_port, duration=120, sysid=SYSID), "autopilot", ready_timeout=10)
        prog = info["program"]
        common = ["--config", str(cfg), "--stats-ms", "0"]
        group.spawn([prog, *common, "--node", "mb3", "--target", f"{SYSID}/1", "--mavlink",
                     f"udp:bind=127.0.0.1:{bind},peer=127.0.0.1:{ap_port}", "--fleet", "door"], "mb3", ready_timeout=10)
        group.spawn([str(node), *common, "--node", "relay"], "relay", ready_timeout=10)
        door = group.spawn([prog, *common, "--node", "door", "--gcs", f"udp:bind=127.0.0.1:{gcs_port}",
                            "--fleet", "mb2", "--fleet", "mb3"], "door", ready_timeout=10)
        g = Gcs(gcs_port)
        try:
            r = measure(g, ap, rtts)
            r["door"] = door.request_stats()["mavlink"]["door"]
            return r
        finally:
            g.conn.close()


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", required=True)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--rtts", type=int, default=200)
    args = ap.parse_args()
    build = Path(args.build)
    results: dict[str, list[dict]] = {"direct": [], "mavproxy": [], "door": []}
    with tempfile.TemporaryDirectory() as td:
        for r in range(args.runs):  # interleaved: drift of the machine touches every path alike
            tmp = Path(td) / f"run{r}"
            tmp.mkdir()
            results["direct"].append(run_direct(tmp, args.rtts))
            results["mavproxy"].append(run_mavproxy(tmp, args.rtts))
            results["door"].append(run_door(tmp, args.rtts, build))
    Path(args.out).write_text(json.dumps(results, indent=1))
    for path, runs in results.items():
        rtt = [x for run in runs for x in run["rtt_ms"]]
        print(f"{path:9s} rtt median {pct(rtt, 0.5):7.3f} ms  p90 {pct(rtt, 0.9):7.3f} ms  lost {sum(r['rtt_lost'] for r in runs)}"
              f"  ATTITUDE/s {sum(r['attitude_per_s'] for r in runs) / len(runs):7.1f}"
              f"  delivered {sum(r['delivered'] for r in runs) / len(runs):.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
