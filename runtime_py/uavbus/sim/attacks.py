"""Issue 11's attacks, replayed against a running Table 2 (the paper's HITL network on 127.0.0.1).

    h = Hitl(attack_options(program, config=signed_config(TABLE2, tmp)))   # + the tap: start_with_tap()
    campaign = Campaign(h, tap)
    campaign.start_flows()
    results = campaign.run()            # every attack; or run(["forged gpsOut to the GCS", ...])
    [r.as_json() for r in results]      # {"name", "sent", "accepted", "dropped_as"} (make demo's summary.json)

The attacker is the one of the issue: it is in range of the gcs1 <-> rmax1ob1 UDP datalink (a `UdpTap`
that records every datagram and injects with the source address each end expects: spoofed UDP source),
may send from an address of its own, and may connect to rmax1ob2's TCP port. It knows the wire format
and the catalogue, reads what is sent in clear (e.g. request ids), and holds no key: it forges frames
unsigned, signed with a key it guessed, or naming a key id nobody has, and it replays what it recorded.

**What each attack counts.** The legitimate streams cross the same links as the attack, so nothing is
inferred from rates alone. `dropped_as` is what the victim node counted, by reason, on the link the
attack came in on, between the moments just before and after the attack. The GCS listens on its UDP
datalink only (`attack_options()`), so no frame reaches it, or rmax1ob1 from it, twice over the parallel
link: with no legitimate duplicates, every drop on those links during an attack is the attack's own.
`accepted` = frames sent minus frames dropped, and at least what the effect shows (a value that
landed, a row that appeared or vanished, a message delivered twice, a connection taken over): with
signing on every attack must show 0 for both; with signing off the same accounting shows what got in.
"""

from __future__ import annotations

import os
import socket
import struct
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from uavbus._bindings import ub_sec
from uavbus.sim.attacker import UdpTap, forge, insert_udp_tap, tcp_connect
from uavbus.sim.hitl import Hitl, HitlOptions

__all__ = ["ATTACKS", "SHORT_ATTACKS", "LOCKOUT", "LOCKOUT_COUNTER", "AttackResult", "Campaign", "attack_options",
           "start_with_tap"]

DATA, PUB_REQUEST, PUB_STOP, NACK = 0, 1, 3, 6     # admin codes (ub_frame.h)
NACK_TABLE_FULL = 3
MAGIC = b"\x5a\xa5" * 4                   # marks every forged value
MODES = (("unsigned", {}), ("signed", {"key": None}), ("signed", {"key_id": 77}))   # no tag; a guessed key; key id 77
GPS_MS, IMU_MS, NAV_MS = 100, 20, 50
UDP_LINK = {"gcs": "gcsPortDatalink1", "primary": "onboardPortDatalink1"}   # the tapped datalink's two ends
TCP_LINK = ("secondary", "onboard2PortIPC")
HOSTED = ("gpsOut", "navFilterState", "imuOutPrimary", "onboardSet")        # what rmax1ob1 produces or binds
ENTITY = {"gcs": "gcs1", "primary": "rmax1ob1", "secondary": "rmax1ob2", "backup": "fcs20"}

# The attacks in the order they run (names as in issue 11); SHORT_ATTACKS: `make demo --short` (in make test).
ATTACKS = (
    "forged admin request (spoofed UDP source)",
    "forged write: armed = 1",
    "forged write: controller gains",
    "forged write: datum",
    "forged write: waypoint",
    "forged gpsOut to the GCS",
    "forged NACK",
    "forged STOP",
    "pre-sent sequence numbers",
    "table exhaustion (40 requests)",
    "1 ms amplification (1 request)",
    "1 ms amplification (30 requests)",
    "datagrams from an unknown UDP source",
    "replay of recorded frames",
    "TCP takeover",
    "replay after a restart of both ends",
)
# Issue 23's lockout, by an insider who holds the group key (a captured vehicle): not one of ATTACKS (whose
# attacker holds no key), run by Campaign.insider_lockout() with the fleet's key file.
LOCKOUT = "lockout: one frame in fcs20's name, counter 2^48-2, group key"
LOCKOUT_COUNTER = (1 << 48) - 2
SHORT_ATTACKS = ("forged admin request (spoofed UDP source)", "forged write: armed = 1", "forged gpsOut to the GCS",
                 "forged NACK", "1 ms amplification (1 request)", "replay of recorded frames")


def attack_options(program: Path | None, config: Path, **kw: Any) -> HitlOptions:
    """Table 2 as the attacks need it: the GCS on its UDP datalink only (every frame it gets crosses the
    tap, and none twice), with storage for onboardSet too (what the forged admin request would make a
    vehicle stream to it: delivered, so seen, and not dropped as unbound); rmax1ob1 with a configured
    publication of its own (navFilterState to rmax1ob2 over TCP: the vehicle's own row of the forged STOP)."""
    node_args = {"primary": ["--publish", "rmax1ob1:navFilterState>rmax1ob2/100"]}
    binds = ("gpsOut", "imuOut", "navFilterState", "onboardSet")
    return HitlOptions(program=program, config=config, gcs_links=(UDP_LINK["gcs"],), gcs_binds=binds,
                       node_args=node_args, **kw)


def start_with_tap(opts: HitlOptions) -> tuple[Hitl, UdpTap]:
    """Starts Table 2 with the attacker's tap on the gcs1 <-> rmax1ob1 UDP datalink. Close both."""
    h = Hitl(opts)
    taps: list[UdpTap] = []

    def tap_datalink(topo: Any) -> None:
        for t in taps:              # a retried start (ports taken meanwhile): a new tap for the new ports
            t.close()
        taps.clear()
        taps.append(insert_udp_tap(topo, ("gcs", UDP_LINK["gcs"]), ("primary", UDP_LINK["primary"]), h.alloc))

    h.on_topology = tap_datalink
    try:
        h.start()
    except BaseException:
        h.close()
        for t in taps:
            t.close()
        raise
    return h, taps[0]


@dataclass
class AttackResult:
    name: str
    sent: int
    accepted: int
    dropped_as: dict[str, int]
    effect: str                      # what would show had it worked, and what showed
    at: str = ""                     # where it was counted ("rmax1ob1:onboardPortDatalink1", ...)
    extra: dict[str, Any] = field(default_factory=dict)

    def as_json(self) -> dict[str, Any]:
        return {"name": self.name, "sent": self.sent, "accepted": self.accepted, "dropped_as": self.dropped_as,
                "counted_at": self.at, "effect": self.effect}

    def line(self) -> str:
        drops = ", ".join(f"{k} {v}" for k, v in sorted(self.dropped_as.items())) or "nothing"
        return f"sent {self.sent}, accepted {self.accepted}, dropped as {drops} (at {self.at}); {self.effect}"


def _payload(frame: bytes) -> bytes:
    return frame[64:64 + int.from_bytes(frame[50:52], "little")]


def _src(frame: bytes) -> str:
    return frame[36:48].rstrip(b"\0").decode("ascii", "replace")


def _dest(frame: bytes) -> str:
    return frame[24:36].rstrip(b"\0").decode("ascii", "replace")


def _counter(frame: bytes) -> int:
    flags = frame[3] & 0xF0
    trailer = {0x10: 11, 0x20: 19, 0x90: 20, 0xA0: 28}.get(flags, 0)  # with ORIGIN (0x80): + the 9-byte block
    hi = int.from_bytes(frame[len(frame) - trailer + 1:len(frame) - trailer + 3], "little") if trailer else 0
    return hi << 32 | int.from_bytes(frame[52:56], "little")


class Campaign:
    """Runs the attacks against `h` (started with `start_with_tap()`, options from `attack_options()`)."""

    def __init__(self, h: Hitl, tap: UdpTap, say: Callable[[str], None] | None = None) -> None:
        self.h, self.tap = h, tap
        self.cat = h.gcs.catalogue
        self.say = say or (lambda _s: None)
        self.rows: dict[str, int] = {}
        self.guessed = os.urandom(32)
        self.results: list[AttackResult] = []
        self.phases: list[tuple[str, float, float]] = []   # (label, t0, t1): windows the rates are judged over
        self._counter = 10**12                          # counters of forged frames: far ahead of anything real

    # ---- the legitimate traffic -------------------------------------------------------------------------
    def start_flows(self, timeout: float = 8.0) -> None:
        """The paper's two tests from gcs1's administration table (gpsOut 10 Hz, 1 hop; imuOut 50 Hz, 2 hops)
        and navFilterState from rmax1ob2 (20 Hz, over the TCP link); returns once all three flow."""
        h = self.h
        self.rows = {"gps": h.add_row("publication", "gpsOut", "rmax1ob1", "gcs1", GPS_MS),
                     "imu": h.add_row("subscription", "imuOut", "fcs20", "gcs1", IMU_MS),
                     "nav": h.add_row("subscription", "navFilterState", "rmax1ob2", "gcs1", NAV_MS)}
        for row in self.rows.values():
            h.wait_status(row, "active", timeout)
        since = time.monotonic()
        for name, source in (("gpsOut", "rmax1ob1"), ("imuOut", "fcs20"), ("navFilterState", "rmax1ob2")):
            h.wait_data(name, source, 3, 5.0, since=since)

    def rates(self, t0: float, t1: float) -> dict[str, float]:
        """Achieved rates (Hz) at gcs1 in [t0, t1): gpsOut (10 Hz requested) and imuOut (50 Hz)."""
        return {"gpsOut": self.h.meter("gpsOut", "rmax1ob1").rate_hz(t0, t1),
                "imuOut": self.h.meter("imuOut", "fcs20").rate_hz(t0, t1)}

    def sent_rates(self, t0: float, t1: float) -> dict[str, float]:
        """The same streams' rates by what their sources stamped in [t0, t1] and gcs1 got (`sent_rate_hz`):
        for a short window opened right after the harness waited (a lockout's 3 s), where a stall of this
        process across its start would hand frames sent before it over inside it (a CI run of 2026-11-27: 55.5 Hz)."""
        return {"gpsOut": self.h.meter("gpsOut", "rmax1ob1").sent_rate_hz(t0, t1),
                "imuOut": self.h.meter("imuOut", "fcs20").sent_rate_hz(t0, t1)}

    # ---- observing the victims --------------------------------------------------------------------------
    def _stats(self, node: str) -> dict[str, Any]:
        if node == "gcs":
            return {"links": self.h.gcs.link_counters()}
        return self.h.child_stats(node)

    def _snap(self, *nodes: str) -> dict[str, dict[str, Any]]:
        return {n: self._stats(n) for n in nodes}

    @staticmethod
    def _drops(stats: dict[str, Any], link: str) -> dict[str, int]:
        return {k: int(v) for k, v in stats["links"][link]["drops"].items()}

    def _dropped(self, before: dict[str, dict[str, Any]], after: dict[str, dict[str, Any]],
                 where: list[tuple[str, str]]) -> dict[str, int]:
        out: dict[str, int] = {}
        for node, link in where:
            b, a = self._drops(before[node], link), self._drops(after[node], link)
            for reason, n in a.items():
                if n - b.get(reason, 0) > 0:
                    out[reason] = out.get(reason, 0) + n - b.get(reason, 0)
        return out

    def _dump(self, node: str, content: str) -> bytes:
        proc = self.h.group[node]
        m = proc.mark()
        proc.send(f"dump {content}")
        return bytes.fromhex(self.h.child_event(node, "dump", 3.0, since=m)["packed"])

    def _pubsub(self, node: str, stats: dict[str, Any] | None = None) -> list[dict[str, Any]]:
        s = stats or self._stats(node)
        return [r for rows in s["pubsub"].values() for r in rows]

    # ---- forging ----------------------------------------------------------------------------------------
    def _forms(self, content: str | None, src: str, dest: str, payload: bytes, admin: int = DATA,
               counter: int | None = None) -> list[bytes]:
        """The same frame in the three forms an attacker without the key can make."""
        out = []
        for mode, kw in MODES:
            if counter is None:
                self._counter += 1
            c = counter if counter is not None else self._counter
            args = {k: (self.guessed if k == "key" and v is None else v) for k, v in kw.items()}
            out.append(forge(self.cat, content, src, dest, payload, admin=admin, counter=c, mode=mode, **args))
        return out

    def _request(self, content: str, peer: str, period_ms: int, lease_ms: int = 0, rid: int = 1,
                 code: int = PUB_REQUEST, src: str = "gcs1", dest: str = "rmax1ob1") -> list[bytes]:
        payload = struct.pack("<III12s", rid, period_ms, lease_ms, peer.encode().ljust(12, b"\0"))
        return self._forms(content, src, dest, payload, admin=code)

    def _value(self, content: str, **fields: Any) -> bytes:
        value = self.cat.default(content)
        value.update(fields)
        return self.cat.encode(content, value)

    def _settle(self, seconds: float = 0.3) -> None:
        self.h.run_for(seconds)

    def _result(self, name: str, sent: int, dropped: dict[str, int], effect_count: int, effect: str,
                where: list[tuple[str, str]]) -> AttackResult:
        accepted = max(sent - sum(dropped.values()), effect_count, 0)
        at = ", ".join(f"{ENTITY[n]}:{link}" for n, link in where)
        r = AttackResult(name, sent, accepted, dropped, effect, at)
        self.results.append(r)
        return r

    def _forgery(self, name: str, frames: list[bytes], direction: str, effect: Callable[[], tuple[int, str]],
                 settle: float = 0.3) -> AttackResult:
        """Injects forged frames toward one end of the datalink and accounts for them there."""
        node = "primary" if direction == "a>b" else "gcs"
        where = [(node, UDP_LINK[node])]
        before = self._snap(node)
        for k in range(0, len(frames), 30):
            self.tap.inject(direction, *frames[k:k + 30])
            self.h.run_for(0.02)
        self._settle(settle)
        after = self._snap(node)
        n, what = effect()
        return self._result(name, len(frames), self._dropped(before, after, where), n, what, where)

    # ---- the attacks ------------------------------------------------------------------------------------
    def _forged_admin_request(self, name: str) -> AttackResult:
        # The issue's first attack: rmax1ob1 told (as gcs1, from gcs1's UDP address) to stream onboardSet
        # over the datalink the attacker listens on.
        frames = self._request("onboardSet", "gcs1", 100, rid=0x1234)
        mark = len(self.h.messages)

        def effect() -> tuple[int, str]:
            rows = [r for r in self._pubsub("primary") if r["content"] == "onboardSet"]
            got = sum(1 for _t, n, *_x in self.h.messages[mark:] if n == "onboardSet")
            return len(rows), f"rows streaming onboardSet at rmax1ob1: {len(rows)} (onboardSet frames on the link: {got})"
        return self._forgery(name, frames, "a>b", effect)

    def _forged_write(self, name: str) -> AttackResult:
        targets: list[tuple[str, str, str, bytes]]   # (node, entity, content, forged value)
        if name.endswith("armed = 1"):
            targets = [("primary", "rmax1ob1", "onboardSet", self._value("onboardSet", armed=True)),
                       ("backup", "fcs20", "fcsSet", self._value("fcsSet", armed=True))]   # 2 hops, via rmax1ob1
        elif name.endswith("controller gains"):
            gains = [[9.5, -9.5, 9.5]] * 4
            targets = [("primary", "rmax1ob1", "onboardSet", self._value("onboardSet", controllerGains=gains))]
        elif name.endswith("datum"):
            datum = {"latitudeDeg": -33.86, "longitudeDeg": 151.2, "altitudeMsl": 4000.0, "magneticVariationDeg": 12}
            targets = [("primary", "rmax1ob1", "onboardSet", self._value("onboardSet", datum=datum))]
        else:
            wp = {"latitudeDeg": 51.5, "longitudeDeg": -0.12, "altitudeMsl": 10.0, "speed": 40.0, "valid": 1}
            targets = [("primary", "rmax1ob1", "gcsMissionRmax1[0]", self._value("gcsMissionRmax1[0]", **wp))]
        before = {(node, content): self._dump(node, content) for node, _e, content, _v in targets}
        frames = [f for _n, entity, content, value in targets for f in self._forms(content, "gcs1", entity, value)]

        def effect() -> tuple[int, str]:
            changed = [f"{ENTITY[node]}.{content}" for node, _e, content, _v in targets
                       if self._dump(node, content) != before[(node, content)]]
            return len(changed), ("written: " + ", ".join(changed) if changed else
                                  "directories unchanged: " + ", ".join(f"{e}.{c}" for _n, e, c, _v in targets))
        return self._forgery(name, frames, "a>b", effect)

    def _forged_gps(self, name: str) -> AttackResult:
        # An image the receiver's codec accepts, as an attacker would craft it: unpack refuses bool bytes
        # other than 0/1 and bitfields out of width (docs/catalogue.md), so those bytes stay zero.
        t = self.cat.instance("gpsOut").type
        image = bytearray((MAGIC * (t.packed_size // len(MAGIC) + 1))[:t.packed_size])
        for offset, width in t.refusable:
            image[offset:offset + width] = bytes(width)
        evil = bytes(image)
        frames = [f for _ in range(5) for f in self._forms("gpsOut", "rmax1ob1", "gcs1", evil)]
        mark = len(self.h.messages)

        def effect() -> tuple[int, str]:
            shown = sum(1 for *_x, raw in self.h.messages[mark:] if MAGIC in raw)
            return shown, f"false positions delivered to gcs1: {shown}"
        return self._forgery(name, frames, "b>a", effect)

    def _request_ids(self) -> dict[tuple[str, str], int]:
        """(content, target) -> request id, read off the datalink (gcs1's requests are sent in clear)."""
        ids: dict[tuple[str, str], int] = {}
        for f in self.tap.frames("a>b", admin=PUB_REQUEST):
            if _src(f) == "gcs1" and f[3] & 0x20 == 0:
                inst = self.cat.find(bytes(f[8:24]))
                if inst is not None:
                    ids[(inst.name, _dest(f))] = int.from_bytes(_payload(f)[:4], "little")
        return ids

    def _forged_nack(self, name: str) -> AttackResult:
        ids = self._request_ids()
        frames = []
        for content, target, code in (("gpsOut", "rmax1ob1", PUB_REQUEST), ("imuOut", "fcs20", PUB_REQUEST)):
            for rid in [*range(1, 9), ids.get((content, target), 0)]:
                payload = struct.pack("<IBBH", rid, code, NACK_TABLE_FULL, 0)
                frames += self._forms(content, target, "gcs1", payload, admin=NACK)

        def effect() -> tuple[int, str]:
            st = {k: self.h.admin.status(self.rows[k]) for k in ("gps", "imu")}
            failed = [k for k, s in st.items() if s["status"] != "active" or s.get("nack_reason")]
            return len(failed), ("GCS rows failed: " + ", ".join(failed) if failed else
                                 f"GCS rows active (request ids read off the radio: {len(ids)})")
        return self._forgery(name, frames, "b>a", effect)

    def _forged_stop(self, name: str) -> AttackResult:
        ids = self._request_ids()
        frames = (self._forms("gpsOut", "gcs1", "rmax1ob1",
                              struct.pack("<I12s", ids.get(("gpsOut", "rmax1ob1"), 0), b"gcs1".ljust(12, b"\0")),
                              admin=PUB_STOP)
                  + self._forms("navFilterState", "rmax1ob2", "rmax1ob1",
                                struct.pack("<I12s", 0, b"rmax1ob2".ljust(12, b"\0")), admin=PUB_STOP))

        def rows_now() -> set[tuple[str, str]]:
            return {(r["content"], r.get("destination", "")) for r in self._pubsub("primary")
                    if r["kind"] == "publication"}
        before = rows_now()
        wanted = {("gpsOut", "gcs1"), ("navFilterState", "rmax1ob2")}

        def effect() -> tuple[int, str]:
            gone = sorted(f"{c}->{d}" for c, d in (wanted & before) - rows_now())
            return len(gone), ("rows removed at rmax1ob1: " + ", ".join(gone) if gone else
                               "rmax1ob1 kept gpsOut->gcs1 and its configured navFilterState->rmax1ob2")
        return self._forgery(name, frames, "a>b", effect)

    def _pre_sent(self, name: str) -> AttackResult:
        # fcs20's next 64 counters, pre-sent to the forwarder rmax1ob1 (the issue's "70 genuine frames").
        genuine = [f for f in self.tap.frames("b>a") if _src(f) == "fcs20" and f[48] == DATA]
        last = max((_counter(f) for f in genuine), default=0)
        payload = _payload(genuine[-1]) if genuine else bytes(self.cat.instance("imuOut").type.packed_size)
        frames = [f for k in range(1, 65) for f in self._forms("imuOut", "fcs20", "gcs1", payload, counter=last + 3 + k)]
        relay = ("primary", "onboardPortRelay")
        before_relay = self._snap("primary")
        t0 = time.monotonic()
        r = self._forgery(name, frames, "a>b", lambda: (0, ""), settle=0.6)
        after_relay = self._snap("primary")
        lost = sum(self._dropped(before_relay, after_relay, [relay]).values())
        imu = self.h.meter("imuOut", "fcs20").rate_hz(t0, time.monotonic())
        r.accepted = max(r.accepted, lost)
        r.effect = f"genuine fcs20 frames dropped at the forwarder: {lost}; imuOut at gcs1 {imu:.1f} Hz"
        return r

    def _exhaustion(self, name: str) -> AttackResult:
        peers = ["gcs1", "rmax1ob2", "fcs20", *(f"ghost{k}" for k in range(7))]
        reqs = [(c, p) for p in peers for c in HOSTED][:40]
        frames = [f for k, (c, p) in enumerate(reqs) for f in self._request(c, p, 1000, 0, rid=0x5000 + k)][:120]
        n_before = len(self._pubsub("primary"))

        def effect() -> tuple[int, str]:
            grown = len(self._pubsub("primary")) - n_before
            # the administrator still gets a row at rmax1ob1 (navFilterState, 10 Hz, to gcs1)
            row = self.h.add_row("publication", "navFilterState", "rmax1ob1", "gcs1", 100)
            try:
                self.h.wait_status(row, "active", 3.0)
                served = "the administrator's new row is active"
            except TimeoutError:
                served = f"the administrator's new row is {self.h.admin.status(row)}"
            self.h.admin.deactivate(row)
            self.h.run_for(0.3)
            return max(grown, 0) + (0 if served.endswith("active") else 1), f"rows added at rmax1ob1: {grown}; {served}"
        r = self._forgery(name, frames, "a>b", effect)
        r.extra["requests"] = len(frames) // len(MODES)
        return r

    def _amplification(self, name: str) -> AttackResult:
        many = "30" in name
        targets = [(c, p) for p in ("gcs1", "rmax1ob2", "fcs20", *(f"sink{k}" for k in range(6))) for c in HOSTED]
        reqs = targets[:30] if many else [("imuOutPrimary", "gcs1")]
        frames = [f for k, (c, p) in enumerate(reqs) for f in self._request(c, p, 1, 0, rid=0x7000 + k)]
        t_before = time.monotonic()
        self.h.run_for(0.5)
        base = self._link_rate(t_before, time.monotonic())
        r = self._forgery(name, frames, "a>b", lambda: (0, ""), settle=0.5)
        self.h.run_for(0.7)                                  # the sender has left: is anything still running?
        t1 = time.monotonic()
        after = self._link_rate(t1 - 0.7, t1)
        fast = [x for x in self._pubsub("primary") if x["period_ms"] < 10]
        r.accepted = max(r.accepted, len(fast))
        r.effect = (f"rows at 1 ms: {len(fast)}; datalink toward gcs1 after the attacker left: {after / 1000:.1f} kB/s "
                    f"(before: {base / 1000:.1f} kB/s)")
        r.extra.update(bytes_per_s_before=base, bytes_per_s_after=after)
        return r

    def _link_rate(self, t0: float, t1: float) -> float:
        """Bytes/s the tap forwarded toward gcs1 in [t0, t1)."""
        return sum(len(d) for d in self.tap.frames("b>a", since=t0, until=t1)) / max(t1 - t0, 1e-3)

    def _foreign(self, name: str) -> AttackResult:
        node, link = "primary", UDP_LINK["primary"]
        assert self.h.topo is not None
        addr = self.h.topo.find(node, link).spec_b.split("bind=")[1].split(",")[0]
        host, port = addr.rsplit(":", 1)
        before = self._snap(node)
        frames = self._forms("onboardSet", "gcs1", "rmax1ob1", self._value("onboardSet", armed=True))
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            for f in frames:
                s.sendto(f, (host, int(port)))
        finally:
            s.close()
        self._settle(0.2)
        after = self._snap(node)
        foreign = after[node]["links"][link]["udp"]["foreign"] - before[node]["links"][link]["udp"]["foreign"]
        dropped = {"foreign": foreign} if foreign else {}
        dropped.update(self._dropped(before, after, [(node, link)]))
        return self._result(name, len(frames), dropped, 0, "refused by the UDP driver before the router (accept=peer)",
                            [(node, link)])

    def _replay(self, name: str) -> AttackResult:
        now = time.monotonic()
        down = self.tap.frames("b>a", until=now - 1.0)    # all received (and so seen) by their receivers
        up = self.tap.frames("a>b", until=now - 1.0)
        where = [("gcs", UDP_LINK["gcs"]), ("primary", UDP_LINK["primary"])]
        before = self._snap("gcs", "primary")
        mark = len(self.h.messages)
        for k in range(0, max(len(down), len(up)), 40):
            self.tap.inject("b>a", *down[k:k + 40])
            self.tap.inject("a>b", *up[k:k + 40])
            self.h.run_for(0.02)
        self._settle(0.4)
        after = self._snap("gcs", "primary")
        twice = self._delivered_twice(mark)
        return self._result(name, len(down) + len(up), self._dropped(before, after, where), twice,
                            f"messages delivered twice at gcs1: {twice}", where)

    def _delivered_twice(self, mark: int) -> int:
        seen = {(n, s, q) for _t, n, s, q, _r in self.h.messages[:mark]}
        return sum(1 for _t, n, s, q, _r in self.h.messages[mark:] if (n, s, q) in seen)

    def _tcp(self, name: str) -> AttackResult:
        node, link = TCP_LINK
        assert self.h.topo is not None
        listen = self.h.topo.find(node, link).spec_b.split("listen=")[1]
        before = self._snap(node)
        old = [f for f in self.tap.frames("b>a", until=time.monotonic() - 5.0) if _src(f) == "rmax1ob1"][:30]
        nav = self.cat.instance("navFilterState").type.packed_size
        forged = (self._forms("navFilterState", "rmax1ob1", "rmax1ob2", bytes(nav))
                  + self._forms("onboard2Set", "gcs1", "rmax1ob2", self._value("onboard2Set", armed=True)))
        # Three from one address: at most 2 unproven candidates per address, so the third evicts the first
        # (docs/security.md, "TCP links"); the two newest carry the attack.
        socks = [tcp_connect(listen) for _ in range(3)]
        try:
            self.h.run_for(0.1)
            socks[2].sendall(os.urandom(200))                       # junk first: the decoder resynchronises
            socks[2].sendall(b"".join(forged))
            socks[1].sendall(b"".join(old))
            self.h.run_for(1.5)
            after = self._snap(node)
        finally:
            for s in socks:
                s.close()
        t_b, t_a = before[node]["links"][link]["tcp"], after[node]["links"][link]["tcp"]
        taken = (t_a["replaced"] - t_b["replaced"]) + (t_a["adopted"] - t_b["adopted"])
        r = self._result(name, len(forged) + len(old), self._dropped(before, after, [(node, link)]), taken,
                         f"connections {t_a['candidates'] - t_b['candidates']} held as candidates, "
                         f"{t_a['candidates_refused'] - t_b['candidates_refused']} refused, "
                         f"{t_a['candidates_evicted'] - t_b['candidates_evicted']} evicted, taken over: {taken}; "
                         f"established link {t_a['state']}", [(node, link)])
        r.extra["connections"] = len(socks)
        return r

    def _restart_replay(self, name: str) -> AttackResult:
        h = self.h
        everything = (self.tap.frames("b>a"), self.tap.frames("a>b"))
        self.say("    (restarting rmax1ob1 and gcs1; the attacker keeps everything it recorded)")
        h.restart("primary")
        h.restart_gcs()
        self.start_flows()
        h.run_for(0.5)
        t0 = time.monotonic()
        where = [("gcs", UDP_LINK["gcs"]), ("primary", UDP_LINK["primary"])]
        before = self._snap("gcs", "primary")
        mark = len(h.messages)
        down, up = everything
        for k in range(0, max(len(down), len(up)), 40):
            self.tap.inject("b>a", *down[k:k + 40])
            self.tap.inject("a>b", *up[k:k + 40])
            h.run_for(0.02)
        self._settle(0.6)
        after = self._snap("gcs", "primary")
        h.run_for(1.5)                              # the rates after the restarts, over a window long enough
        self.phases.append(("after the restarts", t0, time.monotonic()))
        twice = self._delivered_twice(mark)
        return self._result(name, len(down) + len(up), self._dropped(before, after, where), twice,
                            f"messages delivered twice at gcs1: {twice}", where)

    # ---- an insider: the group key ------------------------------------------------------------------------
    def insider_lockout(self, key_file: Path, watch_s: float = 3.0) -> AttackResult:
        """Issue 23's lockout by a holder of the fleet key (a captured vehicle): ONE imuOut frame in fcs20's
        name, signed with the group key, counter 2^48-2, injected toward the forwarder rmax1ob1 (on fcs20's
        path to gcs1) and toward gcs1 itself. Before the jump bound it moved both windows past every counter
        fcs20 will ever use, silencing it for good; now each is dropped `counter_jump` (docs/security.md,
        "Lockout") and fcs20's imuOut keeps its rate. `accepted` counts the frame where it got in, plus 1 if
        imuOut at gcs1 fell below 90 % of its 50 Hz afterwards (the frames fcs20 stamped in the watch window
        that reached gcs1: `StreamMeter.sent_rate_hz`)."""
        key_id, key = ub_sec.ub_keyfile_load(str(key_file))
        genuine = [f for f in self.tap.frames("b>a") if _src(f) == "fcs20" and f[48] == DATA]
        payload = _payload(genuine[-1]) if genuine else bytes(self.cat.instance("imuOut").type.packed_size)
        frame = forge(self.cat, "imuOut", "fcs20", "gcs1", payload, counter=LOCKOUT_COUNTER, mode="signed", key=key,
                      key_id=key_id)
        where = [("primary", UDP_LINK["primary"]), ("gcs", UDP_LINK["gcs"])]
        before = self._snap("gcs", "primary")
        self.tap.inject("a>b", frame)          # to the forwarder rmax1ob1, as if from gcs1's side of the datalink
        self.tap.inject("b>a", frame)          # to gcs1, as if relayed by rmax1ob1
        self._settle(0.5)
        t0 = time.monotonic()
        self.h.run_for(watch_s)
        t1 = time.monotonic()
        after = self._snap("gcs", "primary")
        # What fcs20 sent in the window and gcs1 got, placed at fcs20's own timeTags: a harness that stalled
        # across t0 (the tap and the serial relay are its threads) hands over frames sent before t0 just
        # after it, which by receive instants read 55.5 Hz for 50 (metrics.py).
        rates = self.sent_rates(t0, t1)
        imu = rates["imuOut"]
        # a held backlog shows in the data age of what arrived in the window (the next such failure says where)
        late = sum(age > 100.0 for age in self.h.meter("imuOut", "fcs20").latencies(t0, t1))
        status = self.h.admin.status(self.rows["imu"])["status"] if "imu" in self.rows else "?"
        silenced = int(imu < 0.9 * 1000 / IMU_MS)
        dropped = self._dropped(before, after, where)
        # not in self.results: those are the keyless attacker's (run()'s list)
        r = AttackResult(LOCKOUT, 2, max(2 - sum(dropped.values()), silenced, 0), dropped,
                         f"imuOut from fcs20 at gcs1 over the next {watch_s:.0f} s: {imu:.1f} Hz "
                         f"({1000 / IMU_MS:.0f} requested{f'; {late} arrived > 100 ms after fcs20 stamped them' if late else ''}"
                         f"); GCS row {status}",
                         ", ".join(f"{ENTITY[n]}:{link}" for n, link in where))
        r.extra.update(imu_hz=imu, gps_hz=rates["gpsOut"], row_status=status, window=(t0, t1), imu_late=late)
        return r

    # ---- running ----------------------------------------------------------------------------------------
    def run(self, names: tuple[str, ...] | list[str] = ATTACKS, record_s: float = 4.5) -> list[AttackResult]:
        """Records traffic for `record_s`, then runs each attack in `names` (in ATTACKS order), printing one
        line each through `say`. Returns the results; self.phases holds the windows for the rate checks."""
        handlers: dict[str, Callable[[str], AttackResult]] = {
            ATTACKS[0]: self._forged_admin_request,
            **{n: self._forged_write for n in ATTACKS if n.startswith("forged write")},
            "forged gpsOut to the GCS": self._forged_gps, "forged NACK": self._forged_nack,
            "forged STOP": self._forged_stop, "pre-sent sequence numbers": self._pre_sent,
            "table exhaustion (40 requests)": self._exhaustion,
            "1 ms amplification (1 request)": self._amplification,
            "1 ms amplification (30 requests)": self._amplification,
            "datagrams from an unknown UDP source": self._foreign, "replay of recorded frames": self._replay,
            "TCP takeover": self._tcp, "replay after a restart of both ends": self._restart_replay,
        }
        unknown = set(names) - set(handlers)
        if unknown:
            raise ValueError(f"unknown attacks: {sorted(unknown)}")
        self.h.run_for(record_s)                            # the eavesdropper records first
        t0 = time.monotonic()
        for name in (n for n in ATTACKS if n in names):
            if name == "replay after a restart of both ends":
                self.phases.append(("under attack", t0, time.monotonic()))
            r = handlers[name](name)
            self.say(f"    {name}: {r.line()}")
        if "replay after a restart of both ends" not in names:
            self.phases.append(("under attack", t0, time.monotonic()))
        return self.results
