"""The Zenoh bridge's batch format 1 (docs/bridges.md "Batches") and a burst through two bridges.

  - encode/decode round trip, edge sizes included (1 frame, 1-byte and 65535-byte frames, 65535 frames),
    read by both readers: Python's (batch_spans, the reference) and C's (ub_batch_check, the bridge's);
  - every damaged or foreign payload is refused whole, by both readers, with the counter that names why;
  - two ZenohBridge objects with real Zenoh sessions on tcp/127.0.0.1 (in this process, so the test drives
    both loops): a burst larger than one sample from node A reaches node B complete and in order, in fewer
    samples than frames (packed by the C batch link, ub_batchlink.h); a foreign, a bare-frame (pre-batch bridge) and a truncated sample published on the
    bridge's keys are counted by reason and dropped, and frames after them still pass.
"""

from __future__ import annotations

import ctypes
import json
import threading
import time

import pytest

from bridge_testutil import close_all, two_bridges_config
from uavbus import Node
from uavbus._bindings import ub_batchlink
from uavbus.bridges.zenoh_bridge import (BATCH_HEADER, BatchError, ZenohBridge, batch_spans, encode_batch,
                                         set_timer_slack, zenoh_config)
from uavbus.sim.hitl import catalogue_for
from uavbus.sim.portalloc import PortAllocator

zenoh = pytest.importorskip("zenoh", reason="eclipse-zenoh is in the `test` extras (make setup installs it)")


def frames_of(payload: bytes) -> list[bytes]:
    """The Python reader's frames, after checking that the C reader (ub_batch_check) agrees."""
    assert ub_batchlink.ub_batch_check(payload) == (ub_batchlink.OK, len(batch_spans(payload)))
    return [payload[at:at + n] for at, n in batch_spans(payload)]


@pytest.mark.parametrize("frames", [
    [b"\xa5\x5b" + bytes(62)],
    [b"x"],
    [bytes([i % 251]) * (1 + i * 37 % 1200) for i in range(50)],
    [b"\xff" * 0xFFFF, b"z"],
])
def test_batch_round_trip(frames):
    payload = encode_batch(frames)
    assert payload[:3] == b"\xa5\xba\x01"
    assert len(payload) == BATCH_HEADER + sum(2 + len(f) for f in frames)
    assert frames_of(payload) == frames


def test_batch_of_65535_frames_and_the_limits():
    frames = [bytes([i & 0xFF]) for i in range(0xFFFF)]
    assert frames_of(encode_batch(frames)) == frames
    with pytest.raises(ValueError):
        encode_batch(frames + [b"a"])
    with pytest.raises(ValueError):
        encode_batch([])
    with pytest.raises(ValueError):
        encode_batch([b"a", b""])
    with pytest.raises(ValueError):
        encode_batch([bytes(0x10000)])


def _reason(payload: bytes) -> str:
    """Why the Python reader refuses `payload`, checked to be the C reader's reason (the bridge's)."""
    with pytest.raises(BatchError) as exc:
        batch_spans(payload)
    status, count = ub_batchlink.ub_batch_check(payload)
    assert (ub_batchlink.REASONS.get(status), count) == (exc.value.reason, 0), payload[:8]
    return exc.value.reason


def test_damaged_and_foreign_payloads_are_refused_by_reason():
    good = encode_batch([b"\xa5\x5b" + bytes(70), b"\xa5\x5b" + bytes(80)])
    assert _reason(b"") == "batch_foreign"
    assert _reason(b"hello zenoh") == "batch_foreign"
    assert _reason(b"\xa5") == "batch_foreign"
    assert _reason(b"\xa5\x5b" + bytes(70)) == "batch_version"        # a bare frame: a pre-batch bridge
    assert _reason(b"\xa5\xba\x02" + good[3:]) == "batch_version"     # a later format
    assert _reason(good[:4]) == "batch_malformed"                      # header cut
    assert _reason(good[:-1]) == "batch_malformed"                     # last frame cut
    assert _reason(good + b"\0") == "batch_malformed"                  # bytes after the last frame
    assert _reason(good[:3] + b"\x03\x00" + good[5:]) == "batch_malformed"  # count says 3, holds 2
    assert _reason(good[:3] + b"\x00\x00") == "batch_malformed"        # no frames
    assert _reason(good[:5] + b"\x00\x00" + good[7:]) == "batch_malformed"  # a zero-length frame
    assert len(batch_spans(good)) == 2


def _config(path, ports: PortAllocator, batch: bool = False) -> None:
    a = {k: ports.port() for k in ("A", "B", "gwA", "gwB")}
    path.write_text(json.dumps(two_bridges_config("zbatch", a, batch=batch)))


def _udp(node, link: str) -> dict:
    return node.port_info(link)["udp"]


def _two_sites(tmp_path, uavbus_node, closers, batch: bool):
    """Nodes A, B, gwA, gwB on their configured site ports (UDP, batching or not) and two Zenoh sessions joined
    over TCP (gwA's side listening); everything opened is appended to `closers`."""
    catalogue = catalogue_for(uavbus_node)
    ports = PortAllocator()
    cfg = tmp_path / "zbatch.json"
    _config(cfg, ports, batch=batch)
    endpoint = f"tcp/127.0.0.1:{ports.port()}"
    nodes = {}
    for name in ("A", "B", "gwA", "gwB"):
        n = nodes[name] = Node(catalogue, config=cfg, node=name)
        closers.append(n.close)
        n.open_ports_from_config()
    sa = zenoh.open(zenoh_config("peer", [endpoint], []))
    closers.append(sa.close)
    sb = zenoh.open(zenoh_config("peer", [], [endpoint]))
    closers.append(sb.close)
    return nodes, sa, sb


@pytest.mark.parametrize("site_batch", [False, True], ids=["datagram_per_frame", "site_batch"])
def test_burst_through_two_bridges_arrives_whole_in_order(tmp_path, uavbus_node, site_batch):
    """With site_batch every site port says "batch": true: A's send_many() of 25 frames and gwB's sample of
    ~10 frames each leave in shared datagrams, split back into every frame, in order, by gwA and B."""
    closers = []
    try:
        nodes, sa, sb = _two_sites(tmp_path, uavbus_node, closers, batch=site_batch)
        # Small samples (~10 frames of gpsOut each) so that the burst takes many, each checked.
        ga = ZenohBridge(nodes["gwA"], "zenoh", sa, "uavbus/zbatch", batch_bytes=1024)
        closers.append(ga.close)
        gb = ZenohBridge(nodes["gwB"], "zenoh", sb, "uavbus/zbatch", batch_bytes=1024)
        closers.append(gb.close)
        pub = nodes["A"].publisher("srcA", "gpsOut", to="dstB")
        nodes["B"].bind("gpsOut")
        got: list[int] = []
        nodes["B"].on_data(lambda m: got.append(m.value["solutionCount"]))

        def turn() -> None:
            for bridge in (ga, gb):
                bridge.turn()
            nodes["B"].poll(0.001)

        deadline = time.monotonic() + 10
        while not got and time.monotonic() < deadline:  # sessions and routes up
            pub.directory.solutionCount = 0
            pub.send()
            turn()
        assert got, f"nothing crossed: gwA {ga.stats()} gwB {gb.stats()}"
        for _ in range(20):
            turn()
        got.clear()
        a0, b0 = ga.stats(), gb.stats()
        n = 600  # many samples; 25 per turn stay within the UDP sockets' buffers (not the bridge's concern)
        before = {k: _udp(nodes[node], link) for k, node, link in (("a", "A", "l"), ("gwA", "gwA", "site"),
                                                                    ("gwB", "gwB", "site"), ("b", "B", "l"))}
        for k in range(1, n + 1, 25):
            if site_batch:
                pub.send_many(range(k, k + 25), field="solutionCount")
            else:
                for v in range(k, k + 25):
                    pub.directory.solutionCount = v
                    pub.send()
            turn()
        deadline = time.monotonic() + 10
        while len(got) < n and time.monotonic() < deadline:
            turn()
        assert got == list(range(1, n + 1)), (len(got), got[:5], ga.stats(), gb.stats())
        # Every sample gwA published during the burst reaches gwB, compared as counts since the burst began
        # and once both have settled. Not since the start: a warm-up frame gwA publishes before its session
        # has learnt of gwB's subscription goes nowhere (Zenoh drops a put no subscriber matches), so the
        # totals differ by the warm-up's luck; they did, about once in 40 loaded runs.
        deadline = time.monotonic() + 5
        a, b = ga.stats(), gb.stats()
        while b["samples_in"] - b0["samples_in"] != a["samples_out"] - a0["samples_out"] and time.monotonic() < deadline:
            turn()
            a, b = ga.stats(), gb.stats()
        assert b["samples_in"] - b0["samples_in"] == a["samples_out"] - a0["samples_out"], (a0, a, b0, b)
        assert a["published"] - a0["published"] == n == b["received"] - b0["received"], (a0, a, b0, b)
        assert b["rejected"] == 0, b
        assert a["samples_out"] < a["published"], a  # batched: fewer samples than frames
        # The site links: frames and datagrams each port counted during the burst (hellos and requests
        # ride along, so at least n frames).
        d = {k: {c: _udp(nodes[node], link)[c] - before[k][c] for c in ("frames_out", "datagrams_out", "frames_in",
                                                                       "datagrams_in")}
             for k, node, link in (("a", "A", "l"), ("gwA", "gwA", "site"), ("gwB", "gwB", "site"), ("b", "B", "l"))}
        assert d["a"]["frames_out"] >= n and d["gwB"]["frames_out"] >= n, d
        if site_batch:  # several frames per datagram both ways: A's 25 per send_many, gwB's per sample
            assert d["a"]["datagrams_out"] * 5 <= d["a"]["frames_out"], d
            assert d["gwA"]["datagrams_in"] * 5 <= d["gwA"]["frames_in"], d
            assert d["gwB"]["datagrams_out"] * 3 <= d["gwB"]["frames_out"], d
            assert d["b"]["datagrams_in"] * 3 <= d["b"]["frames_in"], d
        else:  # one datagram per frame
            assert d["a"]["datagrams_out"] == d["a"]["frames_out"], d
            assert d["gwB"]["datagrams_out"] == d["gwB"]["frames_out"], d
        if site_batch:
            return  # the refusals below do not depend on the site links

        # Foreign, pre-batch and truncated samples on gwB's keys: refused by reason, the next frames pass.
        spy = sa.declare_publisher("uavbus/zbatch/dstB/srcA/gpsOut/data")
        closers.insert(0, spy.undeclare)
        good = encode_batch([b"\xa5\x5b" + bytes(70)])
        for bad in (b"not a batch", b"\xa5\x5b" + bytes(70), good[:-3]):
            spy.put(bad)
        got.clear()
        pub.directory.solutionCount = 7777
        pub.send()
        deadline = time.monotonic() + 10
        b = gb.stats()
        while (not got or sum(b[r] for r in ("batch_foreign", "batch_version", "batch_malformed")) < 3) \
                and time.monotonic() < deadline:
            turn()
            b = gb.stats()
        assert (b["batch_foreign"], b["batch_version"], b["batch_malformed"]) == (1, 1, 1), b
        assert got == [7777], got
        assert b["rejected"] == 0, b
        assert sorted(e["reason"] for e in gb.events if e.get("event") == "refused") == \
            ["batch_foreign", "batch_malformed", "batch_version"]
    finally:
        close_all(closers)


@pytest.mark.parametrize("in_zenoh_thread", [False, True], ids=["python_thread", "zenoh_network_thread"])
def test_a_sample_taken_on_a_zenoh_thread_leaves_batching_site_ports_at_once(tmp_path, uavbus_node, in_zenoh_thread):
    """gwB takes samples on a Zenoh callback (rx_in_callback, as `uavbus bridge zenoh` runs; on the Python
    thread Zenoh wakes for it (--sample-thread python), or on Zenoh's network thread itself, the default) and its
    site port batches ("batch": true): each sample's frames are flushed from that thread in shared datagrams,
    so B gets them although gwB's loop never turns. Without that flush they would wait in gwB's UDP queue for
    a turn that never comes here."""
    closers = []
    try:
        nodes, sa, sb = _two_sites(tmp_path, uavbus_node, closers, batch=True)
        ga = ZenohBridge(nodes["gwA"], "zenoh", sa, "uavbus/zbatch")
        closers.append(ga.close)
        gb = ZenohBridge(nodes["gwB"], "zenoh", sb, "uavbus/zbatch", in_zenoh_thread=in_zenoh_thread)
        closers.append(gb.close)
        gb.rx_in_callback = True  # from here on gwB's node is touched under its node_lock only
        pub = nodes["A"].publisher("srcA", "gpsOut", to="dstB")
        nodes["B"].bind("gpsOut")
        got: list[int] = []
        nodes["B"].on_data(lambda m: got.append(m.value["solutionCount"]))
        deadline = time.monotonic() + 10
        while not got and time.monotonic() < deadline:  # sessions and routes up, both loops turning
            pub.directory.solutionCount = 0
            pub.send()
            ga.turn()
            with gb.node_lock:
                gb.turn()
            nodes["B"].poll(0.005)
        assert got, f"nothing crossed: gwA {ga.stats()} gwB {gb.stats()}"
        # The warm-up sent a 0 per turn until the first arrived; the others are still on their way (Zenoh,
        # gwB's thread). Let them land before counting, or a late 0 opens the burst's list (seen once in a
        # loaded run): turn until 300 ms pass with nothing new.
        quiet_since, seen = time.monotonic(), len(got)
        deadline = time.monotonic() + 5
        while time.monotonic() - quiet_since < 0.3 and time.monotonic() < deadline:
            ga.turn()
            with gb.node_lock:
                gb.turn()  # whatever it queued is sent
            nodes["B"].poll(0.005)
            if len(got) != seen:
                quiet_since, seen = time.monotonic(), len(got)
        assert set(got) == {0}, got
        got.clear()
        site0, samples0 = _udp(nodes["gwB"], "site"), gb.counters["samples_in"]
        pub.send_many(range(1, 31), field="solutionCount")
        deadline = time.monotonic() + 10
        while len(got) < 30 and time.monotonic() < deadline:
            ga.turn()
            nodes["B"].poll(0.005)
        site = _udp(nodes["gwB"], "site")
        sent = site["frames_out"] - site0["frames_out"]
        assert got == list(range(1, 31)), (got, gb.stats(), site)
        # gwB.turn() was not called since: the Zenoh thread that took each sample sent its frames.
        assert sent >= 30 and site["datagrams_out"] - site0["datagrams_out"] < sent, (site0, site)
        assert 1 <= gb.counters["samples_in"] - samples0 < 30, gb.counters  # whole samples made them shared
    finally:
        gb_ = locals().get("gb")
        if gb_ is not None:
            gb_.rx_in_callback = False
        close_all(closers)


def _one_bridge(tmp_path, uavbus_node, closers, **kw):
    """Node A and bridge gwA (real UDP between them, a real Zenoh session with nobody on the other end)."""
    catalogue = catalogue_for(uavbus_node)
    ports = PortAllocator()
    cfg = tmp_path / "zbatch.json"
    _config(cfg, ports)
    nodes = {}
    for name in ("A", "gwA"):
        n = nodes[name] = Node(catalogue, config=cfg, node=name)
        closers.append(n.close)
        n.open_ports_from_config()
    session = zenoh.open(zenoh_config("peer", [f"tcp/127.0.0.1:{ports.port()}"], []))
    closers.append(session.close)
    gw = ZenohBridge(nodes["gwA"], "zenoh", session, "uavbus/zbatch", **kw)
    closers.append(gw.close)
    pub = nodes["A"].publisher("srcA", "gpsOut", to="dstB")
    return gw, pub


def _ends(gw) -> tuple[int, int, int, int]:
    s = gw.stats()
    return s["flush_idle"], s["flush_full"], s["flush_aged"], s["flush_woken"]


def test_a_batch_leaves_when_the_site_goes_idle_not_on_a_timer(tmp_path, uavbus_node):
    """ub_ports_drain() through the bridge's turn: a lone frame leaves in the turn that reads it, once the
    site's socket stayed quiet for the idle gap; frames that keep coming closer than the gap join the same
    sample however long that takes (up to the age bound), and the next frame after the gap starts a new one."""
    closers = []
    try:
        idle = 0.15
        gw, pub = _one_bridge(tmp_path, uavbus_node, closers, idle_us=int(idle * 1e6), age_us=1_000_000)
        pub.send()  # loopback UDP: in gwA's socket when send() returns
        t = time.monotonic()
        assert gw.turn() == 1
        took = time.monotonic() - t
        assert (gw.counters["samples_out"], gw.counters["published"]) == (1, 1)
        assert _ends(gw) == (1, 0, 0, 0)
        assert took >= idle * 0.9, took  # it waited for company: the idle gap, not less
        assert gw.zlink.pending == 0

        # Six frames 20 ms apart (gap 150 ms): one turn, one sample, six frames.
        def sender():
            for _ in range(5):
                time.sleep(0.02)
                pub.send()
        pub.send()
        th = threading.Thread(target=sender)
        th.start()
        try:
            moved = gw.turn()
        finally:
            th.join()
        assert moved == 6, moved
        assert (gw.counters["samples_out"], gw.counters["published"]) == (2, 7)
        assert _ends(gw) == (2, 0, 0, 0)
    finally:
        close_all(closers)


def test_batch_size_and_age_bound_the_wait_and_a_sample_from_zenoh_cuts_it_short(tmp_path, uavbus_node):
    """The bounds of the drain: --batch-bytes pending ends it at once (cut into samples of at most that
    size, nothing lost), a site that never goes quiet is cut at --batch-age-us, and a sample waiting for
    the loop (the wake pipe) ends it too."""
    closers = []
    try:
        gw, pub = _one_bridge(tmp_path, uavbus_node, closers, batch_bytes=400, idle_us=1_000_000,
                              age_us=1_000_000)
        for _ in range(10):
            pub.send()
        t = time.monotonic()
        assert gw.turn() == 10
        assert time.monotonic() - t < 0.9  # not the idle gap
        assert _ends(gw) == (0, 1, 0, 0)
        assert gw.counters["published"] == 10 and gw.counters["samples_out"] >= 3 and gw.zlink.pending == 0

        pub.send()
        gw._wake()  # as a Zenoh thread does when it queues a sample
        t = time.monotonic()
        assert gw.turn(woken=False) == 1
        assert time.monotonic() - t < 0.9
        assert _ends(gw) == (0, 1, 0, 1)
    finally:
        close_all(closers)
    closers = []
    try:
        gw, pub = _one_bridge(tmp_path, uavbus_node, closers, idle_us=200_000, age_us=100_000)
        stop = threading.Event()

        def sender():  # every 5 ms for up to 2 s: never quiet for the 200 ms gap
            while not stop.wait(0.005):
                pub.send()
        th = threading.Thread(target=sender)
        th.start()
        try:
            time.sleep(0.01)
            t = time.monotonic()
            moved = gw.turn()
            took = time.monotonic() - t
        finally:
            stop.set()
            th.join()
        assert _ends(gw) == (0, 0, 1, 0)
        assert 0.09 <= took < 0.5 and moved >= 2, (took, moved)
    finally:
        close_all(closers)


def test_the_loop_threads_timer_slack_is_set_and_only_its_own():
    """The bridge's loop sets its own thread's timer slack (its idle gaps sleep by it: 20 us took ~87 us with
    Linux's 50 us default); 0 leaves it; other threads keep theirs."""
    seen: dict[str, int] = {}

    def slack() -> int:  # the calling thread's (PR_GET_TIMERSLACK; /proc shows the main thread's only)
        return ctypes.CDLL(None).prctl(30, 0, 0, 0, 0)

    def loop_thread() -> None:
        seen["before"] = slack()
        seen["zero"] = int(set_timer_slack(0))
        seen["after_zero"] = slack()
        seen["set"] = int(set_timer_slack(1000))
        seen["after"] = slack()

    t = threading.Thread(target=loop_thread)
    t.start()
    t.join()
    assert seen["zero"] == 0 and seen["after_zero"] == seen["before"], seen
    assert seen["set"] == 1 and seen["after"] == 1000, seen
    assert slack() == seen["before"]  # this thread's is untouched
