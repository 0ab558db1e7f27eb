"""Issue 23's insider: a captured vehicle (rmax1ob2) that holds its own valid keys attacks Table 2.

    config = insider_config(out)                     # table2_policy + group key + uavbus keys fleet identities
    h, tap = start_with_tap(insider_options(program, config))
    campaign = InsiderCampaign(h, tap, config)       # the attacker: the group key and rmax1ob2's own keys
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
name within its quota (the policy's limits: `max_rows`, `min_period_ms`, `max_lease_ms`), and false metrics
for certified entities (docs/security.md, "Routing from insiders"). Routing does not run in Table 2 (static
masks from the configuration), so the routes attack runs on a small routed identity network beside it
(`routed_insider()`: rmax1ob2 between a C and a Python node, both `certified` routing) from the same fleet.

Identities come from `uavbus keys fleet` (`insider_config()`): every node, C and Python, keys origin
authentication from the certificates its configuration names, and a revocation handed to one node reaches
all (`revoke()` measures it per node, then restarts the revoked vehicle with its identity). Without
identities (`insider_config(out, identities=False)`: bare X25519 key files, `uavbus_node --origin-key
--origin-peers`, the bench mode) the same attacks run; only gcs1's lookup then knows the revocation.
"""

from __future__ import annotations

import json
import struct
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from uavbus._bindings import ub_frame as uf
from uavbus._bindings import ub_node as un
from uavbus._bindings import ub_ident, ub_origin, ub_sec
from uavbus.sim.attacker import frame_header
from uavbus.sim.attacks import (DATA, IMU_MS, LOCKOUT_COUNTER, PUB_REQUEST, PUB_STOP, UDP_LINK, AttackResult, Campaign,
                                _counter, _src, attack_options)
from uavbus.sim.build import REPO
from uavbus.sim.hitl import HitlOptions
from uavbus.sim.secure import signed_config

__all__ = ["INSIDER_ATTACKS", "CAPTURED", "routed_insider", "GROUP_LOCKOUT", "group_key_lockout", "InsiderCampaign", "insider_config", "insider_options"]

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


def insider_config(out: Path, identities: bool = True) -> Path:
    """Table 2 with its authorization policy and the group key, and per entity: `identities` an identity
    certified by a fleet authority made at run time (`uavbus keys fleet`: out/fleet/{entity}.id, mode 0600,
    and the identity configuration out/fleet/table2_policy.identity.json that names them, so every node
    checks origin tags keyed by the certificates and honours revocations); else a bare X25519 key file
    (out/keys/{entity}.x25519, out/keys/peers.txt the public keys: `uavbus_node --origin-key/--origin-peers`,
    no revocation). The key directory is `key_dir(config)`."""
    if identities:
        from uavbus import keys as keytool

        cfg, _roles = keytool.fleet(str(TABLE2_POLICY), str(out / "fleet"), days=30)
        return cfg
    cfg = signed_config(TABLE2_POLICY, out, name="table2.insider.json")
    keys = out / "keys"
    lines = ["# entity  X25519 public key (made at run time)\n"]
    for entity in ENTITIES:
        path = keys / f"{entity}.x25519"
        path.unlink(missing_ok=True)
        ub_sec.ub_keyfile_new(str(path), 1)
        pk = ub_origin.ub_origin_public_key(ub_sec.ub_keyfile_load(str(path))[1])
        lines.append(f"{entity} {pk.hex()}\n")
    (keys / "peers.txt").write_text("".join(lines), encoding="utf-8")
    return cfg


def key_dir(config: Path) -> Path:
    """Where `insider_config()` put the keys of `config`."""
    return config.parent if uses_identities(config) else config.parent / "keys"


def uses_identities(config: Path) -> bool:
    return "identity" in json.loads(Path(config).read_text(encoding="utf-8")).get("security", {})


def insider_options(program: Path | None, config: Path, **kw: Any) -> HitlOptions:
    """attack_options() with origin authentication on every C node: from the identities the configuration
    names, or (without them) from --origin-key/--origin-peers."""
    opts = attack_options(program, config, **kw)
    # rmax1ob2 also sends to rmax1ob1 and fcs20 on its own (its data, which their write policy does not take:
    # `not_allowed`), so after the revocation every one of them has its frames to refuse
    opts.node_args["secondary"] = [a for dest in ("rmax1ob1", "fcs20")
                                   for a in ("--publish", f"{CAPTURED}:navFilterState>{dest}/100")]
    if uses_identities(config):
        return opts
    keys = key_dir(config)
    origin = ["--origin-key", str(keys / "{entity}.x25519"), "--origin-peers", str(keys / "peers.txt")]
    for node in ("primary", "secondary", "backup"):
        opts.node_args[node] = [*opts.node_args.get(node, []), *origin]
    return opts


def _load(keys: Path, entity: str, identities: bool) -> bytes:
    """`entity`'s X25519 secret key: what the attacker holds for rmax1ob2, what the test reads for the others
    (to compute the public keys an attacker reads off the certificates anyway)."""
    if identities:
        return ub_ident.identfile_load(keys / f"{entity}.id")[2]
    return ub_sec.ub_keyfile_load(str(keys / f"{entity}.x25519"))[1]


class InsiderCampaign(Campaign):
    """The insider's attacks on `h` (started with `start_with_tap(insider_options(...))`)."""

    def __init__(self, h: Any, tap: Any, config: Path, say: Callable[[str], None] | None = None) -> None:
        super().__init__(h, tap, say)
        keys = key_dir(config)
        self.keys = keys
        self.identities = uses_identities(config)
        self.sk = {e: _load(keys, e, self.identities) for e in ENTITIES}
        self.pk = {e: ub_origin.ub_origin_public_key(sk) for e, sk in self.sk.items()}
        self.group_id, self.group_key = ub_sec.ub_keyfile_load(str(keys / "fleet-1.key"))
        self.revoked: dict[str, float] = {}            # entity -> when gcs1's store learnt its revocation
        self._next: dict[str, int] = {}
        if not self.identities:       # with identities, gcs1's Node keys origin authentication from its store
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
        program = getattr(self.h, "program", None)
        if program is None or not self.identities:
            r = AttackResult(name, 0, 0, {}, "not run: the routed network needs identities and the C node program "
                             "(Table 2's masks are static; no route advertisement reaches a routing engine there)", "")
        else:
            r = routed_insider(self.keys, Path(program), self.cat, self.h.alloc, pump=lambda: self.h.run_for(0.01))
            r.name = name
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
        rates = self.sent_rates(t0, t1)   # as Campaign.insider_lockout: not a stalled harness's backlog
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
    def _no_identity(self, node: str) -> int:
        """Frames `node` dropped `no_identity` so far."""
        if node == "gcs":
            return sum(int(c["drops"].get("no_identity", 0)) for c in self.h.gcs.link_counters().values())
        return int(self.h.child_stats(node)["node"]["drops"].get("no_identity", 0))

    def _holds_revocation(self, node: str) -> bool:
        if node == "gcs":
            if not self.identities:
                return CAPTURED in self.revoked
            return self.h.gcs.identity.stats()["accepted"] + self.h.gcs.identity.stats()["known"] >= 1
        if not self.identities:
            return False
        return int(self.h.child_stats(node)["identity"]["revocations"]) >= 1

    def _own_frames(self) -> list[tuple[str, bytes]]:
        """What the revoked vehicle keeps sending in its own name, rightly origin-tagged: data to gcs1, a
        request to rmax1ob1, and one to fcs20 (relayed by rmax1ob1)."""
        req = struct.pack("<III12s", 0xA000, 1000, 0, CAPTURED.encode().ljust(12, b"\0"))
        nav = bytes(self.cat.instance("navFilterState").type.packed_size)
        return [("b>a", self.insider_frame("navFilterState", CAPTURED, "gcs1", nav)),
                ("a>b", self.insider_frame("gpsOut", CAPTURED, "rmax1ob1", req, admin=PUB_REQUEST)),
                ("a>b", self.insider_frame("imuOut", CAPTURED, "fcs20", req, admin=PUB_REQUEST))]

    def revoke(self, timeout: float = 5.0) -> dict[str, Any]:
        """The operator revokes rmax1ob2 (`uavbus keys revoke rmax1ob2`) and hands the record to rmax1ob1
        (`revoke FILE` on its stdin); the revocation service spreads it. Meanwhile the captured vehicle sends
        in its own name, rightly origin-tagged, to gcs1, rmax1ob1 and fcs20 every 20 ms. Per node: when the
        revocation reached it and when it first refused rmax1ob2's frames (`no_identity`), in ms from the
        submission, as seen by polling every node each 20 ms plus the polls' own time (`refused_ms` - `reached_ms`,
        what issue 23 bounds to 2 s, is 0 when both showed in the same poll). Then the revoked vehicle
        restarts with the same identity: `restart` says what happened."""
        nodes = {"gcs": "gcs1", "primary": "rmax1ob1", "backup": "fcs20"}
        base = {n: self._no_identity(n) for n in nodes}
        t0 = time.monotonic()
        if self.identities:
            from uavbus import keys as keytool

            keytool.revoke(CAPTURED, None, None, str(self.keys), None)
            self.h.group["primary"].send(f"revoke {self.keys / 'revocations.ubr'}")
        else:
            self.revoked[CAPTURED] = t0       # gcs1's lookup only: the C nodes' peers file is static
        step_s = 0.02                       # the measurement's resolution: one poll of every node per step
        reached: dict[str, float | None] = dict.fromkeys(nodes)
        refused: dict[str, float | None] = dict.fromkeys(nodes)
        sent = 0
        while time.monotonic() - t0 < timeout and None in refused.values():
            for direction, frame in self._own_frames():
                self.tap.inject(direction, frame)
                sent += 1
            self.h.run_for(step_s)
            for n in nodes:
                now_ms = (time.monotonic() - t0) * 1000.0
                if reached[n] is None and self._holds_revocation(n):
                    reached[n] = now_ms
                if refused[n] is None and self._no_identity(n) > base[n]:
                    refused[n] = now_ms
        out: dict[str, Any] = {"sent": sent, "nodes": {}, "poll_ms": step_s * 1000.0}
        for n, name in nodes.items():
            delay = None if refused[n] is None else max(0.0, refused[n] - (reached[n] or 0.0))
            out["nodes"][name] = {"reached_ms": reached[n], "refused_ms": refused[n], "delay_ms": delay}
        out["restart"] = self._restart_revoked() if self.identities else None
        return out

    def _restart_revoked(self, watch_s: float = 2.0) -> dict[str, Any]:
        """rmax1ob2's node restarts with the identity the operator revoked: first as it is (its own store holds
        the record: it must refuse to start), then with its revocations file thrown away, as a captured vehicle
        would: it starts, and for `watch_s` nothing of it may get in (`delivered`: messages of rmax1ob2 at
        gcs1; `refused`: its frames rmax1ob1 dropped `no_identity`)."""
        from uavbus.sim.process import NodeError

        out: dict[str, Any] = {"refused_to_start": False, "delivered": None, "refused": None}
        try:
            self.h.restart("secondary")
            first = "started with its revoked identity"
        except NodeError as e:
            out["refused_to_start"] = True
            text = " ".join(str(e).split())
            at = max(0, text.find("revoked") - 60)     # the node's own one-line reason
            first = f"refused to start (...{text[at:at + 220]})"
        (self.keys / "state" / f"{CAPTURED}.revocations.ubr").unlink(missing_ok=True)
        try:
            self.h.restart("secondary")
        except NodeError as e:
            out["text"] = f"{first}; without its revocations file: refused to start too ({str(e).strip()[:160]})"
            out["delivered"], out["refused"] = 0, 0
            return out
        base = self._no_identity("primary")
        mark = len(self.h.messages)
        self.h.run_for(watch_s)
        out["delivered"] = sum(1 for x in self.h.messages[mark:] if x[2] == CAPTURED)
        out["refused"] = self._no_identity("primary") - base
        out["text"] = (f"{first}; with its revocations file thrown away it starts: over {watch_s:.0f} s rmax1ob1 "
                       f"refused {out['refused']} of its frames (no_identity), messages of rmax1ob2 delivered to "
                       f"gcs1: {out['delivered']}")
        return out

    # ---- running ----------------------------------------------------------------------------------------
    def run(self, names: tuple[str, ...] | list[str] = INSIDER_ATTACKS, record_s: float = 2.5) -> list[AttackResult]:
        handlers: dict[str, Callable[[str], AttackResult]] = {
            INSIDER_ATTACKS[0]: self._insider_admin_request, INSIDER_ATTACKS[1]: self._stop_as_gcs,
            INSIDER_ATTACKS[2]: self._forged_nack, INSIDER_ATTACKS[3]: self._writes, INSIDER_ATTACKS[4]: self._writes,
            INSIDER_ATTACKS[5]: self._forged_imu, INSIDER_ATTACKS[6]: self._replay_relayed, INSIDER_ATTACKS[7]: self._routes,
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

    def _replay_relayed(self, name: str) -> AttackResult:
        r = self._replay(name)
        r.effect = ("what it overheard on the datalink it is in range of, both directions (rmax1ob2 forwards nobody's "
                    "frames in Table 2's masks); " + r.effect)
        return r

    def _insider_admin_request(self, name: str) -> AttackResult:
        r = self._forged_admin_request(name)
        r.name = name
        return r



# ---- routes for entities it does not own: a small routed identity network ------------------------------------
GHOSTS = ("uav90", "uav91")              # no certificate: entities that do not exist in the fleet
CLAIMED = "fcs20"                       # certified, but not the captured vehicle's: the threat model's open case
ROUTE_HELLO_MS, ROUTE_UPDATE_MS = 100, 200
ROUTE_UPDATE = 10                       # UB_ADMIN_ROUTE_UPDATE (docs/routing.md, "Frame layouts")


def route_entries(frame: bytes) -> list[tuple[str, int]]:
    """The (destination, metric) update entries of a ROUTE_UPDATE frame (docs/routing.md: a 24-byte hello
    part, then 16-byte entries); [] for any other frame."""
    try:
        h = uf.ub_frame_parse(frame)
    except Exception:
        return []
    if h.admin != ROUTE_UPDATE:
        return []
    p = frame[uf.FRAME_HEADER_LEN:uf.FRAME_HEADER_LEN + h.payload_size]
    return [(p[o:o + 12].rstrip(b"\0").decode("ascii", "replace"), int.from_bytes(p[o + 14:o + 16], "little"))
            for o in range(24, 24 + 16 * p[10], 16)]


def routes_config(keys: Path) -> Path:
    """The routed identity network of the routes attack, in the fleet's key directory: rmax1ob2 (the captured
    vehicle) between rmax1ob1 and gcs1, one UDP link each; the fleet's group key, authority and identities;
    counters, certificate copies and revocations in routes-state/ (apart from Table 2's running nodes)."""
    state = keys / "routes-state"
    state.mkdir(exist_ok=True)
    for e in ("rmax1ob1", "rmax1ob2", "gcs1"):
        (state / f"{e}.certs").write_bytes((keys / "fleet.certs").read_bytes())
    doc = {"system": "insider-routes",
           "entities": [{"name": "rmax1ob2", "links": ["toRmax1ob1", "toGcs1"]},
                        {"name": "rmax1ob1", "links": ["toRmax1ob2"]},
                        {"name": "gcs1", "links": ["toRmax1ob2"]}],
           "nodes": {"r2": ["rmax1ob2"], "r1": ["rmax1ob1"], "g1": ["gcs1"]},
           "security": {"keys": ["fleet-1.key"], "counter_file": "routes-state/{entity}.counter",
                        "authority": "authority.pub", "identity": "{entity}.id",
                        "certificates": "routes-state/{entity}.certs",
                        "revocations": "routes-state/{entity}.revocations.ubr"}}
    path = keys / "routes.identity.json"
    path.write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
    return path


def routed_insider(keys: Path, program: Path, cat: Any, alloc: Any, pump: Callable[[], None] | None = None,
                   settle_s: float = 0.6, attack_s: float = 1.0) -> AttackResult:
    """Routes for entities it does not own, on a routed identity network (Table 2 runs no routing): the
    captured vehicle rmax1ob2 (a Python node with its own valid identity, running the routing engine) sits
    between rmax1ob1 (the C program, `--route certified=1`) and gcs1 (a Python node,
    `routing.enable(certified=True)`), each link through a recording UDP tap. Once both have verified it
    (`settle_s`), it starts advertising, at metric 0 as its own, GHOSTS (no certificate) and CLAIMED
    (fcs20: certified, not its own) for `attack_s`. `sent`: ghost entries that crossed the taps; `accepted`:
    ghosts routed at either victim; `dropped_as`: the victims' `dest_refused`. fcs20's claim is what the
    threat model leaves open (false metrics for certified entities: attraction, not forgery); the effect says
    what became of it. `pump` keeps another harness serviced meanwhile (Table 2's GCS)."""
    from uavbus import Node
    from uavbus.sim.attacker import UdpTap
    from uavbus.sim.process import NodeProcess

    cfg = routes_config(keys)
    ep = {k: alloc.addr() for k in ("r2a", "r2b", "r1", "g1", "tap_r2a", "tap_r1", "tap_r2b", "tap_g1")}
    tap_r1 = UdpTap(ep["r2a"], ep["r1"], ep["tap_r2a"], ep["tap_r1"])      # a>b: rmax1ob2 -> rmax1ob1
    tap_g1 = UdpTap(ep["r2b"], ep["g1"], ep["tap_r2b"], ep["tap_g1"])      # a>b: rmax1ob2 -> gcs1
    ropt = {"hello_ms": ROUTE_HELLO_MS, "update_ms": ROUTE_UPDATE_MS}
    proc = NodeProcess([str(program), "--config", str(cfg), "--node", "r1", "--stats-ms", "0",
                        "--route", f"certified=1,hello={ROUTE_HELLO_MS},update={ROUTE_UPDATE_MS}",
                        "--port", f"toRmax1ob2=udp:bind={ep['r1']},peer={ep['tap_r1']}"], "routes-rmax1ob1")
    nodes: list[Any] = []
    try:
        proc.start()
        proc.wait_ready(5.0)
        gcs = Node(cat, config=cfg, node="g1")
        nodes.append(gcs)
        gcs.open_port("toRmax1ob2", f"udp:bind={ep['g1']},peer={ep['tap_g1']}")
        gcs.routing.enable(certified=True, **ropt)
        att = Node(cat, config=cfg, node="r2")
        nodes.append(att)
        att.open_port("toRmax1ob1", f"udp:bind={ep['r2a']},peer={ep['tap_r2a']}")
        att.open_port("toGcs1", f"udp:bind={ep['r2b']},peer={ep['tap_r2b']}")
        att.routing.enable(**ropt)

        def run(seconds: float) -> None:
            end = time.monotonic() + seconds
            while time.monotonic() < end:
                for n in nodes:
                    n.poll(0)
                if pump is not None:
                    pump()
                else:
                    time.sleep(0.005)

        def c_routes() -> dict[str, Any]:
            since = proc.mark()
            proc.send("routes")
            return proc.wait_event("routes", 3.0, since)

        run(settle_s)                       # hellos both ways; each victim challenges and verifies rmax1ob2
        base_c = c_routes()["counters"]["dest_refused"]
        base_py = gcs.routing.counters()["dest_refused"]
        t0 = time.monotonic()
        for e in (*GHOSTS, CLAIMED):       # its engine now advertises them at metric 0, as its own
            att.add_entity(e, local=True)
        run(attack_s)
        table_c = c_routes()["entities"].get("rmax1ob1", {})     # the tables while the links are up
        table_py = gcs.routing.table("gcs1")
        t1 = {}
        for tap in (tap_r1, tap_g1):        # nothing more reaches the victims: exact accounting (under the
            with tap._lock:                 # tap's lock: a frame captured before t1 was forwarded, after it not)
                tap.forwarding = False
                t1[id(tap)] = time.monotonic()
        run(0.2)
        ev = c_routes()
        sent = {v: sum(1 for t, d, f in tap.captured if d == "a>b" and t0 <= t < t1[id(tap)]
                       for dest, _m in route_entries(f) if dest in GHOSTS)
                for v, tap in (("rmax1ob1", tap_r1), ("gcs1", tap_g1))}
        refused = {"rmax1ob1": ev["counters"]["dest_refused"] - base_c,
                   "gcs1": gcs.routing.counters()["dest_refused"] - base_py}
        learned = {"rmax1ob1": [g for g in GHOSTS if table_c.get(g, {}).get("reachable")],
                   "gcs1": [g for g in GHOSTS if table_py.get(g, {}).get("reachable")]}
        claim = {"rmax1ob1": table_c.get(CLAIMED, {}).get("via"), "gcs1": table_py.get(CLAIMED, {}).get("next_hop")}
        accepted = sum(len(v) for v in learned.values())
        r = AttackResult("routes for entities it does not own", sum(sent.values()), accepted,
                         {"dest_refused": sum(refused.values())} if sum(refused.values()) else {},
                         f"{len(GHOSTS)} uncertified entities advertised at metric 0 by rmax1ob2 for {attack_s:.1f} s "
                         f"(entries: rmax1ob1 {sent['rmax1ob1']}, gcs1 {sent['gcs1']}; refused: rmax1ob1 "
                         f"{refused['rmax1ob1']}, gcs1 {refused['gcs1']}); routed: rmax1ob1 {learned['rmax1ob1'] or 'none'}, "
                         f"gcs1 {learned['gcs1'] or 'none'}; allowed by the threat model: its metric-0 claim for "
                         f"{CLAIMED} (certified, not its own) routes {CLAIMED} via "
                         f"{claim['rmax1ob1'] or 'nobody'} at rmax1ob1, {claim['gcs1'] or 'nobody'} at gcs1 "
                         "(attraction, not forgery: origin tags still hold)",
                         "rmax1ob1 (C, --route certified=1) and gcs1 (Python, certified=True), routing engines")
        r.extra.update(sent=sent, refused=refused, learned=learned, claimed=claim)
        return r
    finally:
        for n in nodes:
            n.close()
        proc.stop()
        tap_r1.close()
        tap_g1.close()


GROUP_LOCKOUT = "lockout: one frame each in gcs1's and rmax1ob1's names, counter 2^48-2, group key"


def group_key_lockout(campaign: Campaign, key_file: Path, watch_s: float = 2.0) -> AttackResult:
    """The lockout in the group-key mode (no identities: a key holder signs as anyone) for the victims the
    attacker step's own line (fcs20's name, `Campaign.insider_lockout`) leaves out: one frame in gcs1's name to
    rmax1ob1 and one in rmax1ob1's name to gcs1, each with counter 2^48-2. Each must be dropped `counter_jump`
    (docs/security.md, "Lockout") and silence nobody: gcs1 still administers rmax1ob1 (a new row becomes
    active) and rmax1ob1's gpsOut keeps its 10 Hz at gcs1. `accepted`: frames not dropped, plus 1 per victim
    silenced."""
    from uavbus.sim.attacker import forge

    h = campaign.h
    key_id, key = ub_sec.ub_keyfile_load(str(key_file))
    stop = struct.pack("<I12s", 1, b"gcs1".ljust(12, b"\0"))
    gps = bytes(campaign.cat.instance("gpsOut").type.packed_size)
    to_vehicle = forge(campaign.cat, "gpsOut", "gcs1", "rmax1ob1", stop, admin=PUB_STOP, counter=LOCKOUT_COUNTER,
                       mode="signed", key=key, key_id=key_id)
    to_gcs = forge(campaign.cat, "gpsOut", "rmax1ob1", "gcs1", gps, counter=LOCKOUT_COUNTER, mode="signed", key=key,
                   key_id=key_id)
    where = [("primary", UDP_LINK["primary"]), ("gcs", UDP_LINK["gcs"])]
    before = campaign._snap("gcs", "primary")
    campaign.tap.inject("a>b", to_vehicle)
    campaign.tap.inject("b>a", to_gcs)
    h.run_for(0.3)
    t0 = time.monotonic()
    row = h.add_row("publication", "navFilterState", "rmax1ob1", "gcs1", 100)   # gcs1 -> rmax1ob1, after it
    try:
        h.wait_status(row, "active", watch_s + 2.0)
        admin = "gcs1's new row at rmax1ob1 active"
    except TimeoutError:
        admin = f"gcs1's new row at rmax1ob1 {h.admin.status(row)}"
    h.run_for(max(0.0, watch_s - (time.monotonic() - t0)))
    t1 = time.monotonic()
    h.admin.deactivate(row)
    after = campaign._snap("gcs", "primary")
    rates = campaign.sent_rates(t0, t1)   # what the sources sent in the window: not a stalled harness's backlog
    silenced = int(not admin.endswith("active")) + int(rates["gpsOut"] < 9.0)
    dropped = campaign._dropped(before, after, where)
    r = AttackResult(GROUP_LOCKOUT, 2, max(2 - sum(dropped.values()), silenced, 0), dropped,
                     f"{admin}; gpsOut from rmax1ob1 at gcs1 over the next {t1 - t0:.1f} s: {rates['gpsOut']:.1f} Hz",
                     "rmax1ob1:" + UDP_LINK["primary"] + ", gcs1:" + UDP_LINK["gcs"])
    r.extra.update(rates, admin=admin)
    return r
