"""Issue 23 as one feature on the paper's Table 2, real processes on 127.0.0.1: `uavbus keys fleet` gives every
entity its identity; the C nodes (uavbus_node) and the Python GCS take origin authentication from the identity
store of their configuration (nothing else to set up), and

- gpsOut (10 Hz, 1 hop) and imuOut (50 Hz, 2 hops) flow to gcs1;
- an insider holding rmax1ob2's own identity and the fleet key, on the gcs1 <-> rmax1ob1 datalink (the attack
  tap of test_attacks.py), forges in gcs1's name an admin request and a write of `armed` into rmax1ob1 and
  fcs20, and in fcs20's name imuOut to gcs1, each with an origin tag under its own pairwise key and without
  one: every frame is dropped `bad_origin` or `no_origin` at its destination, counted, and nothing lands;
- after `uavbus keys revoke rmax1ob2` handed to one node (rmax1ob1's stdin), every node refuses rmax1ob2's
  frames (rmax1ob2 publishes to all three) within 2 s (measured: printed), and rmax1ob2 restarted with the
  same identity (its revocations file thrown away, as a captured vehicle would) gets nothing in.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import pytest

from uavbus import keys
from uavbus._bindings import ub_frame as uf
from uavbus._bindings import ub_ident, ub_origin, ub_sec
from uavbus.sim.attacker import frame_header
from uavbus.sim.attacks import Campaign, _counter, _src, attack_options, start_with_tap
from uavbus.sim.build import REPO
from uavbus.sim.hitl import HitlOptions

pytestmark = pytest.mark.timeout(180)

TABLE2 = REPO / "examples" / "configs" / "table2.json"
DATA, PUB_REQUEST = 0, 1
NODES = {"primary": "rmax1ob1", "backup": "fcs20", "gcs": "gcs1"}   # rmax1ob2's destinations
MAGIC_IMU = b"\x5a\xa5\x3c\xc3" * 2                                   # marks every forged imuOut


def test_keys_fleet_decides_roles_and_writes_a_config(tmp_path: Path) -> None:
    cfg, roles = keys.fleet(str(TABLE2), str(tmp_path / "fleet"), days=30)
    # ground stations (gcs*) administer; a vehicle with several links also relays
    assert roles == {"rmax1ob1": "vehicle,relay", "rmax1ob2": "vehicle", "fcs20": "vehicle", "gcs1": "admin"}
    for entity in roles:
        assert (tmp_path / "fleet" / f"{entity}.id").stat().st_mode & 0o077 == 0
        assert f"{entity}: serial" in keys.show(str(tmp_path / "fleet" / f"{entity}.certs"))
    text = cfg.read_text()
    assert '"identity": "{entity}.id"' in text and '"authority": "authority.pub"' in text
    _, admins_given = keys.fleet(str(TABLE2), str(tmp_path / "other"), admins=["rmax1ob2"],
                                 overrides={"fcs20": "vehicle,observer"})
    assert admins_given["rmax1ob2"] == "admin" and admins_given["gcs1"] == "vehicle,relay"
    assert admins_given["fcs20"] == "vehicle,observer"
    with pytest.raises(keys.KeysError, match="not an entity"):
        keys.fleet(str(TABLE2), str(tmp_path / "bad"), admins=["gcs9"])


class Insider(Campaign):
    """The attack campaign's forgeries, made by a key holder: the fleet key signs every frame (hop tag right),
    and the origin block is either its own (rmax1ob2's pairwise key toward the destination: the best a
    captured vehicle can make) or absent. Counters follow what the victim source really sends (read off the
    tapped link), so no freshness rule refuses them before the origin check does."""

    def __init__(self, h: Any, tap: Any, fleet: Path) -> None:
        super().__init__(h, tap, say=print)
        self.group = ub_sec.ub_sec_new({1: ub_sec.ub_keyfile_load(str(fleet / "fleet-1.key"))[1]})
        _cert, _sign, self.kx = ub_ident.identfile_load(fleet / "rmax1ob2.id")   # the captured vehicle's own
        self.pk = {e: ub_ident.identfile_load(fleet / f"{e}.id")[0].kx_pk for e in ("rmax1ob1", "fcs20", "gcs1")}
        self.sent = 0
        self.last: dict[str, int] = {}

    def _next(self, src: str) -> int:
        seen = [_counter(f) for d in ("a>b", "b>a") for f in self.tap.frames(d) if _src(f) == src]
        self.last[src] = max([self.last.get(src, 0), *seen]) + 1   # just above the source's own
        return self.last[src]

    def _forms(self, content: str | None, src: str, dest: str, payload: bytes, admin: int = DATA,
               counter: int | None = None) -> list[bytes]:
        own, _ = ub_origin.ub_origin_pair_keys(ub_ident.entity_id("rmax1ob2"), self.kx, ub_ident.entity_id(dest),
                                               self.pk[dest])
        out = []
        for pair_key in (own, None):
            h = frame_header(self.cat, content, src, dest, admin, self._next(src), payload_size=len(payload))
            h = uf.FrameHeader(**{**h.__dict__, "flags": uf.FLAG_SIGNED, "key_id": 1})
            if pair_key is not None:
                h = uf.FrameHeader(**{**h.__dict__, "flags": uf.FLAG_SIGNED | uf.FLAG_ORIGIN, "origin_hop0": 8})
                h = uf.FrameHeader(**{**h.__dict__, "origin_tag": ub_origin.ub_origin_tag(pair_key, h, payload)})
            out.append(ub_sec.ub_sec_protect(self.group, h, payload))
        self.sent += len(out)
        return out


def origin_drops(h: Any) -> dict[str, int]:
    """bad_origin, no_origin and no_identity drops at every destination of this test, summed per reason."""
    out = {"bad_origin": 0, "no_origin": 0, "no_identity": 0}
    for node in NODES:
        if node == "gcs":
            links = h.gcs.link_counters()
            drops = [links[link]["drops"] for link in links]
        else:
            drops = [h.child_stats(node)["node"]["drops"]]
        for d in drops:
            for reason in out:
                out[reason] += int(d.get(reason, 0))
    return out


def refusals(h: Any, node: str) -> int:
    """no_identity drops at `node`: frames of an entity its store refuses (here: revoked rmax1ob2)."""
    if node == "gcs":
        return sum(int(c["drops"]["no_identity"]) for c in h.gcs.link_counters().values())
    return int(h.child_stats(node)["node"]["drops"]["no_identity"])


def test_table2_with_identities_refuses_an_insider_and_revokes_it(program: Path, tmp_path: Path) -> None:
    fleet = tmp_path / "fleet"
    cfg, _roles = keys.fleet(str(TABLE2), str(fleet), days=30)
    opts: HitlOptions = attack_options(program, cfg)
    # rmax1ob2 sends to every other entity, so each one's refusal after the revocation shows: to gcs1 on its
    # subscription, to the two vehicles unsolicited (their policy refuses it, `not_allowed`, after the origin check)
    opts.node_args["secondary"] = [a for dest in ("rmax1ob1", "fcs20")
                                   for a in ("--publish", f"rmax1ob2:navFilterState>{dest}/100")]
    h, tap = start_with_tap(opts)
    try:
        camp = Insider(h, tap, fleet)
        gps = h.add_row("publication", "gpsOut", "rmax1ob1", "gcs1", 100)
        imu = h.add_row("subscription", "imuOut", "fcs20", "gcs1", 20)
        nav = h.add_row("subscription", "navFilterState", "rmax1ob2", "gcs1", 100)
        for row in (gps, imu, nav):
            h.wait_status(row, "active", 10.0)
        since = time.monotonic()
        h.wait_data("imuOut", "fcs20", 3, 5.0, since=since)
        h.wait_data("navFilterState", "rmax1ob2", 3, 5.0, since=since)
        t0 = time.monotonic()
        h.run_for(3.0)
        rates = camp.rates(t0, time.monotonic())
        print(f"identities: gpsOut {rates['gpsOut']:.1f} Hz (10 requested), imuOut {rates['imuOut']:.1f} Hz (50)")
        assert rates["gpsOut"] > 5 and rates["imuOut"] > 25, rates
        for node in ("primary", "secondary", "backup"):
            origin = h.child_stats(node)["security"]["origin"]
            assert origin is not None and origin["opened"] > 0 and origin["sealed"] > 0, (node, origin)
        mine = h.gcs.security.origin_status()
        assert mine is not None and mine["opened"] > 0 and mine["bad_origin"] == mine["no_origin"] == 0

        # ---- the insider: rmax1ob2's identity and the fleet key, on the gcs1 <-> rmax1ob1 datalink
        before = origin_drops(h)
        results = [camp._forged_admin_request("insider: admin request as gcs1"),
                   camp._forged_write("insider: write as gcs1: armed = 1"),
                   imu_forgery(camp)]
        h.run_for(0.5)
        after = origin_drops(h)
        dropped = {k: after[k] - before[k] for k in after}
        for r in results:
            print(f"  {r.name}: sent {r.sent}, effect: {r.effect}")
        request, write, imu_forged = (r.effect for r in results)
        assert request.startswith("rows streaming onboardSet at rmax1ob1: 0"), request
        assert write.startswith("directories unchanged: rmax1ob1.onboardSet, fcs20.fcsSet"), write
        assert imu_forged == "forged imuOut delivered to gcs1: 0", imu_forged
        print(f"insider frames: sent {camp.sent}, dropped {dropped}")
        assert dropped["bad_origin"] + dropped["no_origin"] == camp.sent, (dropped, camp.sent)
        assert dropped["bad_origin"] == dropped["no_origin"] == camp.sent // 2
        assert not [m for m in h.messages if m[1] == "imuOut" and MAGIC_IMU in m[4]]

        # ---- revocation: handed to rmax1ob1 only; every destination of rmax1ob2 refuses it
        out = keys.revoke("rmax1ob2", None, None, str(fleet), None)
        assert "revoked up to serial" in out
        base = {node: refusals(h, node) for node in NODES}
        proc = h.group["primary"]
        m = proc.mark()
        t_rev = time.monotonic()
        proc.send(f"revoke {fleet / 'revocations.ubr'}")
        assert h.child_event("primary", "revoke", 3.0, since=m)["accepted"] == 1
        took: dict[str, float] = {}
        while len(took) < len(NODES) and time.monotonic() - t_rev < 5.0:
            for node in NODES:
                if node not in took and refusals(h, node) > base[node]:
                    took[node] = time.monotonic() - t_rev
            h.poll(0.01)
        h.run_for(1.0)
        last = max(t for t, _n, src, *_x in h.messages if src == "rmax1ob2")
        print("revocation of rmax1ob2 -> its frames refused (no_identity) at " +
              ", ".join(f"{NODES[n]} {took.get(n, float('nan')) * 1000:.0f} ms" for n in NODES) +
              f"; its last navFilterState delivered to gcs1 {(last - t_rev) * 1000:.0f} ms after the revoke")
        assert set(took) == set(NODES) and max(took.values()) < 2.0, took
        assert last - t_rev < 2.0
        mark = len(h.messages)
        h.run_for(1.0)
        assert not [x for x in h.messages[mark:] if x[2] == "rmax1ob2"], "rmax1ob2's data still delivered"
        assert [x for x in h.messages[mark:] if x[1] == "imuOut"], "imuOut stopped with the revocation"

        # ---- the revoked vehicle restarts with the same identity, its revocations file thrown away
        (fleet / "state" / "rmax1ob2.revocations.ubr").unlink(missing_ok=True)
        h.restart("secondary")
        base = {node: refusals(h, node) for node in NODES}
        mark = len(h.messages)
        h.run_for(3.0)
        refused = {NODES[n]: refusals(h, n) - base[n] for n in NODES}
        drops = {k: v for k, v in h.child_stats("primary")["node"]["drops"].items() if v}
        print(f"restarted rmax1ob2 (same identity): frames refused no_identity {refused}; rmax1ob1's drops {drops}")
        # its neighbour refuses what it sends; what it sends further (to fcs20) dies there too: rmax1ob1 cannot
        # challenge a revoked entity (no pairwise key), so its frames stay `unverified` and are never forwarded
        assert refused["rmax1ob1"] > 0, refused
        assert not [x for x in h.messages[mark:] if x[2] == "rmax1ob2"]
        assert h.child_stats("primary")["identity"]["revocations"] == 1
    finally:
        h.close()
        tap.close()


def imu_forgery(camp: Insider) -> Any:
    """fcs20's imuOut to gcs1, forged by the insider (toward the GCS end of the datalink)."""
    t = camp.cat.instance("imuOut").type
    image = bytearray((MAGIC_IMU * (t.packed_size // len(MAGIC_IMU) + 1))[:t.packed_size])
    for offset, width in t.refusable:
        image[offset:offset + width] = bytes(width)
    frames = [f for _ in range(5) for f in camp._forms("imuOut", "fcs20", "gcs1", bytes(image))]
    mark = len(camp.h.messages)

    def effect() -> tuple[int, str]:
        shown = sum(1 for *_x, raw in camp.h.messages[mark:] if MAGIC_IMU in raw)
        return shown, f"forged imuOut delivered to gcs1: {shown}"
    return camp._forgery("insider: fcs20's imuOut to gcs1", frames, "b>a", effect)



SCENARIO = """name: id3
duration_s: 6
seed: 3
routing: {hello_ms: 200, dead_misses: 3, parallel: all}
signed: true
ground_stations:
  - {name: gcs1, run: python, position: {n: 0, e: 0, alt: 2}}
vehicles:
  - {name: uav1, motion: "orbit:r=100,v=10,n=300,e=0"}
  - {name: uav2, motion: "orbit:r=100,v=10,n=600,e=300,phase=90"}
  - {name: uav3, run: python, motion: "orbit:r=80,v=8,n=900,e=0"}
links:
  - {between: [gcs1, uav1], transport: udp}
  - {between: [uav1, uav2], transport: tcp}
  - {between: [uav2, uav3], transport: udp}
flows:
  - {name: gps2, content: gpsOut, source: uav2, destination: gcs1, period_ms: 100}
  - {name: gps3, content: gpsOut, source: uav3, destination: gcs1, period_ms: 100}
  - {name: imu1to3, content: imuOut, source: uav1, destination: uav3, period_ms: 100}
"""


def test_signed_scenario_runs_with_identities(program: Path, tmp_path: Path) -> None:
    """`signed: true` (and `uavbus sim --signed`): each station its own identity; C and Python nodes seal and
    open origin blocks on every flow (relayed over 2 and 3 hops), and nothing is refused."""
    from uavbus.sim.fleet import FleetRun
    from uavbus.sim.scenario import parse_scenario

    sc = parse_scenario(SCENARIO, "id3.yaml")
    summary = FleetRun(sc, tmp_path, program=program, log=lambda s: None).run()
    assert summary["signed_mode"] == "identity"
    for flow in summary["flows"]:
        assert flow["delivered"] > 0.5 * flow["expected"], flow
    for station, c in summary["counters"].items():
        origin = c.get("origin")
        assert origin is not None and origin["sealed"] > 0 and origin["opened"] > 0, (station, c)
        assert origin["bad_origin"] == origin["no_origin"] == 0, (station, origin)
    assert (tmp_path / "keys" / "uav2.id").stat().st_mode & 0o077 == 0
