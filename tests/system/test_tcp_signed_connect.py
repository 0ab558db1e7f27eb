"""Signed TCP that always connects (issue 29, item 1), with real `uavbus_node` processes on 127.0.0.1.

- The listener only publishes and the client has nothing to send: the client's link hello (a signed
  link-local CHALLENGE sent on connecting, ub_tcp.h) proves it, the listener adopts the connection and the
  publication arrives at its rate within a second of connecting. Before, nothing ever flowed (601 of 601
  frames failed: the candidate waited for a frame the client never sent, expired, and was replaced).
- An outsider without the key holds every candidate slot of the listener with plain connections, from
  two addresses, each renewed long before it expires; the genuine client restarts and is back within a
  second (before: 8 s in one run and the whole 20 s of the attack in the next).

The time back is measured from the restarted client's `ready` to the first delivery its `flows` event
reports (`first_ms`, CLOCK_MONOTONIC like `t_ms`).
"""

from __future__ import annotations

import json
import socket
import threading
import time
from pathlib import Path
from typing import Any

import pytest

from uavbus.sim.process import NodeProcess, ProcessGroup
from uavbus.sim.secure import signed_config

pytestmark = pytest.mark.timeout(90)

CONFIG = {
    "system": "tcp-signed-connect",
    "entities": [
        {"name": "rmax1ob1", "links": ["radio"], "linktoentity": {"gcs1": ["radio"]}},
        {"name": "gcs1", "links": ["gcsRadio"], "linktoentity": {"rmax1ob1": ["gcsRadio"]}},
    ],
    "nodes": {"vehicle": ["rmax1ob1"], "gcs": ["gcs1"]},
}
GPS_MS = 100


@pytest.fixture
def config(tmp_path: Path) -> Path:
    plain = tmp_path / "tcp_connect.json"
    plain.write_text(json.dumps(CONFIG, indent=1))
    return signed_config(plain, tmp_path / "signed")


def start_listener(group: ProcessGroup, program: Path, config: Path) -> tuple[NodeProcess, int]:
    """The vehicle listens and publishes gpsOut to gcs1 on its own (a local row): nothing asks for it."""
    proc = group.spawn([program, "--config", config, "--node", "vehicle", "--port", "radio=tcp:listen=127.0.0.1:0",
                        "--produce", "rmax1ob1", "--publish", f"rmax1ob1:gpsOut>gcs1/{GPS_MS}", "--stats-ms", "0"],
                       "vehicle", ready_timeout=8.0)
    return proc, int(proc.wait_ready()["ports"]["radio"]["local_port"])


def client_argv(program: Path, config: Path, port: int, subscribe: bool = False) -> list[Any]:
    """The GCS connects. Without `subscribe` it only receives (the vehicle's publication is its own row), so
    it has nothing of its own to send; with it, its subscription sends PUB_REQUESTs (a client that talks)."""
    sub = ["--subscribe", f"gcs1:gpsOut@rmax1ob1/{GPS_MS}"] if subscribe else []
    return [program, "--config", config, "--node", "gcs", "--port", f"gcsRadio=tcp:connect=127.0.0.1:{port}",
            *sub, "--flows-ms", "100", "--stats-ms", "0"]


def gps_flow(ev: dict[str, Any]) -> dict[str, Any] | None:
    for f in ev.get("flows", []):
        if f.get("content") == "gpsOut" and f.get("source") == "rmax1ob1" and f.get("count", 0) > 0:
            return f
    return None


def first_delivery_ms(proc: NodeProcess, since: int, timeout: float) -> tuple[int, dict[str, Any]]:
    """CLOCK_MONOTONIC ms of the first gpsOut delivery the client reports after event index `since`."""
    ev = proc.wait_event(lambda e: e.get("event") == "flows" and gps_flow(e) is not None, timeout, since=since,
                         what="gpsOut delivery")
    flow = gps_flow(ev)
    assert flow is not None
    return int(flow["first_ms"]), flow


def tcp_counters(proc: NodeProcess, link: str) -> dict[str, Any]:
    return proc.request_stats()["links"][link]["tcp"]


def test_a_listener_that_only_publishes_delivers_within_a_second_of_connecting(program: Path,
                                                                              config: Path) -> None:
    with ProcessGroup() as group:
        vehicle, port = start_listener(group, program, config)
        gcs = group.spawn(client_argv(program, config, port), "gcs", ready_timeout=8.0)
        ready = gcs.wait_ready()
        first, _ = first_delivery_ms(gcs, 0, timeout=10.0)
        back_s = (first - int(ready["t_ms"])) / 1000.0
        assert back_s < 1.0, f"first gpsOut {back_s:.2f} s after the client was ready"
        # ...and then at its rate: 2 s later, about 20 more.
        mark = gcs.mark()
        time.sleep(2.0)
        flows = gcs.wait_event(lambda e: e.get("event") == "flows" and gps_flow(e) is not None, 3.0, since=mark)
        flow = gps_flow(flows)
        assert flow is not None
        rate = (flow["count"] - 1) / max((flow["last_ms"] - flow["first_ms"]) / 1000.0, 1e-3)
        assert 0.8 * 1000 / GPS_MS <= rate <= 1.2 * 1000 / GPS_MS, flow
        t = tcp_counters(vehicle, "radio")
        assert t["state"] == "up" and t["adopted"] == 1 and t["candidates_expired"] == 0, t
        assert tcp_counters(gcs, "gcsRadio")["hellos"] == 1
        print(f"\nlistener-only signed TCP: first delivery {back_s * 1000:.0f} ms after the client was ready, "
              f"then {rate:.1f} Hz (published at {1000 / GPS_MS:.0f} Hz)")


class SlotHolder:
    """An outsider without the key: plain TCP connections to the listener from several local addresses,
    each closed and opened again every `renew_s` (long before the listener's candidate expiry), so that
    the listener's candidate slots are always held."""

    def __init__(self, port: int, hosts: tuple[str, ...], per_host: int, renew_s: float) -> None:
        self.port, self.renew_s = port, renew_s
        self.slots: list[tuple[str, socket.socket | None]] = [(h, None) for h in hosts for _ in range(per_host)]
        self.connects = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True, name="slot-holder")

    def _open(self, host: str) -> socket.socket:
        s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        s.bind((host, 0))
        s.connect(("127.0.0.1", self.port))
        self.connects += 1
        return s

    def _run(self) -> None:
        i = 0
        while not self._stop.is_set():
            host, old = self.slots[i]
            if old is not None:
                old.close()
            self.slots[i] = (host, self._open(host))
            i = (i + 1) % len(self.slots)
            self._stop.wait(self.renew_s / len(self.slots))

    def start(self) -> None:
        for i, (host, _) in enumerate(self.slots):
            self.slots[i] = (host, self._open(host))
        self._thread.start()

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2.0)
        for _, s in self.slots:
            if s is not None:
                s.close()


def test_plain_connections_holding_the_slots_do_not_keep_a_restarted_client_out(program: Path,
                                                                                config: Path) -> None:
    with ProcessGroup() as group:
        vehicle, port = start_listener(group, program, config)
        # A client that talks (its subscription's requests): what is measured is the slots alone.
        gcs = group.spawn(client_argv(program, config, port, subscribe=True), "gcs", ready_timeout=8.0)
        gcs.wait_ready()
        first_delivery_ms(gcs, 0, timeout=10.0)
        # Every candidate slot held (4: two addresses at their bound of 2), each renewed every 1 s,
        # a tenth of the listener's 10 s expiry.
        holder = SlotHolder(port, ("127.0.0.2", "127.0.0.3"), per_host=2, renew_s=1.0)
        holder.start()
        try:
            time.sleep(1.5)
            held = tcp_counters(vehicle, "radio")["candidates_open"]
            backs = []
            for _ in range(3):     # the genuine client restarts three times under the attack
                ready = gcs.restart(ready_timeout=8.0)
                since = gcs.mark()
                first, _ = first_delivery_ms(gcs, since, timeout=25.0)
                backs.append((first - int(ready["t_ms"])) / 1000.0)
                time.sleep(1.0)
            t = tcp_counters(vehicle, "radio")
        finally:
            holder.close()
        assert max(backs) < 1.0, f"back after restarts in {backs} s"
        assert held == 4, "the outsider did not hold every candidate slot before the restarts"
        assert t["state"] == "up" and t["adopted"] == 4 and t["candidates_evicted"] >= 3, t
        print(f"\nslots held by {holder.connects} plain connections (renewed every 1 s): the restarted client "
              f"was back in {', '.join(f'{b * 1000:.0f}' for b in backs)} ms")
