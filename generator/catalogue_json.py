"""The `<name>.catalogue.json` document (validated by schemas/catalogue.schema.json)."""

from __future__ import annotations

import json
from typing import Any

from .model import Catalogue, Field, StructType
from .render import ABI_VERSION


def catalogue_json(cat: Catalogue, name: str, compact: bool = False) -> str:
    """Deterministic JSON text: fixed key order, two-space indent, one final newline.

    `compact` gives the same document on one line with no spaces: the self-description embedded in
    the generated C catalogue (ub_catalogue_t.json), which binary logs copy into their header.
    """
    doc = {
        "catalogue": name,
        "abi_version": ABI_VERSION,
        "id_scheme": cat.id_scheme,
        "types": [_type(t) for t in cat.types],
        "instances": [
            {"name": i.name, "type": i.type, "id": i.id.hex(), "file": i.loc.file, "line": i.loc.line}
            for i in cat.instances
        ],
        "skipped_instances": [
            {"name": s.name, "file": s.loc.file, "line": s.loc.line, "reason": s.reason} for s in cat.skipped_instances
        ],
        # Enum constants the members use, in declaration order (docs/catalogue.md).
        "enums": {e.name: dict(e.constants) for e in cat.enums},
    }
    if compact:
        return json.dumps(doc, separators=(",", ":"), ensure_ascii=True)
    return json.dumps(doc, indent=2, ensure_ascii=True) + "\n"


def _type(t: StructType) -> dict[str, Any]:
    return {
        "name": t.name,
        "c_name": t.c_name,
        "size": t.size,
        "align": t.align,
        "packed_attr": t.packed_attr,
        "packed_size": t.packed_size,
        "fingerprint": f"{t.fingerprint:08x}",
        "file": t.loc.file,
        "line": t.loc.line,
        "fields": [_field(f) for f in t.fields],
    }


def _field(f: Field) -> dict[str, Any]:
    doc: dict[str, Any] = {
        "name": f.name,
        "wire": f.wire.name if f.wire else ("struct" if f.struct else None),
        "struct": f.struct,
        "count": list(f.dims),
        "offset": f.offset_bits // 8,
        "bit_offset": f.offset_bits,
        "bits": f.bits,
        "c_type": f.c_spelling,
        "long_double": f.long_double,
        "skipped": f.skipped,
        "enum": f.enum,
        "text": f.text,
    }
    # Only members whose header comment says something carry these (older catalogues have neither).
    if f.unit is not None:
        doc["unit"] = f.unit
    if f.doc is not None:
        doc["doc"] = f.doc
    return doc
