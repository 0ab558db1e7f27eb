"""The cffi layer's three tiers stay apart (docs/python.md): only tier 2 (`uavbus._bindings`) calls `lib` or uses
`ffi`; the Pythonic modules above it call the wrappers, so every C return code becomes an exception in one place
and no module above reads a C struct's layout. Engine parts of Node are sub-objects (node.routing, node.wire,
node.security, node.inspect), with the flat names other modules still call kept as delegating aliases."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from binding_testutil import FakeClock as Clock
from binding_testutil import Generated
from uavbus import Node
from uavbus._bindings.ub_error import InvalidArgumentError, NotFoundError

PACKAGE = Path(__file__).resolve().parents[2] / "runtime_py" / "uavbus"
# Tier 1 (the cdefs, the built extension) and tier 2: the only modules that may touch `lib` and `ffi`.
LOWER_TIERS = ("_bindings/", "_build_ffi.py")
# Modules of other rooms that still read `lib` constants directly (admin codes). Each must still need its entry:
# test_known_exceptions_are_still_needed fails once one is fixed, so the list only shrinks.
KNOWN_EXCEPTIONS = {"tools/common.py", "tools/mcap_export.py"}


def violations(source: str) -> list[str]:
    """What in `source` reaches below tier 2: an import of uavbus._ub, or any use of a name `lib` or `ffi`
    (calls, constants, allocations), or a C struct field read through a node's `_c` handle."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom) and node.module == "uavbus._ub":
            found.append(f"{node.lineno}: from uavbus._ub import ...")
        elif isinstance(node, ast.Import) and any(a.name == "uavbus._ub" for a in node.names):
            found.append(f"{node.lineno}: import uavbus._ub")
        elif isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in ("lib", "ffi"):
            found.append(f"{node.lineno}: {node.value.id}.{node.attr}")
        elif (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Attribute) and node.value.attr == "_c"
              and isinstance(node.value.value, ast.Name) and node.value.value.id in ("node", "self")):
            found.append(f"{node.lineno}: {node.value.value.id}._c.{node.attr}")
    return found


def upper_tier_modules() -> list[Path]:
    return sorted(p for p in PACKAGE.rglob("*.py") if not p.relative_to(PACKAGE).as_posix().startswith(LOWER_TIERS))


def test_the_scan_finds_what_it_forbids() -> None:
    planted = ("from uavbus._ub import ffi, lib\n"
               "def f(node):\n"
               "    lib.ub_node_tick(node._c, 0)\n"
               "    buf = ffi.new('uint8_t[]', 4)\n"
               "    return node._c.entities[0].local\n")
    assert violations(planted) == ["1: from uavbus._ub import ...", "3: lib.ub_node_tick", "4: ffi.new",
                                   "5: node._c.entities"]
    assert violations("from uavbus._bindings import ub_node\nub_node.ub_node_tick(node._c, 0)\n") == []


def test_upper_tiers_call_only_the_wrappers() -> None:
    modules = upper_tier_modules()
    assert PACKAGE / "node.py" in modules and PACKAGE / "pylink.py" in modules and len(modules) > 20
    bad = {}
    for path in modules:
        rel = path.relative_to(PACKAGE).as_posix()
        found = violations(path.read_text(encoding="utf-8"))
        if found and rel not in KNOWN_EXCEPTIONS:
            bad[rel] = found
    assert bad == {}, f"tier 3 reaching into cffi (add a wrapper in uavbus/_bindings instead): {bad}"


@pytest.mark.parametrize("rel", sorted(KNOWN_EXCEPTIONS))
def test_known_exceptions_are_still_needed(rel: str) -> None:
    assert violations((PACKAGE / rel).read_text(encoding="utf-8")), f"{rel} is clean now: drop it from the list"


@pytest.fixture()
def node(flightsw: Generated):
    n = Node(flightsw.catalogue, node="gcs", clock=Clock())
    n.add_entity("gcs1", local=True)
    n.add_entity("fcs20")
    n.add_link("gcs1", 2, "radio")
    yield n
    n.close()


def test_tables_read_through_the_query_functions(node: Node) -> None:
    # ub_node_query.c: rows in use, local or not, link[i] of a local entity, a link's name/kind/MTU/encoding.
    assert node.entities() == [{"index": 0, "name": "gcs1", "local": True, "links": [None, None, "radio"]},
                               {"index": 1, "name": "fcs20", "local": False}]
    node.wire.set_mtu("radio", 300)
    link = node.link_counters()["radio"]
    assert (link["transport"], link["mtu"], link["encrypt"], link["encoding"]) == (None, 300, False, "full")
    node.wire.set_encoding("radio", "compact")
    assert node.link_counters()["radio"]["compact"]["tx_frames"] == 0
    node.wire.set_encoding("radio", "full")
    assert node.link_counters()["radio"]["encoding"] == "full"
    assert set(node.wire.fragment_counters()) >= {"tx_transfers", "rx_complete"}
    assert not node.publisher("gcs1", "gpsOut", "fcs20")._local
    assert node.publisher("gcs1", "gpsOut", "gcs1")._local
    node.remove_entity("fcs20")
    with pytest.raises(NotFoundError):
        node.entity_index("fcs20")


def test_engine_parts_are_sub_objects_with_the_old_names_delegating(node: Node) -> None:
    assert not node.routing and node.routing.enabled is False
    with pytest.raises(InvalidArgumentError, match="routing is not enabled"):
        node.routing.table()
    node.enable_routing(hello_ms=100)                 # the flat name (uavbus.sim calls it)
    assert node.routing and node.routing.table()["fcs20"]["reachable"] is False
    assert node.route_links() == node.routing.links() and "radio" in node.routing.links()
    node.routing.disable()
    assert not node.routing.enabled
    assert node.security.enabled is False and node.security() is None and node.security.status() is None
    with pytest.raises(InvalidArgumentError, match="without security"):
        node.use_key(1)
    assert node.inspect.counters() == {"sent": 0, "done": 0, "failed": 0, "unmatched_replies": 0}
    assert node.remote("fcs20").entity == "fcs20" and node._inspector() is node.inspect._requester()
