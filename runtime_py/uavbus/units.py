"""Units and descriptions of catalogued fields, as the generator took them from the headers' comments.

The catalogue records, per member, `"unit"` (e.g. "m/s", from a trailing `/**< [m/s] ... */` or `/* m/s, ... */`)
and `"doc"` (the rest of the comment); catalogues written before that have neither and every lookup is
empty. `units_of(catalogue, type)` flattens them to leaf paths as `uavbus.tools.common.flatten` names
values ("specificForce.x", "motors.rpm": array indices left out), so a tool shows the unit beside a value.
"""

from __future__ import annotations

import json
from functools import lru_cache
from typing import Any


@lru_cache(maxsize=8)
def _raw_types(json_text: str) -> dict[str, dict[str, Any]]:
    doc = json.loads(json_text)
    return {t["name"]: t for t in doc.get("types", [])}


def units_of(catalogue: Any, type_: Any) -> dict[str, dict[str, str]]:
    """{leaf path: {"unit": ..., "doc": ...}} for the members of `type_` (a catalogue Type or its name)
    that have either; the members of a nested struct take its unit unless they have their own."""
    types = _raw_types(catalogue.json_text)
    name = type_ if isinstance(type_, str) else type_.name
    out: dict[str, dict[str, str]] = {}

    def walk(tname: str, prefix: str, depth: int, inherited: str | None) -> None:
        t = types.get(tname)
        if t is None or depth > 16:
            return
        for f in t.get("fields", []):
            if f.get("skipped"):
                continue
            path = f"{prefix}.{f['name']}" if prefix else f["name"]
            info = {k: f[k] for k in ("unit", "doc") if f.get(k)}
            if inherited and "unit" not in info:
                info["unit"] = inherited  # `vector3d_t specificForce; /* m/s^2 */`: x, y and z are in m/s^2
            if info:
                out[path] = info
            if f.get("struct"):
                walk(f["struct"], path, depth + 1, info.get("unit"))

    walk(name, "", 0, None)
    return out



def unit_of(catalogue: Any, content: str, field_path: str) -> str | None:
    """The unit of one field of instance `content` ("imuOut", "specificForce.x"), or None."""
    import re

    inst = catalogue.instance(content)
    return units_of(catalogue, inst.type).get(re.sub(r"\[\d+\]", "", field_path), {}).get("unit")
