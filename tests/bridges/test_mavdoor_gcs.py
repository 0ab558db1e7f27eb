"""What a ground station does through the MAVLink front door beyond seeing and commanding the fleet
(docs/bridges.md#the-front-door-ground-stations-see-the-whole-fleet), with the fleet of test_mavlink_door.py
(three pymavlink autopilots behind three bridge nodes, two of them two uavbus hops from the door):

  - rates: SET_MESSAGE_INTERVAL and REQUEST_DATA_STREAM from ground stations become flows of the bridges'
    routers: each ground station gets the rate it asked, the vehicle's bridge answers COMMAND_ACK as an
    autopilot does and asks its autopilot for the fastest any of them wants (the GCS's command itself never
    reaches the autopilot); two ground stations with one system id are reported;
  - MAVLink 2 signing on the GCS endpoint: a ground station with the key gets in, unsigned and wrong-key
    frames from other addresses are counted and dropped, forged ATTITUDE reaches no ground station;
  - a serial GCS endpoint (a pseudo-terminal pair);
  - the mission protocol (upload, download, clear) from a pymavlink ground station to a vehicle two hops away.
"""

from __future__ import annotations

import os
import socket
import time
from pathlib import Path

from uavbus.sim.process import ProcessGroup

from test_mavlink_door import VEHICLES, Fleet, Gcs, reported, run

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402

M = mavutil.mavlink
ATTITUDE = M.MAVLINK_MSG_ID_ATTITUDE
FORGED_ROLL = 2.5  # the autopilots' rolls stay within +-0.1 rad


def samples_between(g: Gcs, sysid: int, seconds: float, others: list[Gcs]) -> int:
    """ATTITUDE samples of `sysid` that `g` receives in the next `seconds` (others pumped meanwhile)."""
    before = len(g.attitude.get(sysid, ()))
    run([g, *others], seconds)
    return len(g.attitude.get(sysid, ())) - before


def test_rates_asked_by_ground_stations_are_flows_of_the_bus(tmp_path, group: ProcessGroup, mavbridge, uavbus_node):
    f = Fleet(tmp_path, group, mavbridge, uavbus_node)
    a, b = Gcs(f.gcs_port, 250), Gcs(f.gcs_port, 251)
    for g in (a, b):
        group.on_close(g.conn.close)
    run([a, b], 30, lambda: all(len(g.attitude.get(s, ())) >= 20 for g in (a, b) for s in VEHICLES))
    assert all(len(g.attitude.get(s, ())) >= 20 for g in (a, b) for s in VEHICLES), (a.attitude.keys(), b.attitude.keys())

    # A wants system 2's ATTITUDE at 5 Hz, B at 50 Hz (the autopilot's default): each acknowledged as an autopilot does.
    a.conn.mav.command_long_send(2, 1, M.MAV_CMD_SET_MESSAGE_INTERVAL, 0, ATTITUDE, 200_000, 0, 0, 0, 0, 0)
    b.conn.mav.command_long_send(2, 1, M.MAV_CMD_SET_MESSAGE_INTERVAL, 0, ATTITUDE, 20_000, 0, 0, 0, 0, 0)
    run([a, b], 10, lambda: (2, 511, 0) in a.acks and (2, 511, 0) in b.acks)
    assert (2, 511, 0) in a.acks and (2, 511, 0) in b.acks, (a.acks, b.acks)
    reported(f.aps[2], 511)  # the bridge's own request
    run([a, b], 1.0)  # the faster rate reaches mb2, mb2's bridge asks its autopilot
    got_a = samples_between(a, 2, 3.0, [b])
    got_b = samples_between(b, 2, 3.0, [a])
    assert 3 <= got_a and got_a * 4 <= got_b, (got_a, got_b)  # 5 Hz against 50 Hz, whatever the machine's pace
    # The GCSs' commands never reached the autopilot: its bridge asked it, for the fastest rate wanted.
    cmds = [e for e in f.aps[2].all("command") if e["command"] == 511]
    assert cmds and all(e["from"][0] not in (250, 251) for e in cmds), cmds
    asked = [e["requested_us"] for e in f.aps[2].all("interval") if e["msgid"] == ATTITUDE]
    assert asked and asked[-1] == 20_000, (asked, f.aps[2].all("interval"))

    # REQUEST_DATA_STREAM (MAVProxy's and QGroundControl's way with ArduPilot): EXTRA1 (ATTITUDE) of system 3 at 2 Hz.
    a.conn.mav.request_data_stream_send(3, 1, M.MAV_DATA_STREAM_EXTRA1, 2, 1)
    run([a, b], 1.5)
    got3 = samples_between(a, 3, 3.0, [b])
    assert 2 <= got3 <= 12, got3
    assert any(e["msgid"] == ATTITUDE and e["requested_us"] == 500_000 for e in f.aps[3].all("interval")), \
        f.aps[3].all("interval")

    # A wants none of system 2's ATTITUDE any more; B goes on at its rate.
    a.conn.mav.command_long_send(2, 1, M.MAV_CMD_SET_MESSAGE_INTERVAL, 0, ATTITUDE, -1, 0, 0, 0, 0, 0)
    run([a, b], 1.0)
    assert samples_between(a, 2, 2.0, [b]) == 0
    assert samples_between(b, 2, 1.0, [a]) > 20

    door = f.door.request_stats()["mavlink"]["door"]
    mb2 = f.mb2.request_stats()["mavlink"]
    assert door["rate_forwarded"] >= 4 and door["rate_limited"] > 0 and door["flows_full"] == 0, door
    assert mb2["door"]["rate_requests"] >= 3 and mb2["intervals_granted"] >= 1, mb2
    # The flows as stats show them: per ground station at the door, the door's fastest at mb2.
    assert {"link": "peer:door", "sysid": 2, "msgid": ATTITUDE, "interval_us": 20_000} in mb2["door"]["flows"], mb2["door"]
    assert sorted(fl["interval_us"] for fl in door["flows"] if fl["sysid"] == 2) == [-1, 20_000], door["flows"]

    # A third ground station takes A's system id: reported, not hidden.
    mark = f.door.mark()
    c = Gcs(f.gcs_port, 250)
    group.on_close(c.conn.close)
    run([a, b, c], 2.0)
    f.door.wait_event(lambda e: e.get("event") == "warning" and "two ground stations" in e.get("message", ""), 5,
                      since=mark, what="the shared GCS system id reported")
    assert f.door.request_stats()["mavlink"]["door"]["gcs_sysid_shared"] >= 1


def key_file(path: Path, hexkey: str) -> Path:
    path.write_text(f"# MAVLink signing key of the GCS endpoint\n{hexkey}\n")
    path.chmod(0o600)
    return path


GCS_KEY = "a1" * 32


def signed_gcs(port: int, sysid: int, hexkey: str) -> Gcs:
    g = Gcs(port, sysid)
    g.conn.setup_signing(bytes.fromhex(hexkey), sign_outgoing=True, allow_unsigned_callback=None)
    return g


def test_signed_gcs_endpoint_keeps_out_unsigned_and_wrong_key_senders(tmp_path, group: ProcessGroup, mavbridge,
                                                                      uavbus_node):
    key = key_file(tmp_path / "gcs.key", GCS_KEY)
    f = Fleet(tmp_path, group, mavbridge, uavbus_node, door_extra=("--gcs-key", str(key)))
    good = signed_gcs(f.gcs_port, 250, GCS_KEY)
    spoof = Gcs(f.gcs_port, 250)  # unsigned, claiming the good GCS's system id, from another address
    wrong = signed_gcs(f.gcs_port, 249, "b2" * 32)
    for g in (good, spoof, wrong):
        group.on_close(g.conn.close)

    def all_seen() -> bool:
        return all(len(good.attitude.get(s, ())) >= 20 and good.heartbeats.get(s, 0) >= 2 for s in VEHICLES)

    run([good, spoof, wrong], 30, all_seen)
    assert all_seen(), (good.heartbeats, {k: len(v) for k, v in good.attitude.items()},
                        f.door.request_stats()["mavlink"]["door"])
    # pymavlink with a key and no unsigned callback refuses unsigned frames: all it got was signed.
    assert good.conn.mav.signing.goodsig_count > 100 and good.conn.mav.signing.unsigned_count == 0

    # The attackers command system 3 and forge system 2's ATTITUDE at the endpoint; the forger also feeds mb2's
    # MAVLink port from its own address (the forged autopilot: 56 of 115 samples reached the GCS then).
    forged = mavutil.mavlink.MAVLink(None, srcSystem=2, srcComponent=1)
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sent = 0
    try:
        for i in range(40):
            spoof.conn.mav.command_long_send(3, 1, M.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
            wrong.conn.mav.command_long_send(3, 1, M.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
            pkt = M.MAVLink_attitude_message(999_000 + i, FORGED_ROLL, 0, 0, 0, 0, 0).pack(forged)
            sock.sendto(pkt, ("127.0.0.1", f.gcs_port))
            sock.sendto(pkt, ("127.0.0.1", f.mav_ports[2][0]))
            sent += 1
            run([good, spoof, wrong], 0.03)
    finally:
        sock.close()
    run([good, spoof, wrong], 1.0)
    reached = [r for r in good.rolls if abs(r - FORGED_ROLL) < 1e-3]
    assert len(reached) == 0, f"{len(reached)} of {sent} forged ATTITUDE samples reached the GCS"
    assert not [e for e in f.aps[3].all("command") if e["command"] == 400], "an unauthenticated arm reached system 3"
    assert not spoof.heartbeats and not wrong.heartbeats, (spoof.heartbeats, wrong.heartbeats)

    # The key holder still commands.
    good.conn.mav.command_long_send(3, 1, M.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    run([good], 10, lambda: (3, 400, 0) in good.acks)
    assert (3, 400, 0) in good.acks, good.acks
    reported(f.aps[3], 400)
    arms = [e for e in f.aps[3].all("command") if e["command"] == 400]
    assert len(arms) == 1 and arms[0]["from"][0] == 250, arms

    door = f.door.request_stats()["mavlink"]["door"]
    assert door["gcs_signing"] and door["gcs_unsigned"] >= 80 and door["gcs_bad_signature"] >= 40, door
    assert door["clients"] == 1 and door["unauthenticated"] >= 80, door
    assert f.mb2.request_stats()["mavlink"]["transport"]["foreign"] >= 40


class PtyGcs(Gcs):
    """A pymavlink ground station on the master end of a pseudo-terminal pair (the door has the other end)."""

    def __init__(self, sysid: int) -> None:
        import tty

        self.fd, self.slave = os.openpty()
        tty.setraw(self.slave)
        os.set_blocking(self.fd, False)
        self.device = os.ttyname(self.slave)

        class Conn:
            def __init__(conn) -> None:
                conn.mav = M.MAVLink(conn, srcSystem=sysid, srcComponent=190)
                conn.mav.robust_parsing = True
                conn.pending: list = []

            def write(conn, buf: bytes) -> None:
                os.write(self.fd, buf)

            def recv_msg(conn):
                if not conn.pending:
                    try:
                        data = os.read(self.fd, 4096)
                    except (BlockingIOError, OSError):
                        data = b""
                    conn.pending = (conn.mav.parse_buffer(data) or []) if data else []
                return conn.pending.pop(0) if conn.pending else None

            def close(conn) -> None:
                for fd in (self.fd, self.slave):
                    try:
                        os.close(fd)
                    except OSError:
                        pass

        self.conn = Conn()
        self.heartbeats, self.attitude, self.rolls, self.acks, self.next_hb = {}, {}, [], [], 0.0


def test_serial_gcs_endpoint(tmp_path, group: ProcessGroup, mavbridge, uavbus_node):
    """--gcs serial:device=PATH,baud=N: a ground station on a serial line (a pty pair here) sees the fleet and
    commands a vehicle two hops away; the door counts one client."""
    g = PtyGcs(250)
    group.on_close(g.conn.close)
    f = Fleet(tmp_path, group, mavbridge, uavbus_node, gcs_spec=f"serial:device={g.device},baud=57600")
    assert "gcs_port" not in f.door.wait_ready()
    run([g], 30, lambda: all(g.heartbeats.get(s, 0) >= 2 and len(g.attitude.get(s, ())) >= 20 for s in VEHICLES))
    assert all(g.heartbeats.get(s, 0) >= 2 and len(g.attitude.get(s, ())) >= 20 for s in VEHICLES), \
        (g.heartbeats, {k: len(v) for k, v in g.attitude.items()}, f.door.request_stats()["mavlink"]["door"])
    # As MAVLink's command protocol: resent until acknowledged (a pty may drop what its reader did not take in time).
    for attempt in range(5):
        g.conn.mav.command_long_send(3, 1, M.MAV_CMD_COMPONENT_ARM_DISARM, attempt, 1, 0, 0, 0, 0, 0, 0)
        run([g], 2, lambda: (3, 400, 0) in g.acks)
        if (3, 400, 0) in g.acks:
            break
    assert (3, 400, 0) in g.acks, g.acks
    assert not [e for s in (1, 2) for e in f.aps[s].all("command") if e["command"] == 400]
    door = f.door.request_stats()["mavlink"]["door"]
    assert door["clients"] == 1 and door["from_clients"] >= 3 and door["client_parse_errors"] == 0, door


def mission_items(target: int, n: int) -> list:
    return [M.MAVLink_mission_item_int_message(target, 1, i, M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, M.MAV_CMD_NAV_WAYPOINT,
                                               0, 1, 0, 2.0, 0, 0, 473977420 + 1000 * i, 85455940 + 700 * i, 20.0 + i)
            for i in range(n)]


def expect(g: Gcs, kinds: tuple[str, ...], src: int, timeout: float = 5.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        m = g.conn.recv_msg()
        if m is None:
            time.sleep(0.002)
            continue
        if m.get_type() in kinds and m.get_srcSystem() == src:
            return m
    raise AssertionError(f"no {kinds} from system {src} within {timeout} s")


def test_mission_upload_download_clear_two_hops_away(tmp_path, group: ProcessGroup, mavbridge, uavbus_node):
    """The mission protocol as a ground station runs it (pymavlink; MISSION_COUNT / REQUEST_INT / ITEM_INT / ACK)
    with system 3, two uavbus hops from the door: 5 waypoints uploaded, downloaded identical, cleared; system 1
    and 2 see none of it."""
    f = Fleet(tmp_path, group, mavbridge, uavbus_node)
    g = Gcs(f.gcs_port, 250)
    group.on_close(g.conn.close)
    run([g], 30, lambda: all(g.heartbeats.get(s, 0) >= 1 for s in VEHICLES))
    items = mission_items(3, 5)

    g.conn.mav.mission_count_send(3, 1, len(items), 0)
    for _ in items:
        req = expect(g, ("MISSION_REQUEST_INT", "MISSION_REQUEST"), 3)
        g.conn.mav.send(items[req.seq])
    ack = expect(g, ("MISSION_ACK",), 3)
    assert ack.type == M.MAV_MISSION_ACCEPTED and ack.target_system == 250, ack
    f.aps[3].wait_event(lambda e: e.get("event") == "mission" and e.get("what") == "uploaded", 5, what="the upload")
    up = [e for e in f.aps[3].all("mission") if e["what"] == "uploaded"]
    assert len(up) == 1 and up[0]["from"][0] == 250, up
    assert [it[:2] for it in up[0]["items"]] == [[i, M.MAV_CMD_NAV_WAYPOINT] for i in range(5)], up

    g.conn.mav.mission_request_list_send(3, 1, 0)
    count = expect(g, ("MISSION_COUNT",), 3).count
    assert count == 5
    back = []
    for seq in range(count):
        g.conn.mav.mission_request_int_send(3, 1, seq, 0)
        back.append(expect(g, ("MISSION_ITEM_INT",), 3))
    g.conn.mav.mission_ack_send(3, 1, M.MAV_MISSION_ACCEPTED, 0)
    assert [(i.seq, i.command, i.x, i.y, i.z) for i in back] == [(i.seq, i.command, i.x, i.y, i.z) for i in items]

    g.conn.mav.mission_clear_all_send(3, 1, 0)
    assert expect(g, ("MISSION_ACK",), 3).type == M.MAV_MISSION_ACCEPTED
    g.conn.mav.mission_request_list_send(3, 1, 0)
    assert expect(g, ("MISSION_COUNT",), 3).count == 0
    f.aps[3].wait_event(lambda e: e.get("event") == "mission" and e.get("what") == "cleared", 5, what="the clear")
    for s in (1, 2):
        assert not f.aps[s].all("mission"), f"system {s} saw system 3's mission"


def test_two_vehicles_with_one_system_id_are_reported_not_merged(tmp_path, group: ProcessGroup, mavbridge, uavbus_node):
    """mb2's and mb3's autopilots both say system 2 (a cloned parameter file): the door reports it once (warning,
    `sysid_conflicts`), keeps the first vehicle heard and drops the other's frames; a command to system 2 reaches
    one autopilot only."""
    f = Fleet(tmp_path, group, mavbridge, uavbus_node, door_autopilot=False, mb3_sysid=2)
    mark = f.door.mark()
    g = Gcs(f.gcs_port, 250)
    group.on_close(g.conn.close)
    run([g], 30, lambda: len(g.attitude.get(2, ())) >= 50)
    w = f.door.wait_event(lambda e: e.get("event") == "warning" and "used by two vehicles" in e.get("message", ""), 10,
                          since=mark, what="the system id conflict reported")
    assert "system id 2" in w["message"], w
    door = f.door.request_stats()["mavlink"]["door"]
    assert door["systems"] == [2] and door["sysid_conflicts"] > 0, door
    # Not merged: the ATTITUDE samples the GCS got come from one autopilot's clock (distinct, no interleaving of two).
    g.conn.mav.command_long_send(2, 1, M.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    run([g], 10, lambda: (2, 400, 0) in g.acks)
    assert (2, 400, 0) in g.acks, g.acks
    run([g], 1.0)
    got = {k: [e for e in f.aps[k].all("command") if e["command"] == 400] for k in (2, 3)}
    assert sum(1 for k in got if got[k]) == 1, got
