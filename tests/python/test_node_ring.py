"""The Python delivery path batches (issue #28, Build 1): deliveries go to a C-side ring (ub_rxring.h)
drained by one call; a burst larger than the ring loses nothing and keeps its order (the overflow takes the
per-delivery callback, counted in counters()["python"]["ring"]); Publisher.send_many() sends N frames in
one call. Two Python nodes over a C memlink, injected clock, a catalogue generated from a small header."""

from __future__ import annotations

import subprocess
import sys

import pytest

from uavbus import Catalogue, MemLink, Node
from uavbus._bindings.ub_error import InvalidArgumentError

HEADER = """#include <stdint.h>
typedef struct tick { uint32_t n; int16_t k; double x; } tick_t;
tick_t tickOut;
typedef struct flag { uint32_t n; _Bool on; } flag_t;
flag_t flagOut;
"""


def generate(tmp_path_factory: pytest.TempPathFactory, folder: str, name: str, header: str) -> Catalogue:
    d = tmp_path_factory.mktemp(folder)
    (d / f"{name}.h").write_text(header)
    subprocess.run([sys.executable, "-m", "uavbus.cli", "gen", str(d / f"{name}.h"), "--name", name, "-o",
                    str(d / "out")], check=True, capture_output=True)
    return Catalogue.load(d / "out" / f"{name}.catalogue.json")


@pytest.fixture(scope="module")
def cat(tmp_path_factory: pytest.TempPathFactory) -> Catalogue:
    return generate(tmp_path_factory, "ring", "ticks", HEADER)


def pair(cat: Catalogue, ring_records: int | None = None,
         binds: tuple[str, ...] = ("tickOut", "flagOut")) -> tuple[Node, Node, MemLink]:
    tx = Node(cat, clock=lambda: 5.0)
    rx = Node(cat, clock=lambda: 5.0, ring_records=ring_records)
    tx.add_entity("tx", local=True), tx.add_entity("rx")
    rx.add_entity("rx", local=True), rx.add_entity("tx")
    tx.add_link("tx", 0, "l0"), rx.add_link("rx", 0, "l0")
    tx.set_mask("tx", "rx", 1)
    for name in binds:
        rx.bind(name)
    return tx, rx, MemLink(tx, "l0", rx, "l0")


BURST = 60  # one memlink pump (64 frames deep) delivers it in one C call: more than a 16-record ring holds


def test_burst_larger_than_the_ring_loses_nothing_and_keeps_order(cat: Catalogue) -> None:
    tx, rx, link = pair(cat, ring_records=16)
    pub = tx.publisher("tx", "tickOut", "rx")
    for i in range(BURST):
        pub.directory.n = i
        pub.send()
    assert link.pump(10) == BURST
    got: list[int] = []
    rx.on_data(lambda m: got.append(m.value["n"]))
    assert rx.service() == BURST
    assert got == list(range(BURST))
    ring = rx.counters()["python"]["ring"]
    assert ring["recorded"] == 16 and ring["spilled"] == BURST - 16 and ring["dropped"] == 0  # reported
    # Drained: the next burst fits and goes to the ring again, after the spilled ones in order.
    for i in range(10):
        pub.directory.n = 100 + i
        pub.send()
    link.pump(10)
    rx.service()
    assert got[BURST:] == list(range(100, 110))
    assert rx.counters()["python"]["ring"]["recorded"] == 26


def test_receive_batch_in_order_through_the_overflow(cat: Catalogue) -> None:
    tx, rx, link = pair(cat, ring_records=16)
    pub = tx.publisher("tx", "tickOut", "rx")
    assert pub.send_many(list(range(BURST)), field="n") == BURST  # one link accepted each frame
    link.pump(10)
    rx.service(dispatch=False)
    batch = rx.receive()
    assert len(batch) == BURST
    assert batch.column("tickOut", "n") == list(range(BURST))  # ring records, then the spilled ones
    msgs = list(batch)  # Message objects only when asked
    assert [m.value["n"] for m in msgs] == list(range(BURST))
    assert [m.seq for m in msgs] == sorted(m.seq for m in msgs) and len({m.seq for m in msgs}) == BURST
    assert {m.source for m in msgs} == {"tx"} and msgs[0].name == "tickOut"
    assert rx.counters()["python"]["ring"]["spilled"] == BURST - 16
    assert len(rx.receive()) == 0  # drained


def test_send_many_fields_and_whole_images(cat: Catalogue) -> None:
    tx, rx, link = pair(cat)
    pub = tx.publisher("tx", "tickOut", "rx")
    pub.directory.x = 2.5
    pub.send_many([-3, 7, 9], field="k")
    assert pub.directory.k == 9  # the directory keeps the last value
    images = [cat.encode("tickOut", {"n": i, "k": -i, "x": i / 2}) for i in range(5)]
    pub.send_many(images)
    pub.send_many(b"".join(images[:2]))
    link.pump(10)
    got = [m.value for m in (rx.service(), rx._inbox)[1]]
    assert [v["k"] for v in got[:3]] == [-3, 7, 9] and all(v["x"] == 2.5 for v in got[:3])
    assert [v["n"] for v in got[3:]] == [0, 1, 2, 3, 4, 0, 1]
    with pytest.raises(InvalidArgumentError, match="not whole"):
        pub.send_many(b"\0" * 5)
    with pytest.raises(InvalidArgumentError, match="plain scalar"):
        pub.send_many([1], field="nope")


def test_receive_checks_what_a_c_node_would_refuse(cat: Catalogue) -> None:
    # flagOut has a bool: an image whose bool byte is not 0/1 is dropped and counted, in batches too.
    tx, rx, link = pair(cat)
    pub = tx.publisher("tx", "flagOut", "rx")
    good = cat.encode("flagOut", {"n": 1, "on": True})
    bad = bytearray(good)
    bad[4] = 7
    pub.send_many(good + bytes(bad) + good)
    link.pump(10)
    rx.service(dispatch=False)
    batch = rx.receive()
    assert batch.column("flagOut", "n") == [1, 1]
    assert rx.counters()["python"]["refused_payloads"] == 1


def test_rows_decode_every_field_in_order(cat: Catalogue) -> None:
    tx, rx, link = pair(cat, ring_records=16)
    pub = tx.publisher("tx", "tickOut", "rx")
    images = [cat.encode("tickOut", {"n": i, "k": -i, "x": i / 4}) for i in range(BURST)]
    pub.send_many(b"".join(images))
    link.pump(10)
    rx.service(dispatch=False)
    rows = rx.receive().rows("tickOut")
    assert rows == [(i, -i, i / 4) for i in range(BURST)]  # 16 from the ring, 44 spilled, one stream


# A catalogue with no bool or narrow bitfield: receive() takes the records as the C ring wrote them (the
# struct passes over the drained memory), the path of figure 4. `cat` above has a bool, so its batches are
# checked tuples instead; both paths must keep the same order and lose nothing.
PLAIN = """#include <stdint.h>
typedef struct tick { uint32_t n; int16_t k; double x; } tick_t;
tick_t tickOut;
typedef struct pos { int32_t lat; int32_t lon; float alt; } pos_t;
pos_t posOut;
"""


@pytest.fixture(scope="module")
def plain(tmp_path_factory: pytest.TempPathFactory) -> Catalogue:
    return generate(tmp_path_factory, "ringplain", "plain", PLAIN)


def plain_pair(cat: Catalogue, ring_records: int | None = None) -> tuple[Node, Node, MemLink]:
    return pair(cat, ring_records, binds=("tickOut", "posOut"))


def test_overflow_over_several_c_calls_before_one_drain(plain: Catalogue) -> None:
    # Three bursts, each its own C call, none drained in between: the ring takes 16, then spills until
    # it is drained (a delivery never overtakes an older one), and one receive() hands over all 60.
    assert not any(i.type.refusable for i in plain.instances)  # the record path, not checked tuples
    tx, rx, link = plain_pair(plain, ring_records=16)
    pub = tx.publisher("tx", "tickOut", "rx")
    for burst in range(3):
        pub.send_many([burst * 20 + i for i in range(20)], field="n")
        link.pump(10)
        rx.service(dispatch=False)
    delivered = rx.counters()["delivered"]
    batch = rx.receive()
    assert batch.column("tickOut", "n") == list(range(60))
    assert [r[0] for r in batch.rows("tickOut")] == list(range(60))
    assert [m.value["n"] for m in batch] == list(range(60))  # Message objects when asked, same order
    ring = rx.counters()["python"]["ring"]
    assert (ring["recorded"], ring["spilled"], ring["dropped"], ring["spill_dropped"]) == (16, 44, 0, 0)
    assert ring["recorded"] + ring["spilled"] == delivered == 60  # every C delivery reached Python
    assert ring["high_water"] == 16
    # The spill ended with the drain: the next burst goes to the ring again.
    pub.send_many(list(range(100, 110)), field="n")
    link.pump(10)
    rx.service(dispatch=False)
    assert rx.receive().column("tickOut", "n") == list(range(100, 110))
    assert rx.counters()["python"]["ring"]["recorded"] == 26


def test_two_contents_interleaved_through_the_overflow(plain: Catalogue) -> None:
    tx, rx, link = plain_pair(plain, ring_records=16)
    ticks = tx.publisher("tx", "tickOut", "rx")
    posts = tx.publisher("tx", "posOut", "rx")
    for i in range(30):  # 60 deliveries in one C call, alternating contents
        ticks.directory.n, ticks.directory.k, ticks.directory.x = i, -i, i / 8
        ticks.send()
        posts.directory.lat, posts.directory.lon, posts.directory.alt = i, 2 * i, 0.5
        posts.send()
    link.pump(10)
    rx.service(dispatch=False)
    batch = rx.receive()
    assert len(batch) == 60
    assert [(m.name, m.value["n"] if m.name == "tickOut" else m.value["lat"]) for m in batch] == \
        [(name, i) for i in range(30) for name in ("tickOut", "posOut")]
    # rows() of a mixed batch: each content's deliveries only, in order, ring records then spilled ones.
    assert batch.rows("tickOut") == [(i, -i, i / 8) for i in range(30)]
    assert batch.rows("posOut") == [(i, 2 * i, 0.5) for i in range(30)]
    assert rx.counters()["python"]["ring"]["spilled"] == 60 - 16


def test_rows_of_one_content_from_the_records(plain: Catalogue) -> None:
    tx, rx, link = plain_pair(plain)  # the default ring holds the whole burst: no spill
    pub = tx.publisher("tx", "tickOut", "rx")
    pub.send_many(b"".join(plain.encode("tickOut", {"n": i, "k": -i, "x": i / 4}) for i in range(40)))
    link.pump(10)
    rx.service(dispatch=False)
    batch = rx.receive()
    assert batch.rows("tickOut") == [(i, -i, i / 4) for i in range(40)]
    assert batch.rows("posOut") == []
    assert rx.counters()["python"]["ring"]["spilled"] == 0


def test_spill_bound_counts_what_it_drops(plain: Catalogue, monkeypatch: pytest.MonkeyPatch) -> None:
    # Spilled deliveries wait in Python until the next drain; past SPILL_MAX (a receiver run with
    # dispatch=False that never calls receive()) they are dropped and counted, never silently.
    import uavbus.node

    monkeypatch.setattr(uavbus.node, "SPILL_MAX", 10)
    tx, rx, link = plain_pair(plain, ring_records=16)
    tx.publisher("tx", "tickOut", "rx").send_many(list(range(BURST)), field="n")
    link.pump(10)
    rx.service(dispatch=False)
    assert rx.receive().column("tickOut", "n") == list(range(26))  # the oldest kept, in order
    ring = rx.counters()["python"]["ring"]
    assert (ring["recorded"], ring["spilled"], ring["spill_dropped"]) == (16, BURST - 16, BURST - 26)
