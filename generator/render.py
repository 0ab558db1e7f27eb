"""Rendering: model -> {relative_path: text} through Jinja2 templates named after model classes.

Templates live in `templates/<lang>/<ModelClass>.<ext>.j2`; a model class is rendered by the first
template found along its MRO (nunavut style), so a new subclass needs no dispatch code. Identifier
mangling (C and Python keywords, names our generated code uses) happens here and nowhere else,
driven by `templates/properties.json`. Nothing here writes files; output is deterministic.
"""

from __future__ import annotations

import json
import os
import re
from dataclasses import dataclass
from itertools import product
from pathlib import Path
from typing import Any

import jinja2

from . import model
from .model import Catalogue, Field, StructType

from uavbus._paths import TEMPLATES_DIR as TEMPLATE_DIR  # package data (templates/ in the repository)
ABI_VERSION = 2  # must equal UB_CATALOGUE_ABI_VERSION in runtime_c/include/ub/ub_catalogue.h


class Properties:
    """Per-language reserved identifiers and the prefixes for names the language would mangle
    (templates/properties.json)."""

    def __init__(self, data: dict[str, Any]) -> None:
        self.reserved = {lang: frozenset(v["reserved_identifiers"]) for lang, v in data.items()}
        self.dunder_prefix = {lang: v.get("dunder_prefix", {}) for lang, v in data.items()}

    @classmethod
    def load(cls, template_dir: Path = TEMPLATE_DIR) -> "Properties":
        return cls(json.loads((template_dir / "properties.json").read_text()))

    def mangle(self, name: str, lang: str, role: str = "attribute") -> str:
        """`name` unchanged unless the language would not take it as is: a name with a leading `__`
        (Python mangles it inside class bodies) gets the role's prefix (`C` for a class, `m` for an
        attribute); a reserved name gets a trailing underscore (repeated until free, so `pack_`
        stays distinct from a mangled `pack`).

        >>> p = Properties({"py": {"reserved_identifiers": ["class"], "dunder_prefix": {"class": "C"}}})
        >>> p.mangle("__pthread", "py", "class"), p.mangle("class", "py")
        ('C__pthread', 'class_')
        """
        prefix = self.dunder_prefix.get(lang, {}).get(role)
        if prefix and name.startswith("__"):
            name = prefix + name
        while name in self.reserved[lang]:
            name += "_"
        return name


@dataclass(frozen=True)
class RenderInputs:
    name: str  # NAME: output base name and C/Python prefix
    catalogue_json: str = ""  # compact catalogue JSON, embedded in NAME.c as the catalogue's self-description
    outdir: str | None = None  # where NAME.h goes: input headers no -I finds are included relative to it


def c_include(inc: "str | model.IncludeFile", outdir: str | None) -> str:
    """An #include operand: as the inputs spell it, or an input header's path relative to the
    directory of the generated header (a quoted include is looked up there first; no -I needed).

    >>> c_include(model.IncludeFile("/src/fw/nav/nav.h"), "/src/out")
    '"../fw/nav/nav.h"'
    """
    if isinstance(inc, str):
        return inc
    if outdir is None:
        return f'"{os.path.basename(inc.path)}"'
    return '"' + os.path.relpath(inc.path, os.path.abspath(outdir)).replace(os.sep, "/") + '"'


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
            c_put=c_put, c_get=c_get, c_get_ro=c_get_ro, c_store_type=c_store_type, c_literal=c_literal,
            c_bytes=c_bytes, c_string=c_string,
            c_valid=c_valid, c_value_type=c_value_type,
            py_attr=lambda n: self.props.mangle(n, "py"), py_class=self.py_class,
            py_format=self.py_format, py_literal=py_literal, hex8=lambda v: f"0x{v:08x}",
            c_include=lambda inc: c_include(inc, inputs.outdir),
        )
        self.env.globals.update(
            cat=cat, NAME=inputs.name, abi_version=ABI_VERSION, model=model,
            type_of=cat.type, leaves_of=self.leaves_count, C_PATH=c_path, render_node=self.render_node,
            id_scheme_c="UB_ID_SCHEME_" + cat.id_scheme.upper(), catalogue_json=inputs.catalogue_json,
            check_runs=check_runs, json_rows=c_json_rows, wire_checks=lambda t: model.wire_checks(cat, t),
            py_checks=self.py_checks, py_property_checks=self.py_property_checks, indexes=lambda dims: list(product(*(range(d) for d in dims))), concrete=_concrete, LOOP_MIN=LOOP_MIN,
            rounds=PROPERTY_ROUNDS, bind_bases=lambda: bind_bases(cat), abi_hint=lambda t: abi_hint(cat, t),
            bindable=lambda i: bindable(i, cat),
        )
        self._py_classes = self._python_class_names()

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

    def render_selftest_linux_arm(self) -> dict[str, str]:
        """The system-call shim that lets a bare-metal ARM self-test run under qemu-arm (user mode)."""
        n = self.inputs.name
        return {f"{n}_selftest_linux_arm.c": tidy(self.env.get_template("c/SelftestLinuxArm.c.j2").render())}

    def render_selftest(self) -> dict[str, str]:
        """The self-test programs with their shared values: C split into translation units of about
        SELFTEST_CHUNK_WEIGHT leaves each (so they build in parallel at -O0), and Python."""
        n = self.inputs.name
        cases = [SelftestCase.make(self.cat, t) for t in self.cat.named_types]
        chunks: list[list[SelftestCase]] = [[]]
        weight = 0
        for case in cases:
            if chunks[-1] and weight + case.weight > SELFTEST_CHUNK_WEIGHT:
                chunks.append([])
                weight = 0
            chunks[-1].append(case)
            weight += case.weight
        files = {
            f"{n}_selftest.h": tidy(self.env.get_template("c/Selftest.h.j2").render(chunks=chunks)),
            f"{n}_selftest.c": tidy(self.env.get_template("c/Selftest.c.j2").render(chunks=chunks)),
            f"{n}_selftest.py": tidy(self.env.get_template("py/Selftest.py.j2").render(cases=cases)),
        }
        for k, chunk in enumerate(chunks):
            files[f"{n}_selftest_{k}.c"] = tidy(
                self.env.get_template("c/SelftestChunk.c.j2").render(chunk=chunk, chunk_index=k))
        return files

    # -- Python helpers -----------------------------------------------------------------------
    def _python_class_names(self) -> dict[str, str]:
        """Type name -> Python class name, unique in the module (a clash gets underscores)."""
        taken = set(self.props.reserved["py"])
        out: dict[str, str] = {}
        for t in self.cat.types:
            name = self.props.mangle(t.ident, "py", "class")
            while name in taken:
                name += "_"
            taken.add(name)
            out[t.name] = name
        return out

    def py_class(self, t: StructType | str) -> str:
        return self._py_classes[t if isinstance(t, str) else t.name]

    def py_property_checks(self, t: StructType) -> list[tuple[int, str, int, bool, int]]:
        """(offset, kind, bits, signed, container size) of every bool, narrow bitfield and f32 leaf."""
        return [(c.offset, c.kind, c.field.bits or 0, bool(c.field.wire and c.field.wire.signed), c.field.wire.size)  # type: ignore[union-attr]
                for c in model.wire_checks(self.cat, t, f32=True) if c.kind != "ldouble"]

    def py_checks(self, t: StructType) -> tuple[tuple[int, ...], tuple[tuple[int, int, int, str], ...]]:
        """What Python's unpack refuses: byte offsets of bools (a byte other than 0/1) and, per
        bitfield, (index in the flat value tuple, lowest, highest, member name)."""
        bools, ranges = [], []
        for c in model.wire_checks(self.cat, t):
            if c.kind == "bool":
                bools.append(c.offset)
            elif c.kind == "bits":
                lo, hi = c.field.bit_range()
                ranges.append((c.leaf, lo, hi, c.field.name))
        return tuple(bools), tuple(ranges)

    def py_format(self, t: StructType) -> str:
        """struct-module format for the whole type without the '<' prefix, runs merged ('3f' not 'fff')."""
        return "".join(f"{n}{code}" if n > 1 else code for n, code in _merge_runs(self._format_runs(t)))

    def _format_runs(self, t: StructType) -> list[tuple[int, str]]:
        runs: list[tuple[int, str]] = []
        for f in t.packed_fields:
            if f.text:  # one bytes value per innermost row: "16s" (a count on `s` is its length)
                runs += [(1, f"{f.dims[-1]}s")] * (f.count // f.dims[-1])
            elif f.wire:
                runs.append((f.count, f.wire.py_format))
            else:
                runs += self._format_runs(self.cat.type(f.struct)) * f.count  # type: ignore[arg-type]
        return runs

    def leaves_count(self, t: StructType) -> int:
        """Values in the type's flat tuple (a text row is one `bytes` value)."""
        return sum(f.count // f.dims[-1] if f.text else f.count if f.wire
                   else f.count * self.leaves_count(self.cat.type(f.struct))  # type: ignore[arg-type]
                   for f in t.packed_fields)


SELFTEST_CHUNK_WEIGHT = 3000  # C statements per self-test translation unit, roughly
PROPERTY_ROUNDS = 48  # random byte strings per type in the canonical-codec property test


@dataclass(frozen=True)
class LeafGroup:
    """Leaves of one scalar member at every index of the arrays around it: assigned and compared
    by one loop over a value table (`path` holds loop variables `i0`, `i1`... for the indexes)."""

    path: tuple[str | int, ...]
    dims: tuple[int, ...]  # extent of each loop variable, outermost first
    field: Field
    values: tuple[Any, ...]  # row-major
    readonly: bool = False  # the member or one around it is const: the test writes its bytes

    @property
    def count(self) -> int:
        return len(self.values)


@dataclass(frozen=True)
class SelftestCase:
    type: StructType
    leaves: tuple[model.Leaf, ...]
    expected: bytes
    tree: dict
    groups: tuple[LeafGroup, ...]
    checks: tuple[model.WireCheck, ...]

    @classmethod
    def make(cls, cat: Catalogue, t: StructType) -> "SelftestCase":
        leaves = model.test_leaves(cat, t)
        return cls(t, tuple(leaves), model.expected_packed(cat, t), model.value_tree(leaves, cat, t),
                   tuple(_leaf_groups(cat, t, leaves)), tuple(model.wire_checks(cat, t)))

    @property
    def skipped_paths(self) -> tuple[str, ...]:
        """Top-level skipped members the C test can poison and re-check (unpack must not touch them)."""
        # A flexible array has no size and a bitfield no offsetof: neither can be poisoned.
        return tuple(f.name for f in self.type.fields if f.skipped and f.name
                     and f.skipped not in (model.SKIP_FLEXIBLE, model.SKIP_CONST_BITFIELD))

    @property
    def weight(self) -> int:
        return 20 + sum(1 if g.count < LOOP_MIN else 3 + g.count // 8 for g in self.groups)

    @property
    def seed(self) -> int:
        return self.type.fingerprint or 1


LOOP_MIN = 4  # a group of fewer leaves is written out one statement per leaf


def _leaf_groups(cat: Catalogue, t: StructType, leaves: list[model.Leaf]) -> list[LeafGroup]:
    """The leaves of `t` grouped per member path (array indexes abstracted), in first-leaf order."""
    values = {leaf.path: leaf.value for leaf in leaves}
    out: list[LeafGroup] = []

    def walk(t: StructType, prefix: tuple, dims: tuple[int, ...], ro: bool) -> None:
        for f in t.packed_fields:
            var_path = prefix + (f.name,) + tuple(LoopVar(len(dims) + k) for k in range(len(f.dims)))
            all_dims = dims + f.dims
            if f.struct:
                walk(cat.type(f.struct), var_path, all_dims, ro or f.readonly)
                continue
            vals = tuple(values[_concrete(var_path, index)] for index in product(*(range(d) for d in all_dims)))
            out.append(LeafGroup(var_path, all_dims, f, vals, ro or f.readonly))

    walk(t, (), (), False)
    return out


@dataclass(frozen=True)
class LoopVar:
    """An array index that a self-test loop runs over: written `[i<k>]` in C paths."""

    k: int


def _concrete(path: tuple, index: tuple[int, ...]) -> tuple:
    """A group path with its loop variables replaced by `index` (LoopVar(0) -> index[0]...)."""
    return tuple(index[p.k] if isinstance(p, LoopVar) else p for p in path)


@dataclass(frozen=True)
class CheckRun:
    """`count` checked scalars of one member, `stride` bytes apart from `offset` (unpack validation)."""

    field: Field
    offset: int
    count: int
    stride: int


def check_runs(checks: list[model.WireCheck]) -> list[CheckRun]:
    """Refusable scalars (bools, narrow bitfields) merged into runs of equal stride."""
    runs: list[CheckRun] = []
    for c in checks:
        if c.kind == "ldouble":
            continue
        last = runs[-1] if runs else None
        if last is not None and last.field is c.field:
            stride = c.offset - last.offset if last.count == 1 else last.stride
            if c.offset == last.offset + stride * last.count and stride > 0:
                runs[-1] = CheckRun(last.field, last.offset, last.count + 1, stride)
                continue
        runs.append(CheckRun(c.field, c.offset, 1, 0))
    return runs


# -- C filters (pure functions, doctested) --------------------------------------------------------


_ABI_SIZED = re.compile(r"(?<!long )\blong\b(?! long| double)|size_t|ptrdiff_t|intptr")  # long and pointer-sized


def abi_hint(cat: Catalogue, t: StructType) -> str:
    """What in `t` a different compiler ABI lays out differently, with the flag that decides it: the
    text of the layout assertions' messages (a failing one then says where to look, not only
    "regenerate", which changes nothing while the ABI differs)."""
    found: dict[str, None] = {}

    def walk(t: StructType, seen: set[str]) -> None:
        if t.packed_attr:
            found["packing (#pragma pack, -fpack-struct)"] = None
        for f in t.fields:
            spelled = f.c_spelling
            if f.enum or spelled.startswith("enum "):
                found["enum size (-fshort-enums)"] = None
            if f.skipped == model.SKIP_POINTER or _ABI_SIZED.search(spelled):
                found["long and pointer size (-m32/-m64)"] = None
            if f.long_double:
                found["long double size (-mlong-double-*)"] = None
            elif f.wire is not None and f.wire.size == 8 and f.bits is None:
                found["8-byte member alignment (-malign-double, -m32)"] = None
            if f.bits is not None:
                found["bitfield layout (-mms-bitfields)"] = None
            if f.struct and f.struct not in seen:
                seen.add(f.struct)
                walk(cat.type(f.struct), seen)

    walk(t, {t.name})
    where = ", ".join(found) if found else "type sizes and alignment"
    parsed = cat.abi or "clang's default for the generating machine"
    return (f"differs from the catalogue: the ABI of this compiler is not the one the catalogue was parsed with "
            f"({parsed}; check: {where}); regenerate with --target-cc <this compiler> and the flags of this build")


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
    return f"{acc} = {c_read(f)};"


def c_read(f: Field) -> str:
    """The expression that reads one scalar at `p`."""
    w = f.wire
    assert w is not None
    if w.name == "bool":
        return "ub_get_u8(p) != 0u"
    if w.name == "f32":
        return "ub_get_f32le(p)"
    if w.name == "f64":
        return "ub_get_f64le(p)"
    suffix = "" if w.size == 1 else "le"
    read = f"ub_get_u{w.bits}{suffix}(p)"
    return f"({w.c_type}){read}" if w.signed else read


def c_store_type(f: Field) -> str:
    """A C type with the size and representation of the member's storage (the wire's C type holds the
    same bits: an int or enum member has its wire type's size, a bool is one byte 0 or 1)."""
    assert f.wire is not None
    return "long double" if f.long_double else f.wire.c_type


def c_get_ro(f: Field, addr: str) -> str:
    """Unpack of a const member: the value is built in a local of the member's storage type and its
    bytes copied to `addr` (the member's address without the const), never assigned through a const lvalue.

    >>> from uavbus_gen.model import PRIMITIVES, Field, SourceLoc
    >>> c_get_ro(Field("t", (), 0, SourceLoc("x.h", 1), "uint8_t", wire=PRIMITIVES["u8"], readonly=True), "A")
    '{ const uint8_t v = ub_get_u8(p); memcpy(A, &v, sizeof v); }'
    """
    store = c_store_type(f)
    value = c_read(f)
    if f.long_double or (f.wire is not None and f.wire.name == "bool"):
        value = f"({store})({value})"
    return f"{{ const {store} v = {value}; memcpy({addr}, &v, sizeof v); }}"


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


JSON_ROW = 4000  # characters per row of the embedded catalogue (C99: a string literal holds at most 4095)
JSON_PIECE = 1000  # characters per source line of a row (C99: a logical source line holds at most 4095)


def c_json_rows(text: str, row: int = JSON_ROW) -> list[tuple[int, list[str]]]:
    """ASCII text cut into rows of `row` characters, each as (array size, [C string literals, one
    per source line]); the last row holds the rest and the NUL (an empty literal if nothing is left).

    >>> c_json_rows("abcdefg", row=4)
    [(4, ['"abcd"']), (4, ['"efg"'])]
    """
    rows = [text[i:i + row] for i in range(0, len(text), row)]
    if not rows or len(rows[-1]) == row:
        rows.append("")
    out = []
    for k, chunk in enumerate(rows):
        pieces = [chunk[i:i + JSON_PIECE] for i in range(0, len(chunk), JSON_PIECE)] or [""]
        out.append((len(chunk) + (1 if k == len(rows) - 1 else 0), [c_string(p) for p in pieces]))
    return out


def c_value_type(f: Field) -> str:
    """The C type of a self-test value table for `f` (its wire type's C type; long double tables
    hold doubles, the values are exact in both)."""
    assert f.wire is not None
    return f.wire.c_type


def c_valid(f: Field, at: str) -> str:
    """A C condition, true when the wire scalar of checked field `f` at `at` is one unpack accepts.

    >>> from uavbus_gen.model import PRIMITIVES, Field, SourceLoc
    >>> loc = SourceLoc("x.h", 1)
    >>> c_valid(Field("b", (), 0, loc, "_Bool", wire=PRIMITIVES["bool"]), "q")
    'ub_get_u8(q) <= 1u'
    >>> c_valid(Field("s", (), 0, loc, "int", wire=PRIMITIVES["i8"], bits=5), "q")
    '(int8_t)ub_get_u8(q) >= -16 && (int8_t)ub_get_u8(q) <= 15'
    """
    w = f.wire
    assert w is not None
    if w.name == "bool":
        return f"ub_get_u8({at}) <= 1u"
    read = f"ub_get_u{w.bits}{'' if w.size == 1 else 'le'}({at})"
    lo, hi = f.bit_range()
    if not w.signed:
        return f"{read} <= {_c_int(hi, w.bits, False)}"
    val = f"({w.c_type}){read}"
    return f"{val} >= {_c_int(lo, w.bits, True)} && {val} <= {_c_int(hi, w.bits, True)}"


def _c_int(v: int, bits: int, signed: bool) -> str:
    if bits == 64:
        return f"INT64_C({v})" if signed else f"UINT64_C({v})"
    if signed:
        return f"({v + 1} - 1)" if v == -(1 << 31) else str(v)  # INT32_MIN has no literal
    return f"{v}u"


def c_path(path: tuple, base: str) -> str:
    """`base` + path as C member/index access: ('a', 1, 'b') -> `base.a[1].b`; a LoopVar is `[i<k>]`."""
    out = base
    for part in path:
        if isinstance(part, LoopVar):
            out += f"[i{part.k}]"
        else:
            out += f"[{part}]" if isinstance(part, int) else f".{part}"
    return out


def _merge_runs(runs: list[tuple[int, str]]) -> list[tuple[int, str]]:
    """Adjacent runs of one format code merged: [(1,'f'), (2,'f'), (1,'B')] -> [(3,'f'), (1,'B')]."""
    merged: list[tuple[int, str]] = []
    for n, code in runs:
        if merged and merged[-1][1] == code and not code.endswith("s"):  # "6s" twice is "6s6s", not "26s"
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


@dataclass(frozen=True)
class BindBase:
    """One variable the generated bind table refers to (`NAME_storage`): an array's elements are
    separate instances but one C object, declared once with the dimensions its elements span."""

    c_type: str
    base: str
    dims: tuple[int, ...]
    declare: bool  # defined in a `.c` input: NAME.h does not declare it, the table must


def bind_bases(cat: Catalogue) -> list[BindBase]:
    """The variables behind the catalogue's bindable instances, in instance order of first use. An
    instance catalogued once per defining file (`name@file`) is left out: one program links at most
    one of those definitions under that name, and the table cannot tell which."""
    out: dict[str, BindBase] = {}
    for inst in cat.instances:
        t = cat.type(inst.type)
        if not bindable(inst, cat):
            continue
        old = out.get(inst.base)
        dims = tuple(i + 1 for i in inst.index)
        if old is not None:
            dims = tuple(max(a, b) for a, b in zip(old.dims, dims))
        out[inst.base] = BindBase(t.c_name, inst.base, dims, str(inst.loc.file).endswith(".c"))
    return list(out.values())


def bindable(inst: "model.Instance", cat: Catalogue) -> bool:
    # Catalogued from a `.c` input: its declaration in NAME.h (if any) may differ (const, bounds), and
    # redeclaring it could conflict, so it is bound by hand. Header-declared instances are marked weak.
    # Made from a type (handle-based objects): there is no C object to refer to; the application binds it.
    return (inst.qualifier is None and not inst.runtime and cat.type(inst.type).c_name is not None
            and not str(inst.loc.file).endswith(".c"))

