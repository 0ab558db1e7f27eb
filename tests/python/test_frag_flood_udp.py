"""Fragment reassembly shared fairly, over real UDP sockets on 127.0.0.1 (issue 29, item 3).

A genuine 2-fragment directory goes from node a to node b through a relay the test controls; between its two
fragments, an attacker without a key (the network is unsigned) sends b the first fragments of 10 transfers
that never complete, each claiming another source. Before issue 29 the fourth of them evicted the genuine
transfer (every slot busy: the one idle longest made room) and the directory was lost, every time; now a
transfer whose fragments keep arriving is never given up for a newcomer, so every version arrives, and the
refused fragments are counted (`rx_refused`, dropped `incomplete`).
"""

from __future__ import annotations

import socket
import struct
import time

import pytest

from binding_testutil import Generated, _generate
from uavbus import Node
from uavbus._bindings.ub_frame import FrameHeader, ub_frame_finish
from uavbus._bindings.ub_node import entity_id

pytestmark = pytest.mark.timeout(60)

TILE_HEADER = """\
#include <stdint.h>
typedef struct { uint32_t version; uint8_t cells[1500]; } floodTile_t;
extern floodTile_t floodTile;
"""
ADMIN_FRAGMENT = 21


@pytest.fixture(scope="module")
def tilecat(tmp_path_factory: pytest.TempPathFactory) -> Generated:
    src = tmp_path_factory.mktemp("flood") / "flood.h"
    src.write_text(TILE_HEADER, encoding="utf-8")
    return _generate(tmp_path_factory.mktemp("gen"), "floodcat", [src], [])


def udp(bind: str = "127.0.0.1") -> socket.socket:
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind((bind, 0))
    return s


def forged_first_fragment(cat: Generated, src: str, dest: str, transfer: int, seq: int) -> bytes:
    """Fragment 0 of 2 of a floodTile transfer that will never complete, claiming source `src`."""
    inst = cat.catalogue.instance("floodTile")
    total = inst.type.packed_size
    chunk = (total + 1) // 2
    payload = struct.pack("<HHHH", transfer, 0, 2, total) + bytes(chunk)
    h = FrameHeader(dir_id=inst.id, dest_id=entity_id(dest), src_id=entity_id(src), admin=ADMIN_FRAGMENT,
                    payload_size=len(payload), seq=seq, fingerprint=inst.type.fingerprint)
    return ub_frame_finish(h, payload)


def poll_until(nodes: list[Node], cond, seconds: float = 2.0) -> bool:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        for n in nodes:
            n.poll(0.002)
        if cond():
            return True
    return False


def test_never_completing_transfers_of_other_sources_do_not_evict_a_genuine_one(tilecat: Generated) -> None:
    a, b = Node(tilecat.catalogue), Node(tilecat.catalogue)
    relay, attacker = udp(), udp()
    relay.settimeout(2.0)
    try:
        for n, me, other in ((a, "a", "b"), (b, "b", "a")):
            n.add_entity(me, local=True)
            n.add_entity(other)
            n.add_link(me, 0, "radio")
            n.set_mask(me, other, 1)
        b.open_port("radio", "udp:bind=127.0.0.1:0,accept=any")
        b_addr = ("127.0.0.1", b.local_port("radio"))
        a.open_port("radio", f"udp:bind=127.0.0.1:0,peer=127.0.0.1:{relay.getsockname()[1]}")
        tile = a.bind("floodTile")
        b.bind("floodTile")
        got: list[int] = []
        b.on_data(lambda m: got.append(m.value["version"]))
        frag = b.wire.fragment_counters
        versions = list(range(1, 6))
        for v in versions:
            tile.version = v
            tile.cells[1499] = v
            a.send("a", "floodTile", "b")
            first, second = relay.recv(4096), relay.recv(4096)       # the genuine transfer's two fragments
            started = frag()["rx_started"]
            relay.sendto(first, b_addr)
            assert poll_until([a, b], lambda: frag()["rx_started"] > started)
            before = frag()
            for k in range(10):                                       # 10 transfers of other sources
                attacker.sendto(forged_first_fragment(tilecat, f"x{k}", "b", 1000 * v + k, 100 * v + k), b_addr)
            assert poll_until([a, b], lambda: sum(frag()[c] - before[c] for c in ("rx_started", "rx_refused")) >= 10)
            relay.sendto(second, b_addr)
            poll_until([a, b], lambda: v in got, 1.0)
        counters = frag()
        assert got == versions, (got, counters)
        assert counters["rx_refused"] >= 7 * len(versions) and counters["rx_evicted"] == 0, counters
        assert b.counters()["drops"]["incomplete"] >= counters["rx_refused"]
    finally:
        relay.close()
        attacker.close()
        a.close()
        b.close()
