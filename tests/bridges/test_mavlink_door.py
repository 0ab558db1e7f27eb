"""The MAVLink front door (docs/bridges.md#the-front-door-ground-stations-on-the-bus): ground stations
nobody here wrote (pymavlink's mavutil, two at once) see every vehicle of the fleet through one bridge
node's GCS endpoint, whichever bridge node each autopilot hangs off.

    autopilot 1 (sys 1) -- uavbus_mavbridge [door] --gcs udp:...  <-- GCS A (pymavlink, sys 255)
                                   |                               <-- GCS B (pymavlink, sys 254)
                                 udp (uavbus)
                                   |
                           uavbus_node [relay1]
                              /          \\
            uavbus_mavbridge [mb2]    uavbus_mavbridge [mb3]      (two uavbus hops from the door)
                     |                          |
             autopilot 2 (sys 2)       autopilot 3 (sys 3)

Checked, each able to fail:
  - both GCSs get HEARTBEAT and distinct ATTITUDE samples of systems 1, 2 and 3 (counts, not rates);
  - a COMMAND_LONG GCS A sends to system 2 reaches autopilot 2 only (autopilots 1 and 3 log no such
    command) with GCS A's ids, and its COMMAND_ACK (target 255) reaches GCS A, not GCS B (system 254);
  - a forged ATTITUDE (system 2, a roll no autopilot sends) from another address than autopilot 2's
    reaches no GCS and is counted `foreign` by mb2's transport;
  - the door reports the three vehicles and no system id conflict.
"""

from __future__ import annotations

import json
import os
import re
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

from uavbus.sim.portalloc import PortAllocator
from uavbus.sim.process import ProcessGroup
from uavbus.sim.secure import signed_config

from bridge_testutil import autopilot_argv

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402

FORGED_ROLL = 2.5  # the autopilots' rolls stay within +-0.1 rad
VEHICLES = (1, 2, 3)


def write_config(path: Path, ports: PortAllocator, compact: bool = False) -> None:
    a = {k: ports.port() for k in ("door", "relay_door", "relay_mb2", "relay_mb3", "mb2", "mb3")}

    def udp(bind: str, peer: str, encoding: str = "full") -> dict[str, str]:
        return {"transport": "udp", "bind": f"127.0.0.1:{a[bind]}", "peer": f"127.0.0.1:{a[peer]}", "encoding": encoding}

    mb2_link = "compact" if compact else "full"  # a radio link's encoding: both ends say the same
    cfg = {
        "system": "doortest",
        "entities": [
            {"name": "door", "links": ["toRelay"], "linktoentity": {"relay1": [0], "mb2": [0], "mb3": [0]}},
            {"name": "relay1", "links": ["toDoor", "toMb2", "toMb3"],
             "linktoentity": {"door": ["toDoor"], "mb2": ["toMb2"], "mb3": ["toMb3"]}},
            {"name": "mb2", "links": ["toRelay"], "linktoentity": {"relay1": [0], "door": [0], "mb3": [0]}},
            {"name": "mb3", "links": ["toRelay"], "linktoentity": {"relay1": [0], "door": [0], "mb2": [0]}},
        ],
        "nodes": {"door": ["door"], "relay": ["relay1"], "mb2": ["mb2"], "mb3": ["mb3"]},
        "ports": {
            "door:toRelay": udp("door", "relay_door"),
            "relay1:toDoor": udp("relay_door", "door"),
            "relay1:toMb2": udp("relay_mb2", "mb2", mb2_link),
            "relay1:toMb3": udp("relay_mb3", "mb3"),
            "mb2:toRelay": udp("mb2", "relay_mb2", mb2_link),
            "mb3:toRelay": udp("mb3", "relay_mb3"),
        },
        # Which bridges may hand a bridge MAVLink frames: the door and the vehicle bridges, nobody else.
        "security": {"write": {
            "door": [{"from": ["mb2", "mb3"], "content": "mavFrame"}],
            "mb2": [{"from": "door", "content": "mavFrame"}],
            "mb3": [{"from": "door", "content": "mavFrame"}],
        }},
    }
    path.write_text(json.dumps(cfg, indent=1))


class Gcs:
    """A pymavlink ground station on the door's UDP endpoint (mavutil `udpout`, as MAVProxy's --master)."""

    def __init__(self, port: int, sysid: int, kind: str = "udpout") -> None:
        self.conn = mavutil.mavlink_connection(f"{kind}:127.0.0.1:{port}", source_system=sysid,
                                               source_component=190, dialect="common")
        self.heartbeats: dict[int, int] = {}
        self.attitude: dict[int, set[int]] = {}
        self.rolls: list[float] = []
        self.acks: list[tuple[int, int, int]] = []  # (from system, command, result)
        self.next_hb = 0.0

    def pump(self) -> None:
        now = time.monotonic()
        if now >= self.next_hb:
            self.conn.mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_GCS, mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0,
                                         mavutil.mavlink.MAV_STATE_ACTIVE)
            self.next_hb = now + 0.5
        while (m := self.conn.recv_msg()) is not None:
            kind, src = m.get_type(), m.get_srcSystem()
            if kind == "HEARTBEAT":
                self.heartbeats[src] = self.heartbeats.get(src, 0) + 1
            elif kind == "ATTITUDE":
                self.attitude.setdefault(src, set()).add(m.time_boot_ms)
                self.rolls.append(m.roll)
            elif kind == "COMMAND_ACK":
                self.acks.append((src, m.command, m.result))


def reported(ap, command: int, timeout: float = 5.0) -> None:
    """Waits for autopilot `ap` to report `command` on its stdout (the ACK may overtake the report)."""
    ap.wait_event(lambda e: e.get("event") == "command" and e.get("command") == command, timeout,
                  what=f"the autopilot reports command {command}")


def run(gcss: list[Gcs], seconds: float, until=None) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        for g in gcss:
            g.pump()
        if until is not None and until():
            return
        time.sleep(0.005)


class Fleet:
    """Three autopilots behind the door, mb2 and mb3 (the diagram above); ports from the allocator. `aps[k]` is the
    autopilot behind the k-th bridge (door 1, mb2 2, mb3 3), whose system id is k unless `mb3_sysid` says another
    for mb3's (two vehicles with one id)."""

    def __init__(self, tmp_path: Path, group: ProcessGroup, mavbridge: dict[str, str], uavbus_node: Path,
                 door_autopilot: bool = True, signed: bool = False, compact: bool = False,
                 gcs_transport: str = "udp:bind", door_extra: tuple[str, ...] = (),
                 gcs_spec: str | None = None, mb3_sysid: int = 3) -> None:
        ports = PortAllocator()
        cfg = tmp_path / "door.json"
        write_config(cfg, ports, compact)
        if signed:
            cfg = signed_config(cfg, tmp_path / "signed")
        prog = mavbridge["program"]
        self.aps, self.mav_ports = {}, {}
        self.vehicles = VEHICLES if door_autopilot else VEHICLES[1:]
        self.sysids = {1: 1, 2: 2, 3: mb3_sysid}
        for k in self.vehicles:
            ap_port, bind = ports.port(), ports.port()
            self.aps[k] = group.spawn(autopilot_argv(ap_port, duration=55, sysid=self.sysids[k]), f"autopilot{k}",
                                      ready_timeout=10)
            self.mav_ports[k] = (bind, ap_port)
        self.gcs_port = ports.port()

        def bridge(node: str, k: int | None, extra: list[str]):
            mav = []
            if k is not None:
                bind, peer = self.mav_ports[k]
                mav = ["--target", f"{self.sysids[k]}/1", "--mavlink", f"udp:bind=127.0.0.1:{bind},peer=127.0.0.1:{peer}"]
            return group.spawn([prog, "--config", str(cfg), "--node", node, "--stats-ms", "0"] + mav + extra,
                               node, ready_timeout=10)

        spec = gcs_spec or f"{gcs_transport}=127.0.0.1:{self.gcs_port}"
        self.door = bridge("door", 1 if door_autopilot else None, ["--gcs", spec,
                                                                   "--fleet", "mb2", "--fleet", "mb3", *door_extra])
        self.mb2 = bridge("mb2", 2, ["--fleet", "door"])
        self.mb3 = bridge("mb3", 3, ["--fleet", "door"])
        group.spawn([str(uavbus_node), "--config", str(cfg), "--node", "relay", "--stats-ms", "0"], "relay",
                    ready_timeout=10)
        assert gcs_spec is not None or self.door.wait_ready()["gcs_port"] == self.gcs_port


def test_two_gcs_see_three_vehicles_and_commands_reach_only_their_target(tmp_path, group: ProcessGroup, mavbridge,
                                                                                  uavbus_node):
    f = Fleet(tmp_path, group, mavbridge, uavbus_node)
    aps, mav_ports, gcs_port, door, mb2 = f.aps, f.mav_ports, f.gcs_port, f.door, f.mb2
    a, b = Gcs(gcs_port, 255), Gcs(gcs_port, 254)
    group.on_close(a.conn.close)
    group.on_close(b.conn.close)

    def everyone_seen() -> bool:
        return all(len(g.attitude.get(s, ())) >= 20 and g.heartbeats.get(s, 0) >= 2 for g in (a, b) for s in VEHICLES)

    run([a, b], 30, everyone_seen)
    assert everyone_seen(), (f"A: hb {a.heartbeats} att { {s: len(v) for s, v in a.attitude.items()} }; "
                             f"B: hb {b.heartbeats} att { {s: len(v) for s, v in b.attitude.items()} }; "
                             f"door: {door.request_stats()['mavlink'].get('door')}")

    # A command from GCS A to system 2 only.
    marks = {s: ap.mark() for s, ap in aps.items()}
    a.conn.mav.command_long_send(2, 1, mavutil.mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    run([a, b], 10, lambda: any(ack[0] == 2 and ack[1] == 400 for ack in a.acks))
    assert (2, 400, 0) in a.acks, f"no COMMAND_ACK from system 2 at GCS A: {a.acks}; door {door.request_stats()['mavlink']['door']}"
    # The ACK can overtake the autopilot's own report of the command on its stdout: wait for the report.
    aps[2].wait_event(lambda e: e.get("event") == "command" and e.get("command") == 400, 5, since=marks[2],
                      what="autopilot 2 reports the arm command")
    got = [e for e in aps[2].all("command") if e["command"] == 400]
    assert len(got) == 1 and got[0]["from"] == [255, 190] and got[0]["params"][0] == 1.0, got
    run([a, b], 1.0)  # time for a wrongly routed copy to arrive anywhere else
    for s in (1, 3):
        ap = aps[s]
        ap.send("stats")
        ap.wait_event("stats", 3, since=marks[s])
        assert not [e for e in ap.all("command") if e["command"] == 400], f"autopilot {s} got GCS A's command"
    assert not [ack for ack in b.acks if ack[1] == 400], f"GCS B got GCS A's ACK: {b.acks}"

    # A forger sends ATTITUDE as system 2 to mb2's MAVLink port from its own address.
    forged = mavutil.mavlink.MAVLink(None, srcSystem=2, srcComponent=1)
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        for i in range(20):
            msg = mavutil.mavlink.MAVLink_attitude_message(999_000 + i, FORGED_ROLL, 0, 0, 0, 0, 0)
            sock.sendto(msg.pack(forged), ("127.0.0.1", mav_ports[2][0]))
            run([a, b], 0.05)
    finally:
        sock.close()
    run([a, b], 1.0)
    for g in (a, b):
        assert not [r for r in g.rolls if abs(r - FORGED_ROLL) < 1e-3], "a forged ATTITUDE reached a GCS"
    s2 = mb2.request_stats()["mavlink"]
    assert s2["transport"]["foreign"] >= 20 and s2["other_source"] == 0, s2

    st = door.request_stats()["mavlink"]["door"]
    assert st["systems"] == [1, 2, 3] and st["sysid_conflicts"] == 0, st
    assert st["clients"] == 2 and st["from_peers"] > 0 and st["to_clients"] > 0, st


PARAM_COUNT = 20  # mav_autopilot.PARAMS


def test_tcp_autopilot_parameters_and_statustext_through_the_door(tmp_path, group: ProcessGroup, mavbridge):
    """An autopilot on TCP (as SITL's 5760, mav_autopilot.py --tcp) behind the door: a pymavlink GCS fetches
    the whole parameter list with the exact names (char arrays: a 16-character one with no NUL), sets one,
    and reads STATUSTEXT; the bridge reconnects when the autopilot restarts."""
    ports = PortAllocator()
    ap_port, gcs_port = ports.port(), ports.port()
    cfg = tmp_path / "door1.json"
    cfg.write_text(json.dumps({
        "system": "doortest1",
        "entities": [{"name": "door", "links": [], "linktoentity": {}}],
        "nodes": {"door": ["door"]},
        "security": {"write": {"door": [{"from": "door", "content": "mavFrame"}]}},
    }))
    argv = autopilot_argv(ap_port, duration=50, sysid=7) + ["--tcp"]
    ap = group.spawn(argv, "autopilot7", ready_timeout=10)
    door = group.spawn([mavbridge["program"], "--config", str(cfg), "--node", "door", "--stats-ms", "0",
                        "--mavlink", f"tcp:connect=127.0.0.1:{ap_port}", "--gcs", f"udp:bind=127.0.0.1:{gcs_port}"],
                       "door", ready_timeout=10)
    door.wait_event(lambda e: e.get("event") == "autopilot" and e.get("state") == "connected", 10,
                    what="autopilot connected over TCP")
    g = Gcs(gcs_port, 255)
    group.on_close(g.conn.close)
    run([g], 10, lambda: g.heartbeats.get(7, 0) >= 1)
    assert g.heartbeats.get(7), f"no HEARTBEAT of system 7 at the GCS: {door.request_stats()['mavlink']}"

    # The parameter list, with pymavlink's own bookkeeping (as MAVProxy's `param fetch`).
    values: dict[str, float] = {}
    texts: list[str] = []

    def collect() -> None:
        while (m := g.conn.recv_msg()) is not None:
            if m.get_type() == "PARAM_VALUE" and m.get_srcSystem() == 7:
                values[m.param_id] = m.param_value
                count = m.param_count
                assert count == PARAM_COUNT, count
            elif m.get_type() == "STATUSTEXT":
                texts.append(m.text)

    g.conn.mav.param_request_list_send(7, 1)
    end = time.monotonic() + 10
    while len(values) < PARAM_COUNT and time.monotonic() < end:
        collect()
        time.sleep(0.01)
    assert len(values) == PARAM_COUNT, sorted(values)
    assert values["WPNAV_SPEED_DN_X"] == 150.0 and values["SYSID_THISMAV"] == 7.0, values

    g.conn.mav.param_set_send(7, 1, b"TEST_P05", 42.5, mavutil.mavlink.MAV_PARAM_TYPE_REAL32)
    end = time.monotonic() + 5
    while values.get("TEST_P05") != 42.5 and time.monotonic() < end:
        collect()
        time.sleep(0.01)
    assert values.get("TEST_P05") == 42.5, values
    assert any(e["name"] == "TEST_P05" and e["value"] == 42.5 for e in ap.all("param_set")), ap.all("param_set")

    ap.send("statustext Battery 3 low: 22% left")
    end = time.monotonic() + 5
    while "Battery 3 low: 22% left" not in texts and time.monotonic() < end:
        collect()
        time.sleep(0.01)
    assert "Battery 3 low: 22% left" in texts, texts

    # The autopilot restarts (SITL does): the bridge connects again by itself.
    ap.stop()
    door.wait_event(lambda e: e.get("event") == "autopilot" and e.get("state") == "lost", 10, what="autopilot lost")
    mark = door.mark()
    ap.restart(ready_timeout=10)
    door.wait_event(lambda e: e.get("event") == "autopilot" and e.get("state") == "connected", 15, since=mark,
                    what="autopilot back over TCP")
    t = door.request_stats()["mavlink"]["transport"]
    assert t["connects"] >= 2 and t["disconnects"] >= 1, t


class MavProxy:
    """MAVProxy (PyPI) as an operator runs it: `mavproxy.py --master udpout:HOST:PORT`, commands on stdin."""

    def __init__(self, tmp_path: Path, gcs_port: int, target: int, source_system: int = 250) -> None:
        exe = Path(sys.executable).with_name("mavproxy.py")
        assert exe.exists(), f"{exe} missing: MAVProxy is in the test extra of pyproject.toml (make setup installs it)"
        state = tmp_path / "mavproxy"
        state.mkdir()
        self.proc = subprocess.Popen(
            [sys.executable, str(exe), f"--master=udpout:127.0.0.1:{gcs_port}", f"--source-system={source_system}",
             f"--target-system={target}", f"--state-basedir={state}", f"--logfile={state / 'mav.tlog'}"],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, cwd=state, text=True, bufsize=1)
        self.lines: list[str] = []
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()

    def _read(self) -> None:
        for line in self.proc.stdout:  # type: ignore[union-attr]
            self.lines.append(line.rstrip("\n"))

    def send(self, command: str) -> None:
        self.proc.stdin.write(command + "\n")  # type: ignore[union-attr]
        self.proc.stdin.flush()  # type: ignore[union-attr]

    def wait(self, pattern: str, timeout: float, since: int = 0) -> re.Match[str]:
        rx = re.compile(pattern)
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            for line in self.lines[since:]:
                if (m := rx.search(line)) is not None:
                    return m
            time.sleep(0.05)
        raise AssertionError(f"MAVProxy never printed /{pattern}/ in {timeout} s; its output:\n" + "\n".join(self.lines[-40:]))

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait(5)


def test_mavproxy_and_pymavlink_at_once(tmp_path, group: ProcessGroup, mavbridge, uavbus_node):
    """MAVProxy on the door, aimed at system 3 (two uavbus hops away), while a pymavlink GCS watches: MAVProxy
    sees the vehicles, fetches the whole parameter list (after its MAVFTP attempt times out, as against any
    autopilot without FTP), its arm command is acknowledged by system 3 only, and its `wp load` / `wp list`
    upload and download a 5-item mission with system 3."""
    f = Fleet(tmp_path, group, mavbridge, uavbus_node)
    watcher = Gcs(f.gcs_port, 254)
    group.on_close(watcher.conn.close)
    mp = MavProxy(tmp_path, f.gcs_port, target=3)
    group.on_close(mp.close)
    end = time.monotonic() + 40
    seen: set[int] = set()
    while time.monotonic() < end and not (len(seen) == 3 and any("Received" in x for x in mp.lines)):
        run([watcher], 0.2)
        seen = {int(m.group(1)) for x in mp.lines if (m := re.search(r"Detected vehicle (\d+):1", x))}
    assert seen == set(VEHICLES), "MAVProxy did not see the three vehicles:\n" + "\n".join(mp.lines[-30:])
    got = mp.wait(r"Received (\d+) parameters", 5)
    assert int(got.group(1)) == PARAM_COUNT, got.group(0)
    lists = [e for e in f.aps[3].all("param_list") if e["from"][0] == 250]
    assert lists and not [e for s in (1, 2) for e in f.aps[s].all("param_list") if e["from"][0] == 250]

    mark = len(mp.lines)
    mp.send("arm throttle")
    mp.wait(r"COMMAND_ACK.*(ARM|400).*ACCEPTED|Got COMMAND_ACK: COMPONENT_ARM_DISARM: ACCEPTED", 15, since=mark)
    reported(f.aps[3], 400)
    arms = [e for e in f.aps[3].all("command") if e["command"] == 400]
    assert arms and arms[0]["from"][0] == 250, arms
    for s in (1, 2):
        assert not [e for e in f.aps[s].all("command") if e["command"] == 400], f"autopilot {s} got MAVProxy's arm"
    run([watcher], 0.5)
    assert all(len(watcher.attitude.get(s, ())) > 10 for s in VEHICLES), {k: len(v) for k, v in watcher.attitude.items()}

    # MAVProxy's `wp load` (upload over the mission protocol) and `wp list` (download) with system 3.
    wpl = tmp_path / "mission.txt"
    rows = ["QGC WPL 110", "0\t1\t0\t16\t0\t0\t0\t0\t47.3977420\t8.5455940\t0.000000\t1"]
    rows += [f"{i}\t0\t3\t16\t0\t0\t0\t0\t{47.3977420 + 0.0001 * i:.7f}\t{8.5455940 + 0.0001 * i:.7f}\t{20 + i:.6f}\t1"
             for i in range(1, 5)]
    wpl.write_text("\n".join(rows) + "\n")
    mark = len(mp.lines)
    mp.send(f"wp load {wpl}")
    mp.wait(r"Sent all 5 waypoints|Loaded 5 waypoints in", 20, since=mark)
    f.aps[3].wait_event(lambda e: e.get("event") == "mission" and e.get("what") == "uploaded", 5, what="MAVProxy's upload")
    up = [e for e in f.aps[3].all("mission") if e["what"] == "uploaded"][-1]
    assert up["from"][0] == 250 and [round(it[4]) for it in up["items"]] == [0, 21, 22, 23, 24], up
    mark = len(mp.lines)
    mp.send("wp list")
    saved = mp.wait(r"Saved 5 waypoints to (\S+)", 20, since=mark)
    got = [line.split("\t") for line in Path(saved.group(1)).read_text().splitlines()[1:]]
    assert len(got) == 5, got
    for i, r in enumerate(got[1:], start=1):  # 1e-7 degree: the protocol's integer latitude and longitude
        assert abs(float(r[8]) - (47.3977420 + 0.0001 * i)) < 2e-7 and abs(float(r[9]) - (8.5455940 + 0.0001 * i)) < 2e-7 \
            and abs(float(r[10]) - (20 + i)) < 1e-3, got
    assert not [e for s in (1, 2) for e in f.aps[s].all("mission")], "another vehicle saw MAVProxy's mission"


def test_mavsdk_discovers_every_vehicle_arms_one_and_sets_a_parameter(tmp_path, group: ProcessGroup, mavbridge,
                                                                         uavbus_node):
    """MAVSDK (PyPI `mavsdk`, MAVSDK's C library) on the door: discovers the three system ids, reads each one's
    attitude, arms system 3 (two hops away; only it is armed), sets and reads back a parameter of system 2, and
    uploads a 5-waypoint mission to system 3 and reads it back."""
    f = Fleet(tmp_path, group, mavbridge, uavbus_node)
    script = Path(__file__).with_name("mavsdk_gcs.py")
    proc = subprocess.run([sys.executable, str(script), "--url", f"udpout://127.0.0.1:{f.gcs_port}", "--vehicles", "3",
                           "--arm", "3", "--param", "2:TEST_P07=12.25", "--mission", "3:5", "--rate", "2:5"], capture_output=True, text=True,
                          timeout=80)
    assert proc.returncode == 0, proc.stderr[-3000:]
    got = json.loads(proc.stdout.strip().splitlines()[-1])
    assert got["systems"] == list(VEHICLES), (got, f.door.request_stats()["mavlink"]["door"])
    for s in VEHICLES:
        roll = got["attitude"][str(s)]
        assert roll is not None and abs(roll) < 6.0, got  # the autopilots' roll: 0.1 sin(t) rad
    assert got["arm"] == "ok", got
    reported(f.aps[3], 400)
    arms = [e for s in VEHICLES for e in f.aps[s].all("command") if e["command"] == 400]
    assert len({tuple(e["target"]) for e in arms}) == 1 and all(e["target"][0] == 3 for e in arms), arms
    assert [e for e in f.aps[3].all("command") if e["command"] == 400], "system 3 never saw the arm command"
    assert got["param"] == 12.25, got
    sets = {s: [e for e in f.aps[s].all("param_set") if e["name"] == "TEST_P07"] for s in VEHICLES}
    assert sets[2] and not sets[1] and not sets[3], sets
    # MAVSDK asks system 2's attitude at 5 Hz: acknowledged (by system 2's bridge), a flow of the door's ground station.
    assert got["rate"] == "ok", got
    flows = f.door.request_stats()["mavlink"]["door"]["flows"]
    assert any(fl["sysid"] == 2 and fl["interval_us"] == 200_000 and fl["link"].startswith("gcs:") for fl in flows), flows
    # A 5-waypoint mission uploaded to system 3 with MAVSDK's mission plugin, and read back.
    mission = got["mission"]
    assert isinstance(mission, dict), mission
    assert len(mission["down"]) == 5, mission
    for (lat, lon, alt), (lat2, lon2, alt2) in zip(mission["up"], mission["down"]):
        assert abs(lat - lat2) < 1e-6 and abs(lon - lon2) < 1e-6 and abs(alt - alt2) < 1e-3, mission
    f.aps[3].wait_event(lambda e: e.get("event") == "mission" and e.get("what") == "uploaded", 5, what="MAVSDK's upload")
    assert not [e for s in (1, 2) for e in f.aps[s].all("mission")], "another vehicle saw system 3's mission"


def test_a_door_without_autopilot_on_a_signed_bus_with_a_compact_link(tmp_path, group: ProcessGroup, mavbridge,
                                                                       uavbus_node):
    """The ground side's node is only a door (no --mavlink): the vehicles are all elsewhere. The bus is signed
    (every bridge requires signed frames) and mb2's radio link is compact: the frames still arrive, every
    one verified, none refused."""
    f = Fleet(tmp_path, group, mavbridge, uavbus_node, door_autopilot=False, signed=True, compact=True)
    ready = f.door.wait_ready()
    assert ready["mavlink"] is None and ready["uavbus_signed"], ready
    g = Gcs(f.gcs_port, 255)
    group.on_close(g.conn.close)
    def all_seen() -> bool:
        return all(len(g.attitude.get(s, ())) >= 20 and g.heartbeats.get(s, 0) >= 2 for s in f.vehicles)

    run([g], 30, all_seen)
    assert all_seen() and 1 not in g.attitude, \
        ({k: len(v) for k, v in g.attitude.items()}, g.heartbeats, f.door.request_stats()["mavlink"]["door"])
    g.conn.mav.command_long_send(2, 1, mavutil.mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    run([g], 10, lambda: any(ack[0] == 2 and ack[1] == 400 for ack in g.acks))
    assert (2, 400, 0) in g.acks, g.acks
    st = f.door.request_stats()
    assert st["mavlink"]["door"]["systems"] == [2, 3] and st["mavlink"]["door"]["to_autopilot"] == 0, st["mavlink"]["door"]
    assert st["mavlink"]["messages_out"] == 0, st["mavlink"]  # no autopilot: nothing sent toward one
    assert st["security"]["verified_in"] > 100 and st["security"]["auth_failures"] == 0, st["security"]
    mb2 = f.mb2.request_stats()
    assert mb2["security"]["signed_out"] > 100, mb2["security"]


def test_serial_autopilot_behind_the_door(tmp_path, group: ProcessGroup, mavbridge):
    """An autopilot on a serial line (a pseudo-terminal pair: mav_autopilot.py --pty) behind the door,
    `serial:device=PATH,baud=57600`: a pymavlink GCS sees it and its command is acknowledged."""
    ports = PortAllocator()
    gcs_port = ports.port()
    cfg = tmp_path / "door1.json"
    cfg.write_text(json.dumps({
        "system": "doortest1",
        "entities": [{"name": "door", "links": [], "linktoentity": {}}],
        "nodes": {"door": ["door"]},
        "security": {"write": {"door": [{"from": "door", "content": "mavFrame"}]}},
    }))
    ap = group.spawn(autopilot_argv(0, duration=50, sysid=9) + ["--pty"], "autopilot9", ready_timeout=10)
    device = ap.wait_ready()["device"]
    assert device and device.startswith("/dev/pts/"), device
    door = group.spawn([mavbridge["program"], "--config", str(cfg), "--node", "door", "--stats-ms", "0",
                        "--mavlink", f"serial:device={device},baud=57600", "--gcs", f"udp:bind=127.0.0.1:{gcs_port}"],
                       "door", ready_timeout=10)
    door.wait_event(lambda e: e.get("event") == "autopilot" and e.get("state") == "connected", 10,
                    what="autopilot connected over serial")
    g = Gcs(gcs_port, 255)
    group.on_close(g.conn.close)
    run([g], 15, lambda: g.heartbeats.get(9, 0) >= 1 and len(g.attitude.get(9, ())) >= 20)
    assert g.heartbeats.get(9) and len(g.attitude.get(9, ())) >= 20, (g.heartbeats, door.request_stats()["mavlink"])
    # As MAVLink's command protocol: resent (confirmation counting up) until acknowledged. A pty drops what its
    # reader has not taken in time, like a radio: the bridge counts such gaps as `lost`.
    for attempt in range(5):
        g.conn.mav.command_long_send(9, 1, mavutil.mavlink.MAV_CMD_COMPONENT_ARM_DISARM, attempt, 1, 0, 0, 0, 0, 0, 0)
        run([g], 2, lambda: (9, 400, 0) in g.acks)
        if (9, 400, 0) in g.acks:
            break
    assert (9, 400, 0) in g.acks, (g.acks, ap.all("command"))
    # The pty pair itself loses messages after a few seconds on this machine (a pymavlink reader alone loses as
    # many: docs/bridges.md), so completeness and clean framing are not asserted here; the bridge counts them.
    st = door.request_stats()["mavlink"]
    assert st["messages_in"] > 50, st


def test_two_ground_stations_over_tcp(tmp_path, group: ProcessGroup, mavbridge, uavbus_node):
    """The door as a TCP server (--gcs tcp:listen=...; QGroundControl's and MAVProxy's `tcp:` links): two
    pymavlink ground stations connect, both see the three vehicles, a command from one reaches only its
    target and its ACK only that ground station; when it disconnects the other one goes on."""
    f = Fleet(tmp_path, group, mavbridge, uavbus_node, gcs_transport="tcp:listen")
    a, b = Gcs(f.gcs_port, 255, "tcp"), Gcs(f.gcs_port, 254, "tcp")
    group.on_close(b.conn.close)

    def seen(g: Gcs) -> bool:
        return all(len(g.attitude.get(s, ())) >= 20 and g.heartbeats.get(s, 0) >= 2 for s in VEHICLES)

    run([a, b], 30, lambda: seen(a) and seen(b))
    assert seen(a) and seen(b), ({k: len(v) for k, v in a.attitude.items()}, {k: len(v) for k, v in b.attitude.items()},
                                 f.door.request_stats()["mavlink"]["door"])
    a.conn.mav.command_long_send(2, 1, mavutil.mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    run([a, b], 10, lambda: (2, 400, 0) in a.acks)
    assert (2, 400, 0) in a.acks and not [x for x in b.acks if x[1] == 400], (a.acks, b.acks)
    assert not [e for s in (1, 3) for e in f.aps[s].all("command") if e["command"] == 400]
    a.conn.close()
    before = len(b.attitude.get(3, ()))
    run([b], 2)
    assert len(b.attitude.get(3, ())) > before + 20, "the other ground station stopped when one left"
    st = f.door.request_stats()["mavlink"]["door"]
    assert st["clients"] == 1 and st["clients_closed"] == 1 and st["clients_new"] == 2, st
