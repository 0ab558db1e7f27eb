"""A small autopilot made of pymavlink's mavutil (a MAVLink peer nobody here wrote): the vehicle end of
the MAVLink bridge tests and bench.

    python mav_autopilot.py --port P [--sysid 1 --compid 1] [--key FILE] [--duration S]

Listens on udp 127.0.0.1:P (mavutil `udpin`: it answers whoever spoke last, so it starts streaming
when the bridge's first HEARTBEAT arrives) and, as system 1 component 1:
  - sends HEARTBEAT at 1 Hz, ATTITUDE at 50 Hz and GLOBAL_POSITION_INT at 10 Hz by default, each
    with time_boot_ms (a new value per sample) and values that move;
  - honours MAV_CMD_SET_MESSAGE_INTERVAL (interval µs; 0 = default rate, -1 = off) for the messages
    it streams, answering ACCEPTED, and UNSUPPORTED for any other message id;
  - answers every other COMMAND_LONG / COMMAND_INT with COMMAND_ACK ACCEPTED;
  - serves the parameter protocol over PARAMS (PARAM_REQUEST_LIST, _READ by id or index, PARAM_SET),
    names being MAVLink char arrays (16 bytes, not NUL-terminated at full length);
  - serves the mission protocol (MAVLink's, as PX4 and ArduPilot do, per mission type): upload (MISSION_COUNT ->
    MISSION_REQUEST_INT for each item -> MISSION_ITEM_INT -> MISSION_ACK), download (MISSION_REQUEST_LIST ->
    MISSION_COUNT -> MISSION_REQUEST_INT / MISSION_REQUEST -> MISSION_ITEM_INT -> MISSION_ACK), clear
    (MISSION_CLEAR_ALL -> MISSION_ACK); "mission" events on stdout (uploaded, cleared);
  - sends STATUSTEXT "<name> ready" when a peer first speaks, and on `statustext TEXT` (stdin).
With --tcp it listens for one TCP connection instead (as ArduPilot SITL's 5760); with --pty it makes a
pseudo-terminal pair, keeps the master end and says the other end's path in "ready" (`device`): a serial
autopilot for a bridge's `serial:device=PATH`.
With --key (64 hex digits in a file), pymavlink's own MAVLink 2 signing: everything it sends is signed
and nothing unsigned is accepted.

JSON lines on stdout: "ready", "command" (every command received: id, params, signed), "interval"
(a stream's new interval), "stats" (on `stats` and at exit: messages sent per type, signing counters).
stdin: `stats`, `quit`, `send_unsigned ROLL` (one unsigned ATTITUDE with that roll, then signing
resumes: an attacker without the key), `send_badsig ROLL` (one signed with a wrong key), `pause S`
(stop sending anything, heartbeats too, for S seconds: a lost link).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import select
import sys
import time

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402

DEFAULT_US = {30: 20_000, 33: 100_000}  # ATTITUDE 50 Hz, GLOBAL_POSITION_INT 10 Hz
# The parameter table: a full-length (16-character) name among them, as ArduPilot has.
PARAMS = {"SYSID_THISMAV": 1.0, "WPNAV_SPEED_DN_X": 150.0, **{f"TEST_P{i:02d}": float(i) for i in range(18)}}


def emit(obj: dict) -> None:
    sys.stdout.write(json.dumps(obj, separators=(",", ":")) + "\n")
    sys.stdout.flush()


def read_key(path: str) -> bytes:
    for line in open(path, encoding="ascii"):
        line = line.split("#", 1)[0].strip()
        if line:
            return bytes.fromhex(line)
    raise SystemExit(f"{path}: no key")


class PtyConn:
    """The master end of a pseudo-terminal as a mavutil-like connection (what the main loop uses of one)."""

    def __init__(self, sysid: int, compid: int) -> None:
        import tty

        self.fd, slave = os.openpty()
        tty.setraw(slave)  # 8N1 raw bytes, as ub_serial sets its end too
        self.device = os.ttyname(slave)
        self.slave = slave  # kept open: the pair lives while one end is open
        os.set_blocking(self.fd, False)
        self.mav = mavutil.mavlink.MAVLink(self, srcSystem=sysid, srcComponent=compid)
        self.mav.robust_parsing = True  # as mavutil's own connections: line noise is BAD_DATA, not an exception
        # The main loop sends only while `conn.port` is set: from the bridge's first bytes on (as udpin waits
        # for a client), so nothing piles up in the pty before the bridge reads and no write is cut short.
        self.port = None
        self.pending: list = []
        self.dropped = 0  # messages the pty did not take whole

    def write(self, buf: bytes) -> None:
        try:
            n = os.write(self.fd, buf)
        except BlockingIOError:
            n = 0  # the bridge is not reading: a real serial line would drop it too
        if n < len(buf):
            self.dropped += 1

    def recv_msg(self):
        if not self.pending:
            try:
                data = os.read(self.fd, 4096)
            except (BlockingIOError, OSError):
                data = b""
            if data:
                self.port = self
            self.pending = self.mav.parse_buffer(data) or [] if data else []
        return self.pending.pop(0) if self.pending else None


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--port", type=int, required=True)
    ap.add_argument("--sysid", type=int, default=1)
    ap.add_argument("--compid", type=int, default=1)
    ap.add_argument("--key")
    ap.add_argument("--tcp", action="store_true", help="listen for one TCP connection (as SITL's 5760) instead of udpin")
    ap.add_argument("--pty", action="store_true", help="a serial autopilot on a pseudo-terminal (its path in ready)")
    ap.add_argument("--duration", type=float, default=120.0)
    args = ap.parse_args()

    kind = "tcpin" if args.tcp else "udpin"
    if args.pty:
        conn = PtyConn(args.sysid, args.compid)
    else:
        conn = mavutil.mavlink_connection(f"{kind}:127.0.0.1:{args.port}", source_system=args.sysid,
                                          source_component=args.compid, dialect="common")
    mav = conn.mav
    key = read_key(args.key) if args.key else None
    if key:
        mav.signing.secret_key = key
        mav.signing.sign_outgoing = True
        mav.signing.allow_unsigned_callback = None
        mav.signing.timestamp = int((time.time() - 1420070400) * 100000)
        mav.signing.link_id = 0
    m = mavutil.mavlink
    start = time.monotonic()
    interval_us = dict(DEFAULT_US)
    next_due = {msgid: start for msgid in interval_us}
    next_hb = start
    sent: dict[str, int] = {}
    commands = 0
    paused_until = 0.0
    param_table = dict(PARAMS)
    param_table["SYSID_THISMAV"] = float(args.sysid)
    names = list(param_table)
    greeted = False
    missions: dict[int, list] = {}  # mission type -> items (MISSION_ITEM_INT messages)
    upload: dict = {}  # the upload in progress: type, count, items, peer
    emit({"event": "ready", "pid": os.getpid(), "port": args.port, "signing": key is not None,
          "device": getattr(conn, "device", None)})

    def boot_ms() -> int:
        return int((time.monotonic() - start) * 1000)

    def send(msg: object) -> None:
        peer = conn.port is not None if (args.tcp or args.pty) else conn.clients
        if time.monotonic() < paused_until or not peer:
            return
        mav.send(msg)
        name = msg.get_type()  # type: ignore[attr-defined]
        sent[name] = sent.get(name, 0) + 1

    def stream(msgid: int) -> object:
        t = time.monotonic() - start
        if msgid == 30:
            return m.MAVLink_attitude_message(boot_ms(), 0.1 * math.sin(t), 0.05 * math.cos(t), t % 6.28, 0.1, 0.2, 0.3)
        return m.MAVLink_global_position_int_message(boot_ms(), 473977420 + int(t * 100), 85455940, 500000, 20000,
                                                     100, -50, 0, 9000)

    def stats() -> dict:
        s = {"event": "stats", "sent": sent, "commands": commands, "intervals": {str(k): v for k, v in interval_us.items()},
             "pty_dropped": getattr(conn, "dropped", 0)}
        if key:
            g = mav.signing
            s["signing"] = {"goodsig": g.goodsig_count, "badsig": g.badsig_count, "unsigned": g.unsigned_count,
                            "reject": g.reject_count}
        return s

    def one_off(roll: float, good_key: bool) -> None:
        """One ATTITUDE unsigned (good_key False and no key argument) or signed with a wrong key."""
        saved = (mav.signing.secret_key, mav.signing.sign_outgoing)
        if good_key is False and key is not None:
            mav.signing.sign_outgoing = False
        else:
            mav.signing.secret_key = bytes(32)
            mav.signing.sign_outgoing = True
        mav.send(m.MAVLink_attitude_message(boot_ms(), roll, 0, 0, 0, 0, 0))
        mav.signing.secret_key, mav.signing.sign_outgoing = saved

    end = start + args.duration
    stdin_buf = ""
    while time.monotonic() < end:
        now = time.monotonic()
        wake = min([next_hb] + [t for k, t in next_due.items() if interval_us[k] > 0])
        fd = conn.fd  # tcpin: the listening socket until the bridge connects, then the connection
        r, _, _ = select.select([fd, sys.stdin], [], [], max(0.0, min(wake - now, 0.05)))
        if sys.stdin in r:
            chunk = os.read(sys.stdin.fileno(), 4096).decode()
            if not chunk:
                break
            stdin_buf += chunk
            while "\n" in stdin_buf:
                line, stdin_buf = stdin_buf.split("\n", 1)
                words = line.split()
                if not words:
                    continue
                if words[0] == "quit":
                    end = 0
                elif words[0] == "stats":
                    emit(stats())
                elif words[0] == "send_unsigned":
                    one_off(float(words[1]), good_key=False)
                elif words[0] == "send_badsig":
                    one_off(float(words[1]), good_key=True)
                elif words[0] == "statustext":
                    send(m.MAVLink_statustext_message(m.MAV_SEVERITY_INFO, " ".join(words[1:]).encode()[:50]))
                elif words[0] == "pause":
                    paused_until = time.monotonic() + float(words[1])
        if fd in r:
            while True:
                msg = conn.recv_msg()
                if msg is None:
                    break
                kind = msg.get_type()

                def param_value(name: str) -> None:
                    send(m.MAVLink_param_value_message(name.encode(), param_table[name], m.MAV_PARAM_TYPE_REAL32,
                                                       len(names), names.index(name)))

                if not greeted and kind == "HEARTBEAT":
                    greeted = True
                    send(m.MAVLink_statustext_message(m.MAV_SEVERITY_INFO, f"vehicle {args.sysid} ready".encode()))
                if kind in ("PARAM_REQUEST_LIST", "PARAM_REQUEST_READ", "PARAM_SET") and \
                        msg.target_system not in (0, args.sysid):
                    continue
                if kind == "PARAM_REQUEST_LIST":
                    emit({"event": "param_list", "from": [msg.get_srcSystem(), msg.get_srcComponent()]})
                    for name in names:
                        param_value(name)
                    continue
                if kind == "PARAM_REQUEST_READ":
                    pid = msg.param_id if isinstance(msg.param_id, str) else msg.param_id.decode()
                    name = names[msg.param_index] if 0 <= msg.param_index < len(names) else pid
                    if name in param_table:
                        param_value(name)
                    continue
                if kind == "PARAM_SET":
                    pid = msg.param_id if isinstance(msg.param_id, str) else msg.param_id.decode()
                    if pid in param_table:
                        param_table[pid] = msg.param_value
                        emit({"event": "param_set", "name": pid, "value": msg.param_value})
                        param_value(pid)
                    continue
                if kind.startswith("MISSION_") and getattr(msg, "target_system", args.sysid) not in (0, args.sysid):
                    continue
                mtype = getattr(msg, "mission_type", 0)
                peer = (msg.get_srcSystem(), msg.get_srcComponent())
                if kind == "MISSION_COUNT":
                    upload = {"type": mtype, "count": msg.count, "items": [], "peer": peer}
                    if msg.count == 0:
                        missions[mtype] = []
                        send(m.MAVLink_mission_ack_message(*peer, m.MAV_MISSION_ACCEPTED, mtype))
                    else:
                        send(m.MAVLink_mission_request_int_message(*peer, 0, mtype))
                    continue
                if kind in ("MISSION_ITEM_INT", "MISSION_ITEM") and upload and msg.seq == len(upload["items"]):
                    upload["items"].append(msg)
                    if len(upload["items"]) < upload["count"]:
                        send(m.MAVLink_mission_request_int_message(*peer, len(upload["items"]), mtype))
                    else:
                        missions[upload["type"]] = upload["items"]
                        emit({"event": "mission", "what": "uploaded", "type": upload["type"], "from": list(peer),
                              "items": [[i.seq, i.command, i.x, i.y, i.z] for i in upload["items"]]})
                        send(m.MAVLink_mission_ack_message(*peer, m.MAV_MISSION_ACCEPTED, mtype))
                        upload = {}
                    continue
                if kind == "MISSION_REQUEST_LIST":
                    send(m.MAVLink_mission_count_message(*peer, len(missions.get(mtype, [])), mtype))
                    continue
                if kind in ("MISSION_REQUEST_INT", "MISSION_REQUEST"):
                    items = missions.get(mtype, [])
                    if 0 <= msg.seq < len(items):
                        i = items[msg.seq]
                        x, y = (i.x, i.y) if i.get_type() == "MISSION_ITEM_INT" else (i.x * 1e7, i.y * 1e7)
                        send(m.MAVLink_mission_item_int_message(*peer, i.seq, i.frame, i.command, int(i.seq == 0),
                                                                i.autocontinue, i.param1, i.param2, i.param3, i.param4,
                                                                int(x), int(y), i.z, mtype))
                    else:
                        send(m.MAVLink_mission_ack_message(*peer, m.MAV_MISSION_INVALID_SEQUENCE, mtype))
                    continue
                if kind == "MISSION_CLEAR_ALL":
                    missions[mtype] = []
                    emit({"event": "mission", "what": "cleared", "type": mtype, "from": list(peer)})
                    send(m.MAVLink_mission_ack_message(*peer, m.MAV_MISSION_ACCEPTED, mtype))
                    continue
                if kind not in ("COMMAND_LONG", "COMMAND_INT"):
                    continue
                commands += 1
                params = [msg.param1, msg.param2, msg.param3, msg.param4]
                emit({"event": "command", "command": msg.command, "params": params,
                      "from": [msg.get_srcSystem(), msg.get_srcComponent()],
                      "target": [msg.target_system, msg.target_component],
                      "signed": bool(getattr(msg, "_signed", False))})
                result = m.MAV_RESULT_ACCEPTED
                if msg.command == m.MAV_CMD_SET_MESSAGE_INTERVAL:
                    msgid, us = int(msg.param1), int(msg.param2)
                    if msgid in DEFAULT_US:
                        interval_us[msgid] = DEFAULT_US[msgid] if us == 0 else (0 if us < 0 else us)
                        next_due[msgid] = time.monotonic()
                        emit({"event": "interval", "msgid": msgid, "requested_us": us, "interval_us": interval_us[msgid]})
                    else:
                        result = m.MAV_RESULT_UNSUPPORTED
                send(m.MAVLink_command_ack_message(msg.command, result, 0, 0, msg.get_srcSystem(), msg.get_srcComponent()))
        now = time.monotonic()
        if now >= next_hb:
            send(m.MAVLink_heartbeat_message(m.MAV_TYPE_QUADROTOR, m.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 0,
                                             m.MAV_STATE_ACTIVE, 3))
            next_hb += 1.0
        for msgid, us in interval_us.items():
            if us > 0 and now >= next_due[msgid]:
                send(stream(msgid))
                next_due[msgid] += us / 1e6
                if next_due[msgid] < now:  # behind (a stall): no burst
                    next_due[msgid] = now + us / 1e6
    emit(stats())
    return 0


if __name__ == "__main__":
    sys.exit(main())
