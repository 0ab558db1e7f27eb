"""`uavbus_node` sleeps until its next due time (issue 28 item 5), with real processes on 127.0.0.1.

The motion models (gpsOut 10 Hz, navFilterState 50 Hz, imuOutPrimary 100 Hz on rmax1ob1) are sampled lazily
(programs/node/uavbus_node.c, "motion models"): a sample nobody reads wakes nobody, and whatever reads one
(`dump`, a publication) gets the sample of the latest instant epoch + k * period, as if the model had been
sampled on time. Wake-ups are the node's own count (the stats event's `wakeups`: loop turns). Bounds are
counts, not times: a loaded machine only merges wake-ups, and the old eager sampling woke ~100 times a
second for imuOutPrimary alone.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest

from uavbus.sim.flight import FlightModel
from uavbus.sim.hitl import catalogue_for
from uavbus.sim.process import NodeProcess, ProcessGroup

pytestmark = pytest.mark.timeout(90)

CONFIG = {
    "system": "wakeups",
    "entities": [
        {"name": "rmax1ob1", "links": ["radio"], "linktoentity": {"gcs1": ["radio"]}},
        {"name": "gcs1", "links": ["gcsRadio"], "linktoentity": {"rmax1ob1": ["gcsRadio"]}},
    ],
    "nodes": {"vehicle": ["rmax1ob1"], "gcs": ["gcs1"]},
}
MOTION = "orbit:r=150,v=12,phase=30"
IMU_MS = 10  # imuOutPrimary's model period in uavbus_node (k_dirs)
IDLE_WAKEUPS_PER_S = 10  # what an idle node may take; the eager models took ~100


@pytest.fixture
def config(tmp_path: Path) -> Path:
    path = tmp_path / "wakeups.json"
    path.write_text(json.dumps(CONFIG, indent=1))
    return path


def start_vehicle(group: ProcessGroup, program: Path, config: Path, epoch_ms: int,
                  *extra: str) -> tuple[NodeProcess, int]:
    proc = group.spawn([program, "--config", config, "--node", "vehicle", "--port", "radio=udp:bind=127.0.0.1:0",
                        "--stats-ms", "0", "--motion", MOTION, "--epoch-ms", str(epoch_ms), *extra], "vehicle",
                       ready_timeout=8.0)
    return proc, int(proc.wait_ready()["ports"]["radio"]["local_port"])


def dump(proc: NodeProcess, cat: object, content: str) -> tuple[dict, float, float]:
    """The directory as the node holds it, and time.monotonic() in ms just before asking and after the answer."""
    m = proc.mark()
    before = time.monotonic() * 1000.0
    proc.send(f"dump {content}")
    ev = proc.wait_event("dump", 5.0, since=m)
    after = time.monotonic() * 1000.0
    return cat.decode(content, bytes.fromhex(ev["packed"])), before, after  # type: ignore[attr-defined]


def check_on_grid(imu: dict, epoch_ms: int, model: FlightModel) -> int:
    """The sample is the model's at an instant epoch + k * IMU_MS, stamped with that instant; returns k."""
    t = imu["time"]
    assert t["microseconds"] % 1000 == 0, f"timeTag {t} is not a sample instant (a whole ms on the grid)"
    at_ms = t["seconds"] * 1000 + t["microseconds"] // 1000
    assert (at_ms - epoch_ms) % IMU_MS == 0, f"sample at {at_ms} ms is off the {IMU_MS} ms grid from {epoch_ms}"
    k = (at_ms - epoch_ms) // IMU_MS
    s = model.sample(k * IMU_MS / 1000.0)
    assert (imu["p"], imu["q"], imu["r"]) == pytest.approx(s.rates, rel=1e-12, abs=1e-12)
    sf = imu["specificForce"]
    assert (sf["x"], sf["y"], sf["z"]) == pytest.approx(s.specific_force, rel=1e-12, abs=1e-12)
    dv = imu["deltaVelocity"]
    assert dv["y"] == pytest.approx(s.specific_force[1] * IMU_MS / 1000.0, rel=1e-12, abs=1e-12)
    return k


def test_an_idle_node_sleeps_and_a_dump_reads_the_current_sample(program: Path, config: Path) -> None:
    """No subscriber: the node wakes at most IDLE_WAKEUPS_PER_S a second, yet `dump` after a long sleep gives
    the sample of the latest instant (not the one at its last wake-up), equal to the model's at that instant,
    and its counter counts every instant since the first sample. A `flows` report every 20 ms with nothing
    delivered is neither printed nor woken for (the launcher learns nothing from an unchanged one); the
    `flows` command still answers."""
    from uavbus import Catalogue

    cat = Catalogue.load(catalogue_for(program))
    model = FlightModel(MOTION)
    epoch_ms = int(time.monotonic() * 1000.0) - 5000  # the path started 5 s ago: t > 0 from the first sample
    with ProcessGroup() as group:
        vehicle, _ = start_vehicle(group, program, config, epoch_ms, "--flows-ms", "20")
        imu0, _, _ = dump(vehicle, cat, "imuOutPrimary")
        k0 = check_on_grid(imu0, epoch_ms, model)
        w0 = vehicle.request_stats()["wakeups"]
        t0 = time.monotonic()
        time.sleep(2.0)
        w1 = vehicle.request_stats()["wakeups"]
        idle_s = time.monotonic() - t0
        imu1, before, after = dump(vehicle, cat, "imuOutPrimary")
        k1 = check_on_grid(imu1, epoch_ms, model)
        assert vehicle.all("flows") == [], "periodic flows events with nothing delivered"
        m = vehicle.mark()
        vehicle.send("flows")
        assert vehicle.wait_event("flows", 5.0, since=m)["flows"] == []
    woke = w1 - w0 - 1  # the second `stats` command wakes it once
    assert woke <= IDLE_WAKEUPS_PER_S * idle_s, f"{woke} wake-ups in {idle_s:.2f} s with nobody reading a sample"
    at_ms = epoch_ms + k1 * IMU_MS
    assert before - IMU_MS - 1 <= at_ms <= after + 1, (before, at_ms, after)  # the instant `dump` was read at
    assert k1 - k0 >= 2.0 * 1000 / IMU_MS
    assert imu1["sampleCount"] - imu0["sampleCount"] == k1 - k0, "the counter counts every sample instant"


def test_a_subscribed_model_is_delivered_at_its_rate_with_every_sample_fresh(program: Path, config: Path,
                                                                            tmp_path: Path) -> None:
    """A GCS subscribing to imuOutPrimary every 10 ms gets it at that rate, and every publication carries the
    sample of the latest grid instant at or before the moment it was sent (lazy sampling leaves nothing stale
    behind a publication), with the model's values.

    The send instants come from the vehicle's own log (`--record-tx`: each transmitted frame with the `now` of
    the turn that sent it, CLOCK_MONOTONIC as the epoch). Judged at the GCS by "90 % of the samples distinct",
    as before, this failed on a busy machine (165 of 200 in a serial pass beside other work): a publication
    sent a few ms late falls in the next grid cell, and the next one, on time, in the same cell. That is what
    on-time sampling read late gives too, not stale storage; a sample older than its send instant is."""
    from uavbus import Catalogue, Node
    from uavbus.logfile import LogReader

    cat = Catalogue.load(catalogue_for(program))
    model = FlightModel(MOTION)
    epoch_ms = int(time.monotonic() * 1000.0)
    log = tmp_path / "vehicle.ublog"
    with ProcessGroup() as group:
        vehicle, vport = start_vehicle(group, program, config, epoch_ms, "--record", str(log), "--record-tx")
        gcs = Node(cat, config=config, node="gcs")
        try:
            gcs.open_port("gcsRadio", f"udp:bind=127.0.0.1:0,peer=127.0.0.1:{vport}")
            admin = gcs.admin("gcs1")
            row = admin.add(content="imuOutPrimary", source="rmax1ob1", destination="gcs1", period_ms=IMU_MS)
            gcs.bind("imuOutPrimary")
            admin.activate(row)
            t0 = None
            got = []
            for m in gcs.messages(timeout=5.0):
                if m.name != "imuOutPrimary":
                    continue
                if t0 is None:
                    t0 = time.monotonic()  # counting from the first delivery: the subscription is up
                    continue
                got.append(cat.decode("imuOutPrimary", m.raw))
                if time.monotonic() - t0 >= 2.0:
                    break
            assert t0 is not None, "no imuOutPrimary at all"
            span_s = time.monotonic() - t0
        finally:
            gcs.close()
    assert len(got) >= 0.5 * span_s * 1000 / IMU_MS, f"{len(got)} samples in {span_s:.2f} s at {IMU_MS} ms"
    ks = [check_on_grid(imu, epoch_ms, model) for imu in got]
    assert all(b >= a for a, b in zip(ks, ks[1:])), "samples went back in time"
    # Every publication the vehicle sent: the sample of the latest instant at or before its send instant.
    imu_id = cat.instance("imuOutPrimary").id
    sent = [(r.t_ms, check_on_grid(cat.decode("imuOutPrimary", r.payload), epoch_ms, model))
            for r in LogReader(log) if r.dir == "tx" and r.header.admin == 0 and r.header.dir_id == imu_id]  # DATA
    assert len(sent) >= len(got), (len(sent), len(got))
    stale = [(t, k) for t, k in sent if k != (t - epoch_ms) // IMU_MS]
    assert not stale, f"{len(stale)} of {len(sent)} publications carried another instant's sample: {stale[:5]}"
    # and what the GCS got is what was sent
    assert set(ks) <= {k for _, k in sent}
    # the samples move on with the publications: as many distinct ones as distinct grid cells they were sent in
    assert len({k for _, k in sent}) == len({(t - epoch_ms) // IMU_MS for t, _ in sent})
