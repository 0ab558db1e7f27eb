"""Units and descriptions from the headers' comments (issue 27): the front end finds a member's comment, the
model reads a unit out of it, the catalogue carries both; the layout (fingerprint) does not change."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from gen_testutil import catalogue_of, write

from uavbus_gen import model
from uavbus_gen.catalogue_json import catalogue_json

HEADER = """
#include <stdint.h>
typedef struct vec { double x; double y; double z; } vec_t;
typedef struct sample {
    double p;                 /**< [rad/s] roll rate, body x */
    /** [m] height above ground */
    float agl;
    vec_t accel;              /* m/s^2, body axes */
    float field;              /* Gauss */
    uint32_t count;           /* samples since boot */
    uint16_t plain;
    int32_t speed;            // m/s towards the waypoint
    struct { uint8_t a; } inner; /**< [V] */
} sample_t;
sample_t sample;
"""


@pytest.mark.parametrize("comment, unit, doc", [
    ("[m/s] speed over ground", "m/s", "speed over ground"),
    ("[degC]", "degC", None),
    ("m/s^2, body axes", "m/s^2", "body axes"),
    ("rad/s", "rad/s", None),
    ("samples since boot", None, "samples since boot"),
    ("yyyymmdd", None, "yyyymmdd"),
    ("azimuth, elevation in body axes", None, "azimuth, elevation in body axes"),  # not a unit word
    ("1 s, 10 s, 1 min", None, "1 s, 10 s, 1 min"),
    (None, None, None),
])
def test_parse_comment(comment: str | None, unit: str | None, doc: str | None) -> None:
    assert model.parse_comment(comment) == (unit, doc)


def test_units_reach_the_catalogue_and_leave_the_layout_alone(tmp_path: Path) -> None:
    h = write(tmp_path, "sample.h", HEADER)
    cat = catalogue_of(h)
    f = {x.name: x for x in cat.type("struct sample").fields}
    assert (f["p"].unit, f["p"].doc) == ("rad/s", "roll rate, body x")
    assert (f["agl"].unit, f["agl"].doc) == ("m", "height above ground")  # a doc comment above the member
    assert (f["accel"].unit, f["accel"].doc) == ("m/s^2", "body axes")
    assert (f["field"].unit, f["count"].unit, f["count"].doc) == ("Gauss", None, "samples since boot")
    assert (f["plain"].unit, f["plain"].doc) == (None, None)
    assert (f["speed"].unit, f["speed"].doc) == (None, "m/s towards the waypoint")
    assert f["inner"].unit == "V"
    doc = json.loads(catalogue_json(cat, "sample"))
    fields = {x["name"]: x for x in next(t for t in doc["types"] if t["name"] == "struct sample")["fields"]}
    assert fields["p"]["unit"] == "rad/s" and fields["p"]["doc"] == "roll rate, body x"
    assert "unit" not in fields["plain"] and "doc" not in fields["plain"]  # absent, not null
    bare = write(tmp_path / "bare", "sample.h", "\n".join(line.split("/*")[0].split("//")[0] if "/*" in line or "//" in line
                                                          else line for line in HEADER.splitlines()
                                                          if "/** [m]" not in line))
    plain = catalogue_of(bare)
    assert plain.type("struct sample").fingerprint == cat.type("struct sample").fingerprint
