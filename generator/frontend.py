"""Front end: C files -> plain records. The only module that imports libclang.

Each input is parsed as its own translation unit. Any diagnostic of severity error or worse
aborts the whole run (a partial AST is never catalogued). The records below hold no clang
objects; the model (model.py) decides what is packed and what is skipped.
"""

from __future__ import annotations

import json
import os
import shlex
import shutil
import subprocess
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Iterator, Union

import clang.cindex as ci

# ---------------------------------------------------------------------------------------------
# Plain records


@dataclass(frozen=True)
class SourceLoc:
    file: str  # as given to/seen by clang; made relative by the model
    line: int

    def __str__(self) -> str:
        return f"{self.file}:{self.line}"


@dataclass(frozen=True)
class FeScalar:
    """An arithmetic C type. kind: 'bool', 'int' or 'float'."""

    kind: str
    size: int  # bytes (clang's sizeof)
    signed: bool
    spelling: str  # C spelling, for messages and comments
    plain_char: bool = False  # `char` itself (neither `signed char` nor `unsigned char`)
    is_enum: bool = False
    is_long_double: bool = False


@dataclass(frozen=True)
class FeRecordRef:
    """A struct type, by key (FeRecord.key)."""

    key: str


@dataclass(frozen=True)
class FeOther:
    """Something the model will skip. what: 'pointer', 'union', 'flexible', 'unsupported'."""

    what: str
    spelling: str


FeType = Union[FeScalar, FeRecordRef, FeOther]


@dataclass(frozen=True)
class FeField:
    name: str  # '' for an anonymous union member
    type: FeType  # element type for arrays
    dims: tuple[int, ...]
    offset_bits: int
    bit_width: int | None
    loc: SourceLoc


@dataclass(frozen=True)
class FeRecord:
    """A struct definition. Anonymous struct members are already flattened into `fields`."""

    key: str  # "struct tag", a typedef name, or "<parent key>::<member>" for an unnamed type
    c_name: str | None  # C spelling usable in generated code; None for an unnamed type
    size: int
    align: int
    packed: bool
    fields: tuple[FeField, ...]
    loc: SourceLoc


@dataclass(frozen=True)
class FeInstance:
    name: str
    type_key: str
    dims: tuple[int, ...]
    loc: SourceLoc


@dataclass(frozen=True)
class FeUnit:
    """What one translation unit contributed."""

    file: str
    records: tuple[FeRecord, ...]
    instances: tuple[FeInstance, ...]
    skipped_instances: tuple[tuple[str, SourceLoc, str], ...]  # (name, loc, reason)


class FrontendError(Exception):
    """Parse or usage failure (the CLI exits 2). The message is already `file:line: text`."""


# ---------------------------------------------------------------------------------------------
# Flags


@dataclass(frozen=True)
class ParseOptions:
    include_dirs: tuple[str, ...] = ()
    defines: tuple[str, ...] = ()
    std: str = "c11"
    extra_args: tuple[str, ...] = ()
    compile_commands: str | None = None
    builtin_include: str | None = None  # found by find_builtin_include() when None

    def base_args(self) -> list[str]:
        args = [f"-std={self.std}"]
        args += [f"-I{d}" for d in self.include_dirs]
        args += [f"-D{d}" for d in self.defines]
        return args


def find_builtin_include() -> str:
    """The directory holding the compiler's own headers (stddef.h, stdbool.h, stdarg.h...).

    The libclang wheel ships none, so borrow them: clang's resource dir if a clang is
    installed, else gcc's (`gcc -print-file-name=include`)."""
    probes = (
        ("clang", ["-print-resource-dir"], "include"),
        ("gcc", ["-print-file-name=include"], ""),
        ("cc", ["-print-file-name=include"], ""),
    )
    for tool, args, sub in probes:
        exe = shutil.which(tool)
        if not exe:
            continue
        try:
            out = subprocess.run([exe, *args], capture_output=True, text=True, timeout=10, check=False).stdout
        except (OSError, subprocess.SubprocessError):
            continue
        cand = Path(out.strip()) / sub if sub else Path(out.strip())
        if (cand / "stddef.h").is_file():
            return str(cand)
    raise FrontendError(
        "error: no compiler builtin headers (stddef.h) found; the libclang wheel ships none. "
        "Install a C compiler: `apt-get install gcc` (or clang)."
    )


def _args_from_compile_commands(db_path: str, source: str) -> list[str] | None:
    """Flags for `source` from compile_commands.json (None when the file has no entry)."""
    try:
        entries = json.loads(Path(db_path).read_text())
    except (OSError, ValueError) as exc:
        raise FrontendError(f"{db_path}: error: cannot read compile commands: {exc}") from exc
    if not isinstance(entries, list) or not entries:
        raise FrontendError(f"{db_path}: error: compile commands must be a non-empty JSON array")
    want = os.path.realpath(source)
    chosen = None
    for entry in entries:
        path = os.path.join(entry.get("directory", "."), entry.get("file", ""))
        if os.path.realpath(path) == want:
            chosen = entry
            break
    if chosen is None:
        return None
    return _clean_compile_args(chosen)


def _first_compile_args(db_path: str) -> list[str]:
    entries = json.loads(Path(db_path).read_text())
    return _clean_compile_args(entries[0])


def _clean_compile_args(entry: dict) -> list[str]:
    """Compiler flags of one entry with the compiler, -c, -o X and the source removed; relative
    include paths made absolute against the entry's directory."""
    directory = entry.get("directory", ".")
    raw = entry["arguments"] if "arguments" in entry else shlex.split(entry.get("command", ""))
    src = entry.get("file", "")
    out: list[str] = []
    i = 1  # skip the compiler
    while i < len(raw):
        arg = raw[i]
        if arg == "-c" or arg == src:
            i += 1
            continue
        if arg == "-o":
            i += 2
            continue
        if arg in ("-I", "-isystem", "-include", "-iquote") and i + 1 < len(raw):
            out += [arg, _absolute(directory, raw[i + 1])]
            i += 2
            continue
        if arg.startswith("-I") and len(arg) > 2:
            out.append("-I" + _absolute(directory, arg[2:]))
        elif arg.startswith("-isystem") and len(arg) > 8:
            out.append("-isystem" + _absolute(directory, arg[8:]))
        elif arg.endswith((".c", ".o")) and not arg.startswith("-"):
            pass
        else:
            out.append(arg)
        i += 1
    return out


def _absolute(directory: str, path: str) -> str:
    return path if os.path.isabs(path) else os.path.normpath(os.path.join(directory, path))


def args_for(opts: ParseOptions, source: str) -> list[str]:
    """Every clang argument for one input file (builtin headers first)."""
    builtin = opts.builtin_include or find_builtin_include()
    args = ["-x", "c", "-isystem", builtin]
    if opts.compile_commands:
        db_args = _args_from_compile_commands(opts.compile_commands, source)
        # A header has no entry of its own: it takes the first entry's flags (docs/catalogue.md).
        args += db_args if db_args is not None else _first_compile_args(opts.compile_commands)
        if not any(a.startswith("-std=") for a in args):
            args.append(f"-std={opts.std}")
        args += [f"-I{d}" for d in opts.include_dirs] + [f"-D{d}" for d in opts.defines]
    else:
        args += opts.base_args()
    return args + list(opts.extra_args)


# ---------------------------------------------------------------------------------------------
# Parsing


def parse_files(files: Iterable[str], opts: ParseOptions) -> list[FeUnit]:
    """Parses every file as its own translation unit; raises FrontendError on any clang error."""
    if opts.builtin_include is None:
        opts = ParseOptions(**{**opts.__dict__, "builtin_include": find_builtin_include()})
    index = ci.Index.create()
    return [_parse_one(index, f, opts) for f in files]


def _parse_one(index: ci.Index, path: str, opts: ParseOptions) -> FeUnit:
    if not os.path.isfile(path):
        raise FrontendError(f"{path}: error: no such file")
    try:
        tu = index.parse(path, args=args_for(opts, path))
    except ci.TranslationUnitLoadError as exc:
        raise FrontendError(f"{path}: error: clang could not parse the file ({exc})") from exc
    errors = [d for d in tu.diagnostics if d.severity >= ci.Diagnostic.Error]
    if errors:
        raise FrontendError("\n".join(_format_diag(d) for d in errors))
    walker = _Walker()
    walker.visit_tu(tu)
    return FeUnit(path, tuple(walker.records.values()), tuple(walker.instances), tuple(walker.skipped))


def _format_diag(diag: ci.Diagnostic) -> str:
    loc = diag.location
    where = f"{loc.file.name}:{loc.line}" if loc.file else "<command line>"
    severity = "fatal error" if diag.severity >= ci.Diagnostic.Fatal else "error"
    return f"{where}: {severity}: {diag.spelling}"


def _loc(cursor: ci.Cursor) -> SourceLoc:
    loc = cursor.location
    return SourceLoc(loc.file.name if loc.file else "<built-in>", loc.line)


_SIGNED = {
    ci.TypeKind.SCHAR, ci.TypeKind.SHORT, ci.TypeKind.INT, ci.TypeKind.LONG, ci.TypeKind.LONGLONG,
    ci.TypeKind.WCHAR,
}
_UNSIGNED = {
    ci.TypeKind.UCHAR, ci.TypeKind.USHORT, ci.TypeKind.UINT, ci.TypeKind.ULONG, ci.TypeKind.ULONGLONG,
    ci.TypeKind.CHAR16, ci.TypeKind.CHAR32,
}
_PLAIN_CHAR = {ci.TypeKind.CHAR_S, ci.TypeKind.CHAR_U}
_FLOATS = {ci.TypeKind.FLOAT: False, ci.TypeKind.DOUBLE: False, ci.TypeKind.LONGDOUBLE: True}
_POINTERS = {ci.TypeKind.POINTER, ci.TypeKind.BLOCKPOINTER, ci.TypeKind.MEMBERPOINTER}
_RECORD_CURSORS = {ci.CursorKind.STRUCT_DECL, ci.CursorKind.UNION_DECL}


def _strip_qualifiers(spelling: str) -> str:
    words = [w for w in spelling.split(" ") if w not in ("const", "volatile", "restrict", "_Atomic")]
    return " ".join(words)


def _is_unnamed(decl: ci.Cursor) -> bool:
    return "(unnamed" in decl.spelling or "(anonymous" in decl.spelling or decl.spelling == ""


@dataclass
class _Walker:
    records: dict[str, FeRecord] = field(default_factory=dict)
    instances: list[FeInstance] = field(default_factory=list)
    skipped: list[tuple[str, SourceLoc, str]] = field(default_factory=list)

    def visit_tu(self, tu: ci.TranslationUnit) -> None:
        for cur in tu.cursor.get_children():
            if cur.kind != ci.CursorKind.VAR_DECL or cur.location.is_in_system_header:
                continue
            if cur.storage_class == ci.StorageClass.STATIC or cur.linkage != ci.LinkageKind.EXTERNAL:
                continue
            self._visit_var(cur)

    def _visit_var(self, cur: ci.Cursor) -> None:
        ctype = cur.type.get_canonical()
        dims: list[int] = []
        while ctype.kind == ci.TypeKind.CONSTANTARRAY:
            dims.append(ctype.element_count)
            ctype = ctype.element_type.get_canonical()
        if ctype.kind != ci.TypeKind.RECORD:
            return
        decl = ctype.get_declaration()
        if decl.kind != ci.CursorKind.STRUCT_DECL:
            self.skipped.append((cur.spelling, _loc(cur), "union"))
            return
        if _is_unnamed(decl):
            self.skipped.append((cur.spelling, _loc(cur), "unnamed struct type (give the type a tag or typedef)"))
            return
        if ctype.get_size() < 0:
            self.skipped.append((cur.spelling, _loc(cur), "incomplete struct type (no definition visible)"))
            return
        key = self._record(ctype, None)
        self.instances.append(FeInstance(cur.spelling, key, tuple(dims), _loc(cur)))

    def _record(self, ctype: ci.Type, unnamed_key: str | None) -> str:
        """Records the struct `ctype` (canonical) and what it needs; returns its key."""
        decl = ctype.get_declaration()
        if unnamed_key is None:
            key = _strip_qualifiers(ctype.spelling)
            c_name: str | None = key
        else:
            key, c_name = unnamed_key, None
        if key in self.records:
            return key
        fields = tuple(self._fields(ctype, decl, key, 0))
        packed = any(ch.kind == ci.CursorKind.PACKED_ATTR for ch in decl.get_children())
        self.records[key] = FeRecord(key, c_name, ctype.get_size(), ctype.get_align(), packed, fields, _loc(decl))
        return key

    def _fields(self, ctype: ci.Type, decl: ci.Cursor, key: str, base_bits: int) -> Iterator[FeField]:
        """Fields in declaration order; members of anonymous structs are flattened (as C does)."""
        children = list(decl.get_children())
        used_decls = [_element_type(ch.type).get_declaration() for ch in children if ch.kind == ci.CursorKind.FIELD_DECL]
        for ch in children:
            if ch.kind in _RECORD_CURSORS and _is_unnamed(ch) and not any(ch == u for u in used_decls):
                yield from self._anonymous_member(ctype, ch, key, base_bits)
            elif ch.kind == ci.CursorKind.FIELD_DECL:
                if ch.is_bitfield() and not ch.spelling:
                    continue  # unnamed bitfield: padding, not a member
                yield self._field(ch, key, base_bits)

    def _anonymous_member(self, ctype: ci.Type, rec: ci.Cursor, key: str, base_bits: int) -> Iterator[FeField]:
        if rec.kind == ci.CursorKind.UNION_DECL:
            offset = _first_field_offset(rec, ctype, base_bits)
            yield FeField("", FeOther("union", "anonymous union"), (), offset, None, _loc(rec))
            return
        # Offsets of members of an anonymous struct are asked of the enclosing type: clang
        # resolves names through anonymous members, exactly as C's offsetof does.
        for inner in self._fields(rec.type, rec, key, 0):
            offset = ctype.get_offset(inner.name) if inner.name else -1
            offset = offset + base_bits if offset >= 0 else base_bits + inner.offset_bits
            yield FeField(inner.name, inner.type, inner.dims, offset, inner.bit_width, inner.loc)

    def _field(self, ch: ci.Cursor, key: str, base_bits: int) -> FeField:
        ftype = ch.type.get_canonical()
        dims: list[int] = []
        while ftype.kind == ci.TypeKind.CONSTANTARRAY:
            dims.append(ftype.element_count)
            ftype = ftype.element_type.get_canonical()
        width = ch.get_bitfield_width() if ch.is_bitfield() else None
        offset = ch.get_field_offsetof() + base_bits
        if ftype.kind == ci.TypeKind.INCOMPLETEARRAY:
            return FeField(ch.spelling, FeOther("flexible", ch.type.spelling), (), offset, None, _loc(ch))
        return FeField(ch.spelling, self._type(ftype, f"{key}::{ch.spelling}"), tuple(dims), offset, width, _loc(ch))

    def _type(self, ftype: ci.Type, unnamed_key: str) -> FeType:
        kind = ftype.kind
        spelling = _strip_qualifiers(ftype.spelling)
        size = ftype.get_size()
        if kind == ci.TypeKind.BOOL:
            return FeScalar("bool", size, False, spelling)
        if kind in _PLAIN_CHAR:
            return FeScalar("int", size, kind == ci.TypeKind.CHAR_S, spelling, plain_char=True)
        if kind in _SIGNED or kind in _UNSIGNED:
            return FeScalar("int", size, kind in _SIGNED, spelling)
        if kind in _FLOATS:
            return FeScalar("float", size, True, spelling, is_long_double=_FLOATS[kind])
        if kind == ci.TypeKind.ENUM:
            int_kind = ftype.get_declaration().enum_type.get_canonical().kind
            return FeScalar("int", size, int_kind in _SIGNED or int_kind == ci.TypeKind.CHAR_S, spelling, is_enum=True)
        if kind in _POINTERS or kind == ci.TypeKind.FUNCTIONPROTO:
            return FeOther("pointer", spelling)
        if kind == ci.TypeKind.RECORD:
            decl = ftype.get_declaration()
            if decl.kind == ci.CursorKind.UNION_DECL:
                return FeOther("union", spelling)
            return FeRecordRef(self._record(ftype, unnamed_key if _is_unnamed(decl) else None))
        return FeOther("unsupported", spelling)


def _element_type(t: ci.Type) -> ci.Type:
    t = t.get_canonical()
    while t.kind in (ci.TypeKind.CONSTANTARRAY, ci.TypeKind.INCOMPLETEARRAY):
        t = t.element_type.get_canonical()
    return t


def _first_field_offset(rec: ci.Cursor, ctype: ci.Type, base_bits: int) -> int:
    for ch in rec.get_children():
        if ch.kind == ci.CursorKind.FIELD_DECL and ch.spelling:
            off = ctype.get_offset(ch.spelling)
            if off >= 0:
                return off + base_bits
    return base_bits
