"""Rendering: model -> {relative_path: text} through Jinja2 templates named after model classes.

Templates live in `templates/<lang>/<ModelClass>.<ext>.j2`; a model class is rendered by the first
template found along its MRO (nunavut style), so a new subclass needs no dispatch code. Identifier
mangling (C and Python keywords, names our generated code uses) happens here and nowhere else,
driven by `templates/properties.json`. Nothing here writes files; output is deterministic.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import jinja2

from . import model
from .model import Catalogue, Field, StructType

from uavbus._paths import TEMPLATES_DIR as TEMPLATE_DIR  # package data (templates/ in the repository)
ABI_VERSION = 2  # must equal UB_CATALOGUE_ABI_VERSION in runtime_c/include/ub/ub_catalogue.h


class Properties:
    """Per-language reserved identifiers (templates/properties.json)."""

    def __init__(self, data: dict[str, Any]) -> None:
        self.reserved = {lang: frozenset(v["reserved_identifiers"]) for lang, v in data.items()}

    @classmethod
    def load(cls, template_dir: Path = TEMPLATE_DIR) -> "Properties":
        return cls(json.loads((template_dir / "properties.json").read_text()))

    def mangle(self, name: str, lang: str) -> str:
        """`name` unchanged unless reserved in `lang`; then with a trailing underscore (repeated
        until free, so `pack_` stays distinct from a mangled `pack`)."""
        while name in self.reserved[lang]:
            name += "_"
        return name


@dataclass(frozen=True)
class RenderInputs:
    name: str  # NAME: output base name and C/Python prefix
    includes: tuple[str, ...]  # headers NAME.h includes, as written in #include "..."
    catalogue_json: str = ""  # compact catalogue JSON, embedded in NAME.c as the catalogue's self-description


class Renderer:
    def __init__(self, cat: Catalogue, inputs: RenderInputs, template_dir: Path = TEMPLATE_DIR) -> None:
        if not model.is_identifier(inputs.name):
            raise ValueError(f"--name '{inputs.name}' is not a C identifier")
        self.cat = cat
        self.inputs = inputs
        self.props = Properties.load(template_dir)
        self.env = jinja2.Environment(
            loader=jinja2.FileSystemLoader(str(template_dir)),
            undefined=jinja2.StrictUndefined,
            trim_blocks=True,
            lstrip_blocks=True,
            keep_trailing_newline=True,
            autoescape=False,
        )
        self.env.filters.update(
            c_put=c_put, c_get=c_get, c_literal=c_literal, c_bytes=c_bytes, c_string=c_string, c_string_lines=c_string_lines,
            py_attr=lambda n: self.props.mangle(n, "py"), py_class=self.py_class,
            py_format=self.py_format, py_literal=py_literal, hex8=lambda v: f"0x{v:08x}",
        )
        self.env.globals.update(
            cat=cat, NAME=inputs.name, includes=inputs.includes, abi_version=ABI_VERSION, model=model,
            type_of=cat.type, leaves_of=self.leaves_count, C_PATH=c_path, render_node=self.render_node,
            id_scheme_c="UB_ID_SCHEME_" + cat.id_scheme.upper(), catalogue_json=inputs.catalogue_json,
        )

    # -- template resolution ------------------------------------------------------------------
    def render_node(self, obj: object, lang: str, ext: str, **extra: Any) -> str:
        """Renders `obj` with the first `templates/<lang>/<Class>.<ext>.j2` along its MRO."""
        for klass in type(obj).__mro__:
            name = f"{lang}/{klass.__name__}.{ext}.j2"
            try:
                template = self.env.get_template(name)
            except jinja2.TemplateNotFound:
                continue
            return template.render(node=obj, **extra)
        raise LookupError(f"no template for {type(obj).__name__} ({lang}, .{ext})")

    def render(self) -> dict[str, str]:
        """The generated files: {relative path: text}."""
        n = self.inputs.name
        return {
            f"{n}.h": tidy(self.render_node(self.cat, "c", "h")),
            f"{n}.c": tidy(self.render_node(self.cat, "c", "c")),
            f"{n}.py": tidy(self.render_node(self.cat, "py", "py")),
        }

    def render_selftest(self) -> dict[str, str]:
        """The self-test programs (C and Python) with their shared values."""
        n = self.inputs.name
        cases = [SelftestCase.make(self.cat, t) for t in self.cat.named_types]
        return {
            f"{n}_selftest.c": tidy(self.env.get_template("c/Selftest.c.j2").render(cases=cases)),
            f"{n}_selftest.py": tidy(self.env.get_template("py/Selftest.py.j2").render(cases=cases)),
        }

    # -- Python helpers -----------------------------------------------------------------------
    def py_class(self, t: StructType | str) -> str:
        t = self.cat.type(t) if isinstance(t, str) else t
        return self.props.mangle(t.ident, "py")

    def py_format(self, t: StructType) -> str:
        """struct-module format for the whole type without the '<' prefix, runs merged ('3f' not 'fff')."""
        return "".join(f"{n}{code}" if n > 1 else code for n, code in _merge_runs(self._format_runs(t)))

    def _format_runs(self, t: StructType) -> list[tuple[int, str]]:
        runs: list[tuple[int, str]] = []
        for f in t.packed_fields:
            if f.wire:
                runs.append((f.count, f.wire.py_format))
            else:
                runs += self._format_runs(self.cat.type(f.struct)) * f.count  # type: ignore[arg-type]
        return runs

    def leaves_count(self, t: StructType) -> int:
        return sum(f.count if f.wire else f.count * self.leaves_count(self.cat.type(f.struct)) for f in t.packed_fields)  # type: ignore[arg-type]


@dataclass(frozen=True)
class SelftestCase:
    type: StructType
    leaves: tuple[model.Leaf, ...]
    expected: bytes
    tree: dict

    @classmethod
    def make(cls, cat: Catalogue, t: StructType) -> "SelftestCase":
        leaves = model.test_leaves(cat, t)
        return cls(t, tuple(leaves), model.expected_packed(cat, t), model.value_tree(leaves, cat, t))

    @property
    def skipped_paths(self) -> tuple[str, ...]:
        """Top-level skipped members the C test can poison and re-check (unpack must not touch them)."""
        return tuple(f.name for f in self.type.fields if f.skipped and f.name and f.skipped != model.SKIP_FLEXIBLE)


# -- C filters (pure functions, doctested) --------------------------------------------------------


def c_put(f: Field, acc: str) -> str:
    """The statement that writes one scalar at `p` (signed values travel as their two's-complement bits)."""
    w = f.wire
    assert w is not None
    if w.name == "bool":
        return f"ub_put_u8(p, (uint8_t)({acc} ? 1u : 0u));"
    if w.name == "f32":
        return f"ub_put_f32le(p, {acc});"
    if w.name == "f64":
        return f"ub_put_f64le(p, (double){acc});"
    suffix = "" if w.size == 1 else "le"
    return f"ub_put_u{w.bits}{suffix}(p, (uint{w.bits}_t){acc});"


def c_get(f: Field, acc: str) -> str:
    """The statement that reads one scalar at `p` into `acc`."""
    w = f.wire
    assert w is not None
    if w.name == "bool":
        return f"{acc} = ub_get_u8(p) != 0u;"
    if w.name == "f32":
        return f"{acc} = ub_get_f32le(p);"
    if w.name == "f64":
        return f"{acc} = ub_get_f64le(p);"
    suffix = "" if w.size == 1 else "le"
    read = f"ub_get_u{w.bits}{suffix}(p)"
    return f"{acc} = ({w.c_type}){read};" if w.signed else f"{acc} = {read};"


def c_literal(value: int | float | bool, f: Field) -> str:
    """A C literal of the test value for `f`.

    >>> c_literal(True, None)
    '1'
    """
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, float):
        return repr(value)
    w = f.wire
    assert w is not None
    if w.bits == 64:
        return f"INT64_C({value})" if w.signed else f"UINT64_C({value})"
    return f"{value}" if w.signed or value < 0x80000000 else f"{value}u"


def c_bytes(raw: bytes) -> str:
    """Bytes as a C initializer body: `0x01, 0x02`."""
    return ", ".join(f"0x{b:02x}" for b in raw)


def c_string(text: str) -> str:
    """A C string literal."""
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def c_string_lines(text: str, width: int = 96) -> str:
    """A long C string literal as adjacent literals, one per line (the compiler joins them)."""
    chunks = [text[i:i + width] for i in range(0, len(text), width)] or [""]
    return "\n".join("    " + c_string(c) for c in chunks)


def c_path(path: model.Path, base: str) -> str:
    """`base` + path as C member/index access: ('a', 1, 'b') -> `base.a[1].b`."""
    out = base
    for part in path:
        out += f"[{part}]" if isinstance(part, int) else f".{part}"
    return out


def _merge_runs(runs: list[tuple[int, str]]) -> list[tuple[int, str]]:
    """Adjacent runs of one format code merged: [(1,'f'), (2,'f'), (1,'B')] -> [(3,'f'), (1,'B')]."""
    merged: list[tuple[int, str]] = []
    for n, code in runs:
        if merged and merged[-1][1] == code:
            merged[-1] = (merged[-1][0] + n, code)
        else:
            merged.append((n, code))
    return merged


def py_literal(value: Any) -> str:
    return repr(value)


_BLANK_RUNS = re.compile(r"\n{3,}")


def tidy(text: str) -> str:
    """Trailing whitespace removed, at most one blank line in a row, one final newline."""
    lines = [line.rstrip() for line in text.splitlines()]
    return _BLANK_RUNS.sub("\n\n", "\n".join(lines)).strip("\n") + "\n"
