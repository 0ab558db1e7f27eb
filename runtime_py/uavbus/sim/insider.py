"""Issue 23's insider: a captured vehicle (rmax1ob2) that holds its own valid keys attacks Table 2.

    config = insider_config(out)                     # table2_policy + group key + an X25519 identity per entity
    h, tap = start_with_tap(insider_options(program, config))
    campaign = InsiderCampaign(h, tap, config)       # gcs1 (Python) gets origin authentication too
    campaign.start_flows()
    results = campaign.run()                         # INSIDER_ATTACKS, each an AttackResult (as uavbus.sim.attacks)
    campaign.revoke()                                # the operator cuts rmax1ob2 off: per-node refusal times

Unlike `uavbus.sim.attacks`' outsider, this attacker holds the fleet's group key (so every frame it forges
passes the hop tag at every forwarder) and rmax1ob2's own X25519 secret key (so it can make a right origin
tag for any frame *it* originates). It is in range of the gcs1 <-> rmax1ob1 UDP datalink (the same tap) and
forges each frame in the two forms it can make in another entity's name: origin-tagged under its own
pairwise key with the destination (`bad_origin` at the destination) and with no origin block
(`no_origin`). Accounting is the outsider campaign's: the victim's own drop counters, by reason, on the
link the attack came in on, between just before and just after the attack, plus the effect looked for.

What the threat model lets it do, and what the step counts as accepted by name: requests in its **own**
name within its quota (the policy's limits: `max_rows`, `min_period_ms`, `max_lease_ms`). Routing does not
run in Table 2 (static masks from the configuration), so route advertisements reach no routing engine:
the step says so instead of attacking one.

Origin authentication here uses the primitives that exist on main: `uavbus_node --origin-key
keys/{entity}.x25519 --origin-peers keys/peers.txt` for the C nodes and `node.security.enable_origin()` for
gcs1, whose lookup honours the operator's revocation; the C nodes' peers file is static, so until the
identity store answers their origin lookups (the config-driven identities) a revocation is refused at gcs1
only, and `revoke()` says which nodes refuse it.
"""

from __future__ import annotations

import struct
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from uavbus._bindings import ub_frame as uf
from uavbus._bindings import ub_node as un
from uavbus._bindings import ub_origin, ub_sec
from uavbus.sim.attacker import frame_header
from uavbus.sim.attacks import (DATA, IMU_MS, LOCKOUT_COUNTER, PUB_REQUEST, PUB_STOP, UDP_LINK, AttackResult, Campaign,
                                _counter, _src, attack_options)
from uavbus.sim.build import REPO
from uavbus.sim.hitl import HitlOptions
from uavbus.sim.secure import signed_config

__all__ = ["INSIDER_ATTACKS", "CAPTURED", "InsiderCampaign", "insider_config", "insider_options"]

CAPTURED = "rmax1ob2"
ENTITIES = ("gcs1", "rmax1ob1", "rmax1ob2", "fcs20")
TABLE2_POLICY = REPO / "examples" / "configs" / "table2_policy.json"
INSIDER_ATTACKS = (
    "as gcs1: admin request to rmax1ob1",
    "as gcs1: STOP of gcs1's gpsOut row",
    "as rmax1ob1 and fcs20: NACKs to gcs1",
    "as gcs1: write rmax1ob1's armed = 1 and a waypoint",
    "as itself: write rmax1ob1's armed = 1 and a waypoint",
    "as fcs20: forged imuOut to gcs1",
    "replay of frames it relayed",
    "routes for entities it does not own",
    "flood within its own quota (30 requests, 1 ms and 100 ms, no lease)",
    "lockout: one frame in each victim's name, counter 2^48-2",
)
FORMS = ("own pairwise key", "no origin block")


def insider_config(out: Path) -> Path:
    """Table 2 with its authorization policy, the group key (out/keys/fleet-1.key) and an X25519 identity per
    entity (out/keys/{entity}.x25519, mode 0600, made at run time; out/keys/peers.txt the public keys)."""
    cfg = signed_config(TABLE2_POLICY, out, name="table2.insider.json")
    keys = out / "keys"
    lines = ["# entity  X25519 public key (made at run time)\n"]
    for entity in ENTITIES:
        path = keys / f"{entity}.x25519"
        if path.exists():
            path.unlink()
        ub_sec.ub_keyfile_new(str(path), 1)
        pk = ub_origin.ub_origin_public_key(ub_sec.ub_keyfile_load(str(path))[1])
        lines.append(f"{entity} {pk.hex()}\n")
    (keys / "peers.txt").write_text("".join(lines), encoding="utf-8")
    return cfg


def insider_options(program: Path | None, config: Path, **kw: Any) -> HitlOptions:
    """attack_options() with origin authentication on every C node."""
    opts = attack_options(program, config, **kw)
    keys = config.parent / "keys"
    origin = ["--origin-key", str(keys / "{entity}.x25519"), "--origin-peers", str(keys / "peers.txt")]
    for node in ("primary", "secondary", "backup"):
        opts.node_args[node] = [*opts.node_args.get(node, []), *origin]
    return opts


def _load(keys: Path, entity: str) -> bytes:
    return ub_sec.ub_keyfile_load(str(keys / f"{entity}.x25519"))[1]


class InsiderCampaign(Campaign):
    """The insider's attacks on `h` (started with `start_with_tap(insider_options(...))`)."""

    def __init__(self, h: Any, tap: Any, config: Path, say: Callable[[str], None] | None = None) -> None:
        super().__init__(h, tap, say)
        keys = config.parent / "keys"
        self.keys = keys
        self.sk = {e: _load(keys, e) for e in ENTITIES}
        self.pk = {e: ub_origin.ub_origin_public_key(sk) for e, sk in self.sk.items()}
        self.group_id, self.group_key = ub_sec.ub_keyfile_load(str(keys / "fleet-1.key"))
        self.revoked: dict[str, float] = {}            # entity -> when gcs1's store learnt its revocation
        self._next: dict[str, int] = {}
        h.gcs.security.enable_origin({"gcs1": self.sk["gcs1"]}, self._lookup, recheck_ms=200)

    def _lookup(self, entity: str, _now_s: int) -> bytes | None:
        """gcs1's identity store: the peers' X25519 keys, minus what the operator revoked."""
        return None if entity in self.revoked else self.pk.get(entity)

    # ---- forging as a key holder ------------------------------------------------------------------------
    def _next_counter(self, src: str) -> int:
        """Just ahead of the last counter `src` was seen using on the datalink (either direction): within
        every window's jump bound, so nothing is refused for being far ahead (only the origin tag or the
        policy can refuse it), and never one the genuine sender already used."""
        seen = [_counter(f) for d in ("a>b", "b>a") for f in self.tap.frames(d) if _src(f) == src]
        self._next[src] = max(self._next.get(src, 0), max(seen, default=0) + 100) + 1
        return self._next[src]

    def insider_frame(self, content: str | None, src: str, dest: str, payload: bytes, admin: int = DATA,
                      counter: int | None = None, form: str = FORMS[0], by: str = CAPTURED) -> bytes:
        """A frame in `src`'s name, hop-tagged with the group key; `form` "own pairwise key": origin-tagged
        under `by`'s pairwise key with `dest` (right when src == by), "no origin block": none."""
        c = self._next_counter(src) if counter is None else counter
        hdr = frame_header(self.cat, content, src, dest, admin, c, payload_size=len(payload))
        hdr = uf.FrameHeader(**{**hdr.__dict__, "flags": uf.FLAG_SIGNED, "key_id": self.group_id})
        if form == FORMS[0]:
            hdr = uf.FrameHeader(**{**hdr.__dict__, "flags": uf.FLAG_SIGNED | uf.FLAG_ORIGIN, "origin_hop0": 8})
            key, _ = ub_origin.ub_origin_pair_keys(un.entity_id(by), self.sk[by], un.entity_id(dest), self.pk[dest])
            hdr = uf.FrameHeader(**{**hdr.__dict__, "origin_tag": ub_origin.ub_origin_tag(key, hdr, payload)})
        sec: Any = ub_sec.ub_sec_new({self.group_id: self.group_key})
        return ub_sec.ub_sec_protect(sec, hdr, payload)

    def _forms(self, content: str | None, src: str, dest: str, payload: bytes, admin: int = DATA,
               counter: int | None = None) -> list[bytes]:
        return [self.insider_frame(content, src, dest, payload, admin, counter, form) for form in FORMS]

    # ---- the attacks ------------------------------------------------------------------------------------
    def _stop_as_gcs(self, name: str) -> AttackResult:
        ids = self._request_ids()
        rid = ids.get(("gpsOut", "rmax1ob1"), 0)
        frames = [f for r in {rid, 1, 2} for f in self._forms(
            "gpsOut", "gcs1", "rmax1ob1", struct.pack("<I12s", r, b"gcs1".ljust(12, b"\0")), admin=PUB_STOP)]

        def effect() -> tuple[int, str]:
            rows = [r for r in self._pubsub("primary") if r["content"] == "gpsOut" and r.get("destination") == "gcs1"]
            return (0, "rmax1ob1 kept gpsOut->gcs1") if rows else (1, "gpsOut->gcs1 removed at rmax1ob1")
        return self._forgery(name, frames, "a>b", effect)

    def _writes(self, name: str) -> AttackResult:
        src = "gcs1" if name.startswith("as gcs1") else CAPTURED
        wp = {"latitudeDeg": 51.5, "longitudeDeg": -0.12, "altitudeMsl": 10.0, "speed": 40.0, "valid": 1}
        targets = [("onboardSet", self._value("onboardSet", armed=True)),
                   ("gcsMissionRmax1[0]", self._value("gcsMissionRmax1[0]", **wp))]
        before = {c: self._dump("primary", c) for c, _v in targets}
        forms = FORMS if src != CAPTURED else FORMS[:1]      # in its own name its origin tag is right
        frames = [self.insider_frame(c, src, "rmax1ob1", v, form=f) for c, v in targets for f in forms]

        def effect() -> tuple[int, str]:
            changed = [c for c, _v in targets if self._dump("primary", c) != before[c]]
            return len(changed), ("written at rmax1ob1: " + ", ".join(changed) if changed else
                                  "rmax1ob1's onboardSet and gcsMissionRmax1[0] unchanged")
        return self._forgery(name, frames, "a>b", effect)

    def _forged_imu(self, name: str) -> AttackResult:
        # a frozen IMU: all zero (a value the codec accepts; fcs20's simulated samples never are)
        evil = bytes(self.cat.instance("imuOut").type.packed_size)
        frames = [f for _ in range(10) for f in self._forms("imuOut", "fcs20", "gcs1", evil)]
        mark = len(self.h.messages)

        def effect() -> tuple[int, str]:
            shown = sum(1 for _t, n, s, _q, raw in self.h.messages[mark:] if n == "imuOut" and raw == evil)
            return shown, f"forged imuOut samples delivered to gcs1: {shown}"
        return self._forgery(name, frames, "b>a", effect)

    def _routes(self, name: str) -> AttackResult:
        r = AttackResult(name, 0, 0, {}, "not run: routing does not run in Table 2 (static masks from the "
                         "configuration; no node has --route), so no route advertisement is heard", "")
        self.results.append(r)
        return r

    def _flood_own(self, name: str) -> AttackResult:
        # data to itself (what the read policy lets a vehicle ask for): at 1 ms with no lease, and at 100 ms
        contents = ("gpsOut", "imuOutPrimary")
        frames = [self.insider_frame(contents[k % 2], CAPTURED, "rmax1ob1",
                                     struct.pack("<III12s", 0x9000 + k, 1 if k % 4 < 2 else 100, 0,
                                                 CAPTURED.encode().ljust(12, b"\0")),
                                     admin=PUB_REQUEST) for k in range(30)]
        where = [("primary", UDP_LINK["primary"])]
        before = self._snap("primary")
        limited0 = int(before["primary"]["node"].get("requests_limited", 0))
        for k in range(0, len(frames), 10):
            self.tap.inject("a>b", *frames[k:k + 10])
            self.h.run_for(0.02)
        self._settle(0.5)
        after = self._snap("primary")
        rows = [x for x in self._pubsub("primary", after["primary"]) if x.get("owner") == CAPTURED]
        fast = [x for x in rows if x["period_ms"] < 10]
        unleased = [x for x in rows if not x.get("lease_until_ms")]
        limited = int(after["primary"]["node"].get("requests_limited", 0)) - limited0
        dropped = self._dropped(before, after, where)
        r = AttackResult(name, len(frames), len(rows), dropped,
                         f"allowed (its own name, within its quota): rows for {CAPTURED} at rmax1ob1 {len(rows)} "
                         f"(limit 8), under 10 ms: {len(fast)}, without lease: {len(unleased)}; "
                         f"requests refused over the limits: {limited}",
                         f"rmax1ob1:{UDP_LINK['primary']}")
        r.extra.update(rows=len(rows), fast=len(fast), unleased=len(unleased), limited=limited, allowed=True)
        self.results.append(r)
        return r

    def _lockout(self, name: str, watch_s: float = 2.0) -> AttackResult:
        size = self.cat.instance("imuOut").type.packed_size
        c = LOCKOUT_COUNTER
        stop = struct.pack("<I12s", 1, b"gcs1".ljust(12, b"\0"))
        a_b = [self.insider_frame("gpsOut", "gcs1", "rmax1ob1", stop, admin=PUB_STOP, counter=c),   # gcs1's name
               self.insider_frame("imuOut", "fcs20", "gcs1", bytes(size), counter=c)]   # fcs20's, via the forwarder
        b_a = [self.insider_frame("gpsOut", "rmax1ob1", "gcs1", bytes(self.cat.instance("gpsOut").type.packed_size),
                                  counter=c),                                            # rmax1ob1's, to gcs1
               self.insider_frame("imuOut", "fcs20", "gcs1", bytes(size), counter=c)]   # fcs20's, to gcs1
        where = [("primary", UDP_LINK["primary"]), ("gcs", UDP_LINK["gcs"])]
        before = self._snap("gcs", "primary")
        self.tap.inject("a>b", *a_b)
        self.tap.inject("b>a", *b_a)
        self._settle(0.5)
        t0 = time.monotonic()
        self.h.run_for(watch_s)
        t1 = time.monotonic()
        after = self._snap("gcs", "primary")
        rates = self.rates(t0, t1)
        silenced = int(rates["imuOut"] < 0.9 * 1000 / IMU_MS) + int(rates["gpsOut"] < 9.0)
        dropped = self._dropped(before, after, where)
        gps_row = bool([x for x in self._pubsub("primary") if x["content"] == "gpsOut" and x.get("destination") == "gcs1"])
        sent = len(a_b) + len(b_a)
        r = AttackResult(name, sent, max(sent - sum(dropped.values()), silenced, 0), dropped,
                         f"over the next {watch_s:.0f} s at gcs1: gpsOut {rates['gpsOut']:.1f} Hz, imuOut "
                         f"{rates['imuOut']:.1f} Hz; gcs1's gpsOut row at rmax1ob1 {'kept' if gps_row else 'GONE'}",
                         ", ".join(f"{n}:{link}" for n, link in (("rmax1ob1", where[0][1]), ("gcs1", where[1][1]))))
        r.extra.update(rates)
        self.results.append(r)
        return r

    # ---- revocation -------------------------------------------------------------------------------------
    def revoke(self, timeout: float = 4.0) -> dict[str, Any]:
        """The operator revokes rmax1ob2. gcs1's store learns it at once (its lookup now refuses rmax1ob2);
        the captured vehicle then sends in its own name, rightly origin-tagged, a fresh request every 50 ms
        until each node refuses them. Returns {node: ms from the revocation reaching it to the first refusal},
        None for a node that never refused within `timeout` (the C nodes' static peers file)."""
        payload = struct.pack("<III12s", 0xA000, 1000, 0, CAPTURED.encode().ljust(12, b"\0"))
        where = {"gcs": ("gcs", UDP_LINK["gcs"]), "primary": ("primary", UDP_LINK["primary"])}
        t_rev = time.monotonic()
        self.revoked[CAPTURED] = t_rev
        before = self._snap("gcs", "primary")
        refused: dict[str, float | None] = {"gcs": None, "primary": None}
        sent = 0
        while time.monotonic() - t_rev < timeout and None in refused.values():
            self.tap.inject("b>a", self.insider_frame("navFilterState", CAPTURED, "gcs1",
                                                      bytes(self.cat.instance("navFilterState").type.packed_size)))
            self.tap.inject("a>b", self.insider_frame("gpsOut", CAPTURED, "rmax1ob1", payload, admin=PUB_REQUEST))
            sent += 2
            self.h.run_for(0.05)
            now = self._snap("gcs", "primary")
            for node, (n, link) in where.items():
                d = self._dropped(before, now, [(n, link)])
                if refused[node] is None and d.get("no_identity", 0) > 0:
                    refused[node] = (time.monotonic() - t_rev) * 1000.0
        after = self._snap("gcs", "primary")
        return {"refused_ms": {"gcs1" if k == "gcs" else "rmax1ob1": v for k, v in refused.items()}, "sent": sent,
                "dropped_as": self._dropped(before, after, list(where.values()))}

    # ---- running ----------------------------------------------------------------------------------------
    def run(self, names: tuple[str, ...] | list[str] = INSIDER_ATTACKS, record_s: float = 2.5) -> list[AttackResult]:
        handlers: dict[str, Callable[[str], AttackResult]] = {
            INSIDER_ATTACKS[0]: self._insider_admin_request, INSIDER_ATTACKS[1]: self._stop_as_gcs,
            INSIDER_ATTACKS[2]: self._forged_nack, INSIDER_ATTACKS[3]: self._writes, INSIDER_ATTACKS[4]: self._writes,
            INSIDER_ATTACKS[5]: self._forged_imu, INSIDER_ATTACKS[6]: self._replay, INSIDER_ATTACKS[7]: self._routes,
            INSIDER_ATTACKS[8]: self._flood_own, INSIDER_ATTACKS[9]: self._lockout,
        }
        unknown = set(names) - set(handlers)
        if unknown:
            raise ValueError(f"unknown insider attacks: {sorted(unknown)}")
        self.h.run_for(record_s)
        t0 = time.monotonic()
        for name in (n for n in INSIDER_ATTACKS if n in names):
            r = handlers[name](name)
            self.say(f"    {name}: {r.line()}")
        self.phases.append(("under insider attack", t0, time.monotonic()))
        return self.results

    def _insider_admin_request(self, name: str) -> AttackResult:
        r = self._forged_admin_request(name)
        r.name = name
        return r

