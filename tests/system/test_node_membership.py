"""Membership at run time through uavbus_node's stdin (issue 12 item 1): two processes with automatic routes
over UDP; entities, masks and links added and removed while they run, locally and over the bus
(MEMBERSHIP), a link cut with its own impairment and restored; every command answered with an event."""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest

from uavbus.sim.portalloc import PortAllocator
from uavbus.sim.process import NodeProcess, ProcessGroup

pytestmark = pytest.mark.timeout(60)


def answer(p: NodeProcess, line: str, event: str = "membership", timeout: float = 3.0) -> dict:
    m = p.mark()
    p.send(line)
    return p.wait_event(lambda e: e.get("event") in (event, "error"), timeout, since=m, what=f"answer to {line!r}")


def routes(p: NodeProcess) -> dict:
    return answer(p, "routes", "routes")


def wait_for(p: NodeProcess, check, timeout: float = 3.0) -> dict:
    deadline = time.monotonic() + timeout
    while True:
        r = routes(p)
        if check(r):
            return r
        assert time.monotonic() < deadline, json.dumps(r)[:2000]
        time.sleep(0.1)


@pytest.fixture()
def pair(program: Path, tmp_path: Path):
    cfg = tmp_path / "pair.json"
    cfg.write_text(json.dumps({"entities": [{"name": "uav1", "links": ["to_uav2"]},
                                            {"name": "uav2", "links": ["to_uav1"]}],
                               "nodes": {"a": ["uav1"], "b": ["uav2"]}}))
    alloc = PortAllocator()
    pa, pb = alloc.addr(), alloc.addr()
    common = ["--config", str(cfg), "--route", "hello=100", "--stats-ms", "0"]
    with ProcessGroup() as g:
        a = g.spawn([str(program), *common, "--node", "a", "--port", f"to_uav2=udp:bind={pa},peer={pb}"], "a")
        b = g.spawn([str(program), *common, "--node", "b", "--port", f"to_uav1=udp:bind={pb},peer={pa}"], "b")
        wait_for(a, lambda r: r["entities"]["uav1"].get("uav2", {}).get("reachable"))
        yield a, b, alloc


def test_entities_and_masks_from_stdin(pair) -> None:
    a, b, _ = pair
    ev = answer(a, "entity add ghost")
    assert ev["ok"] and ev["changed"] and ev["entities"] == 3
    assert not answer(a, "entity add ghost")["changed"]  # already so
    assert "ghost" in routes(a)["entities"]["uav1"]
    ev = answer(a, "entity remove ghost")
    assert ev["ok"] and ev["changed"] and "ghost" not in routes(a)["entities"]["uav1"]
    ev = answer(a, "entity remove uav1")
    assert not ev["ok"] and ev["reason"] == "invalid"  # a node's own entity stays
    # A hand-set mask pins the entry; 0 gives it back to routing.
    assert answer(a, "mask uav1 uav2 0x00000001")["ok"]
    assert routes(a)["entities"]["uav1"]["uav2"]["pinned"]
    assert answer(a, "mask uav1 uav2 0x0")["ok"]
    r = routes(a)["entities"]["uav1"]["uav2"]
    assert not r["pinned"] and r["reachable"] and r["mask"] == "0x00000001"
    assert answer(a, "mask uav1 uav2 0x00000010")["reason"] == "invalid"  # no link[1]
    assert answer(a, "entity frobnicate x")["event"] == "error"
    assert answer(a, "mask nobody uav2 0x1")["event"] == "error"


def test_membership_over_the_bus(pair) -> None:
    a, b, alloc = pair
    # The announcement: uav1's node tells uav2 that uav9 exists.
    m = a.mark()
    a.send("member uav2 add_entity uav9")
    done = a.wait_event(lambda e: e.get("event") == "member" and e["status"] != "pending", 3.0, since=m)
    assert done["status"] == "done" and done["changed"] and done["subject"] == "uav9"
    assert "uav9" in routes(b)["entities"]["uav2"]
    # A link created over the bus on the other node, with its port, then removed.
    p1, p2 = alloc.addr(), alloc.addr()
    m = a.mark()
    a.send(f"member uav2 add_link 1 radio2 udp:bind={p1},peer={p2}")
    done = a.wait_event(lambda e: e.get("event") == "member" and e["status"] != "pending", 3.0, since=m)
    assert done["status"] == "done" and done["changed"], done
    assert "radio2" in routes(b)["links"]
    m = a.mark()
    a.send("member uav2 remove_link radio2")
    done = a.wait_event(lambda e: e.get("event") == "member" and e["status"] != "pending", 3.0, since=m)
    assert done["status"] == "done" and "radio2" not in routes(b)["links"]
    m = a.mark()
    a.send("member uav2 remove_entity uav2")
    done = a.wait_event(lambda e: e.get("event") == "member" and e["status"] != "pending", 3.0, since=m)
    assert done["status"] == "failed" and done["reason"] == "invalid"
    counters = routes(b)["membership"]
    assert counters["applied"] == 3 and counters["refused"] == 1


def test_links_added_removed_and_cut_at_run_time(pair) -> None:
    a, b, alloc = pair
    p1, p2 = alloc.addr(), alloc.addr()
    # A second, parallel link between the two, added on both sides at run time: routing uses both (0x11).
    assert answer(a, f"link add uav1 1 extra udp:bind={p1},peer={p2}")["changed"]
    assert answer(b, f"link add uav2 1 extra udp:bind={p2},peer={p1}")["changed"]
    wait_for(a, lambda r: r["entities"]["uav1"]["uav2"]["mask"] == "0x00000011")
    # Cut the first link with its own impairment: the route moves to the second within a few hellos.
    assert answer(a, "link impair to_uav2 loss=1.0", "impaired")["link"] == "to_uav2"
    answer(b, "link impair to_uav1 loss=1.0", "impaired")
    r = wait_for(a, lambda r: r["entities"]["uav1"]["uav2"]["mask"] == "0x00000010")
    assert r["links"]["to_uav2"]["cost"] == 65535
    # Remove the second link on one side: the route is gone; restore the first: it comes back.
    assert answer(a, "link remove extra")["changed"]
    assert not answer(a, "link remove extra")["changed"]  # already gone
    wait_for(a, lambda r: not r["entities"]["uav1"]["uav2"]["reachable"])
    answer(a, "link impair to_uav2 off", "impaired")
    answer(b, "link impair to_uav1 off", "impaired")
    wait_for(a, lambda r: r["entities"]["uav1"]["uav2"]["reachable"])
    assert answer(a, "link add uav1 9 bad")["event"] == "error"
    assert answer(a, "link impair nosuch loss=1.0", "impaired")["event"] == "error"
