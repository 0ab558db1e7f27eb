"""Python that behaves like Python (issue 14, item 6).

- Nested arrays and structs of a bound directory write through to the buffer the router sends from
  (`d.motors[2]["rpm"] = x` is not lost), and what cannot write through refuses loudly.
- Enum members come out as IntEnum (from the catalogue's "enums" section), accept constant names,
  and catalogues without that section still work (plain ints).
- The exceptions are public in uavbus.errors; the package is typed (py.typed); the public API has
  docstrings.
"""

from __future__ import annotations

import enum
import inspect
import json
from pathlib import Path

import pytest

import uavbus
from uavbus import Catalogue, MemLink, Node
from uavbus.directory import ArrayView, Directory

FIXTURE = Path(__file__).resolve().parents[1] / "fixtures" / "enums" / "enumcat.catalogue.json"


@pytest.fixture
def cat() -> Catalogue:
    return Catalogue.load(FIXTURE)


@pytest.fixture
def old_cat() -> Catalogue:
    """The same catalogue as a generator that did not record enums wrote it."""
    doc = json.loads(FIXTURE.read_text())
    del doc["enums"]
    for t in doc["types"]:
        for f in t["fields"]:
            f.pop("enum", None)
    return Catalogue(doc, "old")


def pair(cat: Catalogue) -> tuple[Node, Node, MemLink, list[int]]:
    clock = [0]
    air, gcs = Node(cat, clock=lambda: clock[0]), Node(cat, clock=lambda: clock[0])
    for node, me, other, link in ((air, "uav1", "gcs1", "air0"), (gcs, "gcs1", "uav1", "gnd0")):
        node.add_entity(me, local=True)
        node.add_entity(other)
        node.add_link(me, 0, link)
        node.set_mask(me, other, "0x00000001")
    return air, gcs, MemLink(air, "air0", gcs, "gnd0"), clock


def send_and_receive(air: Node, gcs: Node, clock: list[int]) -> dict:
    gcs.bind("vehicleState")
    assert air.send("uav1", "vehicleState", to="gcs1") == 1
    clock[0] += 1
    gcs.poll(0)
    (msg,) = list(gcs.messages(timeout=0))
    return msg.value


def test_nested_arrays_and_structs_write_through(cat: Catalogue) -> None:
    air, gcs, _, clock = pair(cat)
    d = air.bind("vehicleState")
    d.motors[2]["rpm"] = 5200.0           # the example: was silently lost
    d.motors[1].rpm = 4100.0               # attribute form
    d.motors[3] = {"rpm": 1.5, "lastMode": 2}   # a whole element
    d.cells[1][2] = 3.75                   # two dimensions
    d.cells[0] = [1.0, 2.0, 3.0]           # a whole row
    d.history[-1] = 4                      # negative index
    assert isinstance(d.motors, ArrayView) and isinstance(d.motors[2], Directory)
    assert d.motors[2].rpm == 5200.0 and d.cells[1][2] == 3.75 and len(d.cells) == 2
    assert d.cells == [[1.0, 2.0, 3.0], [0.0, 0.0, 3.75]]
    value = send_and_receive(air, gcs, clock)   # the bytes the router sent carry every write
    assert [m["rpm"] for m in value["motors"]] == [0.0, 4100.0, 5200.0, 1.5]
    assert value["cells"] == [[1.0, 2.0, 3.0], [0.0, 0.0, 3.75]] and value["history"][2] == 4
    air.close()
    gcs.close()


def test_what_cannot_write_through_refuses_loudly(cat: Catalogue) -> None:
    air, _, _, _ = pair(cat)
    d = air.bind("vehicleState")
    snapshot = d.to_dict()
    snapshot["motors"][0]["rpm"] = 99.0      # a detached copy, by contract: the buffer is unchanged
    assert d.motors[0].rpm == 0.0
    with pytest.raises(TypeError, match="slice cannot be written"):
        d.history[0:2] = [1, 1]
    part = d.history[0:2]
    with pytest.raises(TypeError):
        part[0] = 1                          # a slice is a read-only tuple, not a silent copy
    with pytest.raises(IndexError, match=r"vehicleState.history\[3\]: index out of range \(length 3\)"):
        d.history[3] = 1
    with pytest.raises(ValueError, match="expected a list of 3"):
        d.cells[0] = [1.0]
    with pytest.raises(ValueError, match="rpm"):
        d.motors[0] = {"lastMode": 1}         # a whole element needs every member
    d.tMs = 5
    with pytest.raises(ValueError, match="tMs"):
        d.tMs = "five"                       # a refused write leaves the old value (not zeroed)
    with pytest.raises(ValueError):
        d.cells[1] = [1.0, "x", 3.0]          # all or nothing for a row
    assert d.tMs == 5 and d.cells[1] == [0.0, 0.0, 0.0]
    with pytest.raises(AttributeError, match="no packed member 'rmp'"):
        d.motors[0].rmp = 1.0
    air.close()


def test_enums_are_intenums_with_names(cat: Catalogue) -> None:
    air, gcs, _, clock = pair(cat)
    d = air.bind("vehicleState")
    d.mode = "MODE_AUTO"
    d.motors[0].lastMode = "MODE_HOVER"
    d.history[1] = "MODE_LAND"
    mode = d.mode
    assert isinstance(mode, enum.IntEnum) and mode == 3 and mode.name == "MODE_AUTO"
    assert type(mode).__name__ == "flightMode"
    with pytest.raises(ValueError, match="'MODE_WARP' is not a constant of its enum"):
        d.mode = "MODE_WARP"
    d.tMs = 7
    value = send_and_receive(air, gcs, clock)
    assert value["mode"] is type(mode).MODE_AUTO
    assert value["motors"][0]["lastMode"].name == "MODE_HOVER" and value["history"][1].name == "MODE_LAND"
    assert json.dumps({"m": value["mode"]}) == '{"m": 3}'  # still an int for JSON and arithmetic
    d.mode = 9                                            # a value with no constant stays a plain int
    assert d.mode == 9 and not isinstance(d.mode, enum.IntEnum)
    air.close()
    gcs.close()


def test_catalogue_without_enums_still_works(old_cat: Catalogue) -> None:
    air, gcs, _, clock = pair(old_cat)
    d = air.bind("vehicleState")
    d.mode = 3
    d.motors[2]["rpm"] = 1.0
    assert type(d.mode) is int
    with pytest.raises(ValueError):
        d.mode = "MODE_AUTO"   # no names to go by: refused, not stored as garbage
    value = send_and_receive(air, gcs, clock)
    assert value["mode"] == 3 and type(value["mode"]) is int and value["motors"][2]["rpm"] == 1.0
    air.close()
    gcs.close()


def test_errors_are_public_and_the_package_is_typed() -> None:
    import uavbus.errors as errors

    for name in errors.__all__:
        exc = getattr(errors, name)
        assert issubclass(exc, Exception), name
    assert issubclass(errors.ConfigError, errors.UbError) and issubclass(errors.ConfigError, ValueError)
    with pytest.raises(errors.ConfigError) as info:
        Node(Catalogue.load(FIXTURE), config="no/such/file.json")
    assert str(info.value) == "no/such/file.json: cannot open: No such file or directory"
    assert (Path(uavbus.__file__).parent / "py.typed").is_file()


PUBLIC = ["Catalogue", "Node", "Directory", "Message", "Admin", "MemLink"]


def test_public_api_has_docstrings() -> None:
    missing = []
    for cls_name in PUBLIC:
        cls = getattr(uavbus, cls_name)
        if not inspect.getdoc(cls):
            missing.append(cls_name)
        for name, member in vars(cls).items():
            if name.startswith("_"):
                continue
            target = member.fget if isinstance(member, property) else member
            if callable(target) and not (getattr(target, "__doc__", None) or "").strip():
                missing.append(f"{cls_name}.{name}")
    for mod_name in ("uavbus.config", "uavbus.errors", "uavbus.enums"):
        module = __import__(mod_name, fromlist=["x"])
        if not inspect.getdoc(module):
            missing.append(mod_name)
        for name in getattr(module, "__all__", []):
            obj = getattr(module, name)
            if (inspect.isfunction(obj) or inspect.isclass(obj)) and not inspect.getdoc(obj):
                missing.append(f"{mod_name}.{name}")
    assert missing == [], f"public API without a docstring: {missing}"
