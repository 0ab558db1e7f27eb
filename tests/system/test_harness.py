"""The simulation harness on its own: null-modem, port allocator, Table 2 builder, process control."""

from __future__ import annotations

import os
import select
import socket
import sys
import time
from pathlib import Path

import pytest

from uavbus.sim import NodeError, NullModem, PortAllocator, ProcessGroup, RelayFaults, table2
from uavbus.sim.metrics import StreamMeter, SummaryRow, largest_gap, percentile, render_table

REPO = Path(__file__).resolve().parents[2]
FAKE = [sys.executable, str(Path(__file__).with_name("fake_node.py"))]

pytestmark = pytest.mark.timeout(30)


def _open(path: str) -> int:
    return os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)


def _read_until(fd: int, n: int, timeout: float = 3.0) -> bytes:
    out = b""
    deadline = time.monotonic() + timeout
    while len(out) < n and time.monotonic() < deadline:
        r, _, _ = select.select([fd], [], [], 0.05)
        if r:
            out += os.read(fd, 4096)
    return out


def _is_subsequence(needle: bytes, hay: bytes) -> bool:
    it = iter(hay)
    return all(b in it for b in needle)


def test_nullmodem_crosses_every_byte_value_both_ways() -> None:
    data = bytes(range(256)) * 4  # \r, \n, ^C, ^D, XON/XOFF...: a raw line must pass them all unchanged
    with NullModem("t") as nm:
        a, b = _open(nm.path_a), _open(nm.path_b)
        try:
            os.write(a, data)
            assert _read_until(b, len(data)) == data
            os.write(b, data[::-1])
            assert _read_until(a, len(data)) == data[::-1]
        finally:
            os.close(a)
            os.close(b)
        deadline = time.monotonic() + 2.0   # the relay counts after its write returns
        while nm.snapshot()["relayed"] != {"a>b": len(data), "b>a": len(data)} and time.monotonic() < deadline:
            time.sleep(0.01)
        assert nm.snapshot()["relayed"] == {"a>b": len(data), "b>a": len(data)}


def _garbled(seed: int, data: bytes) -> tuple[bytes, dict]:
    with NullModem("g", RelayFaults(chunk_max=7, garbage_p=0.2, garbage_max=5, seed=seed)) as nm:
        a, b = _open(nm.path_a), _open(nm.path_b)
        try:
            os.write(a, data)
            snap: dict = {}
            got = b""
            deadline = time.monotonic() + 3.0
            while time.monotonic() < deadline:
                got += _read_until(b, 1, 0.1)
                snap = nm.snapshot()
                if snap["relayed"]["a>b"] == len(data) and len(got) == len(data) + snap["garbage"]["a>b"]:
                    break
        finally:
            os.close(a)
            os.close(b)
    return got, snap


def test_nullmodem_chunking_and_garbage_are_seeded_and_counted() -> None:
    data = bytes((i * 37) & 0xFF for i in range(600))
    got, snap = _garbled(7, data)
    assert snap["garbage"]["a>b"] > 0 and snap["chunks"]["a>b"] > len(data) // 7
    assert len(got) == len(data) + snap["garbage"]["a>b"]   # every byte accounted for
    assert _is_subsequence(data, got)                      # the payload survives, in order
    assert snap["dropped"]["a>b"] == 0
    # Same seed and same reads -> same garbage. (Reads may split differently; the relay reads whole.)
    got2, snap2 = _garbled(7, data)
    assert snap2["garbage"] == snap["garbage"]


def test_allocator_ports_are_distinct_and_free_for_udp_and_tcp() -> None:
    alloc = PortAllocator()
    ports = [alloc.port() for _ in range(20)]
    assert len(set(ports)) == 20
    for p in ports[:5]:
        for kind in (socket.SOCK_DGRAM, socket.SOCK_STREAM):
            s = socket.socket(socket.AF_INET, kind)
            s.bind(("127.0.0.1", p))
            s.close()


def test_table2_builder_gives_each_link_one_crossed_connection() -> None:
    topo = table2(REPO / "examples/configs/table2.json")
    try:
        gcs, prim, sec, back = (topo.specs(n) for n in ("gcs", "primary", "secondary", "backup"))
        assert set(gcs) == {"gcsPortDatalink1", "gcsPortDatalink2"}
        assert set(prim) == {"onboardPortDatalink1", "onboardPortDatalink2", "onboardPortIPC", "onboardPortRelay"}
        assert set(sec) == {"onboard2PortIPC"} and set(back) == {"onboardPortDatalink1"}
        # UDP peers cross: each side's peer is the other's bind
        g = dict(kv.split("=") for kv in gcs["gcsPortDatalink1"][4:].split(","))
        p = dict(kv.split("=") for kv in prim["onboardPortDatalink1"][4:].split(","))
        assert g["peer"] == p["bind"] and p["peer"] == g["bind"] and g["bind"] != p["bind"]
        assert prim["onboardPortIPC"].replace("connect", "listen") == sec["onboard2PortIPC"]
        assert gcs["gcsPortDatalink2"].startswith("serial:device=/dev/pts/")
        assert gcs["gcsPortDatalink2"] != prim["onboardPortDatalink2"]
        assert topo.port_args("secondary") == ["--port", f"onboard2PortIPC={sec['onboard2PortIPC']}"]
    finally:
        topo.close()


def test_process_ready_commands_kill_restart_and_cleanup() -> None:
    with ProcessGroup() as group:
        p = group.spawn([*FAKE, "n1"], "n1", ready_timeout=10)
        assert p.last("ready")["node"] == "n1"
        assert p.request_stats()["node"] == {"n": 1}
        first_pid = p.pid
        p.kill()
        assert p.returncode == -9 and not p.running
        with pytest.raises(NodeError, match="not running"):
            p.send("stats")
        ev = p.restart(ready_timeout=10)
        assert ev["_run"] == 2 and p.pid != first_pid
        assert p.request_stats()["node"] == {"n": 1}   # a fresh process
        pid = p.pid
    assert not p.running
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)


def test_process_failing_before_ready_names_the_reason() -> None:
    with ProcessGroup() as group:
        with pytest.raises(NodeError, match=r"exited before ready .*status 2.*fake_node.py:1: bad port spec"):
            group.spawn([*FAKE, "n2", "--fail", "bad port spec"], "n2", ready_timeout=10)
        assert "n2" not in group.procs


def test_metrics_rate_percentiles_gap_and_table() -> None:
    m = StreamMeter("imuOut", "fcs20", "gcs1")
    for i in range(101):
        t = i * 0.02 + (1.0 if i > 50 else 0.0)  # 50 Hz with a 1 s outage after message 50
        m.add(t, latency_ms=float(i % 10))
    assert m.rate_hz(0.0, 1.0) == pytest.approx(50.0)
    start, length = largest_gap(m.times)
    assert start == pytest.approx(1.0) and length == pytest.approx(1.02)
    assert percentile([1, 2, 3, 4], 50) == 2.5 and percentile([], 50) is None
    row = SummaryRow.from_meter(m, hops=2, requested_hz=50, t0=0.0, t1=1.0,
                                dropped={"gcsPortDatalink1": {"crc": 3, "duplicate": 40}, "relay": {"duplicate": 2}},
                                transport_ms=[0.5, 1.5, 2.5], redundant=["gcsPortDatalink1"])
    assert row.rate_ok() and row.delivered == 101 and row.age_p50_ms == 4.0 and row.transport_p50_ms == 1.5
    # Copies on the redundant pair are expected; a duplicate anywhere else is reported with the losses.
    assert row.duplicates == {"gcsPortDatalink1": 40}
    assert row.dropped == {"gcsPortDatalink1": {"crc": 3}, "relay": {"duplicate": 2}}
    text = render_table([row])
    assert "fcs20 -> gcs1" in text and "gcsPortDatalink1:crc=3" in text and "1.5 / 2.5" in text


def _stalled_trace(m: StreamMeter, t0: float, stall_s: float, copies: int = 1) -> None:
    """A 50 Hz source (timeTag every 20 ms, 4 ms transport) whose receiver's harness stalled `stall_s`
    up to 5 ms after t0: what was sent meanwhile is handed over at t0 + 5 ms, in one burst (a CI run of 2026-11-27)."""
    for i in range(250):
        stamp = i * 0.02
        t = stamp + 0.004
        if t0 - stall_s <= t < t0 + 0.005:
            t = t0 + 0.005 + i * 1e-5
        for _ in range(copies):
            m.add(t, latency_ms=(t - stamp) * 1000.0, stamp=stamp)


def test_sent_rate_places_each_message_at_its_sources_stamp() -> None:
    t0 = 1.01
    m = StreamMeter("imuOut", "fcs20", "gcs1")
    _stalled_trace(m, t0, stall_s=0.32)
    # By receive instants the backlog lands inside the window: CI's 55.5 Hz for a 50 Hz source.
    assert m.rate_hz(t0, t0 + 3.0) == pytest.approx(55.4, abs=0.2)
    # By the source's stamps each message is where it was sent: late, neither extra nor missing.
    assert m.sent_rate_hz(t0, t0 + 3.0) == pytest.approx(50.0)
    assert m.sent_rate_hz(t0 + 10.0, t0 + 13.0) == 0.0  # nothing sent then: a silenced source reads 0
    twice = StreamMeter("imuOut", "fcs20", "gcs1")
    _stalled_trace(twice, t0, stall_s=0.0, copies=2)
    assert twice.sent_rate_hz(t0, t0 + 3.0) == pytest.approx(100.0, rel=0.01)  # every arrival counts
    bare = StreamMeter("imuOut", "fcs20", "gcs1")
    bare.add(1.0)
    bare.add(1.02)
    with pytest.raises(ValueError, match="no timeTag"):
        bare.sent_rate_hz(0.0, 2.0)


def test_table2_hops() -> None:
    topo = table2(REPO / "examples/configs/table2.json")
    try:
        assert topo.hops("gcs", "primary") == 1
        assert topo.hops("gcs", "backup") == 2      # the paper's IMU subscription: gcs1 -> rmax1ob1 -> fcs20
        assert topo.hops("backup", "secondary") == 2
    finally:
        topo.close()
