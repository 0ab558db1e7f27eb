"""Front end: C files -> plain records. The only module that imports libclang.

Each input is parsed as its own translation unit. An input with any diagnostic of severity error
or worse contributes nothing (a partial AST is never catalogued): parse_inputs() returns an
FeFailure for it, carrying every error with the header where it occurred and the `#include`
chain that led there, so one run reports every failing input. The records below hold no clang
objects; the model (model.py) decides what is packed, skipped or refused.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import shlex
import shutil
import subprocess
import tempfile
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
    enum_key: str | None = None  # FeEnum.key when is_enum


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
    readonly: bool = False  # declared `const` (the member, or each element of an array member)
    comment: str | None = None  # the member's doc comment or trailing comment, as written (model parses units)


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
class FeEnum:
    """An enum type used by a member: its constants in declaration order."""

    key: str  # "enum tag", a typedef name, or "<parent key>::<member>" for an unnamed enum
    constants: tuple[tuple[str, int], ...]
    loc: SourceLoc


@dataclass(frozen=True)
class FeInstance:
    name: str
    type_key: str
    dims: tuple[int, ...]
    loc: SourceLoc
    definition: bool = False  # a definition (with or without initializer), not only `extern`
    runtime: bool = False  # made from a type by --instance-per-type/--instances-from: no C object to link


@dataclass(frozen=True)
class IncludeRef:
    """One `#include` the generated header can write: the directive's operand and the file it opens."""

    text: str  # '<stdint.h>' or '"nav/nav_msg.h"'; '' when no search directory finds the file (the
    # generated header then includes it by its path relative to the output directory: no extra -I)
    path: str  # the file clang opened


@dataclass(frozen=True)
class FeUnit:
    """What one translation unit contributed."""

    file: str
    records: tuple[FeRecord, ...]
    instances: tuple[FeInstance, ...]
    skipped_instances: tuple[tuple[str, SourceLoc, str], ...]  # (name, loc, reason)
    enums: tuple[FeEnum, ...] = ()
    # Struct types defined at file scope outside system headers: (C spelling, loc); for the hint
    # given when a run finds types but no instance.
    defined_types: tuple[tuple[str, SourceLoc], ...] = ()
    is_source: bool = False  # a `.c` file (the generated header cannot include it)
    self_include: IncludeRef | None = None  # a header input: how the generated header includes it
    top_includes: tuple[IncludeRef, ...] = ()  # a `.c` input: its own #include lines, in order
    # A `.c` input: record key -> index into top_includes of the #include that brings its
    # definition in (-1: defined in the .c file itself).
    record_via: tuple[tuple[str, int], ...] = ()
    # With ParseOptions.all_types: every complete struct type defined outside system headers, by each
    # of its names (`struct tag`, typedef names): (name, record key); its record is in `records`.
    named_records: tuple[tuple[str, str], ...] = ()


@dataclass(frozen=True)
class FeDiagnostic:
    severity: str  # "error" or "fatal error"
    loc: SourceLoc | None  # None: the command line
    message: str
    included_from: tuple[SourceLoc, ...] = ()  # the #include lines from the input down to loc.file


@dataclass(frozen=True)
class FeFailure:
    """An input that cannot be catalogued: every error clang reported while parsing it."""

    file: str
    diagnostics: tuple[FeDiagnostic, ...]

    def format(self, rel=lambda p: p) -> str:
        """`input: error: ...` then, per diagnostic, its include chain and `header:line: severity: message`
        (clang's layout), every path through `rel`."""
        n = len(self.diagnostics)
        lines = [f"{rel(self.file)}: error: cannot be parsed ({n} error{'s' if n != 1 else ''}):"]
        for d in self.diagnostics:
            lines += [f"  In file included from {rel(s.file)}:{s.line}:" for s in d.included_from]
            where = f"{rel(d.loc.file)}:{d.loc.line}" if d.loc else "<command line>"
            lines.append(f"  {where}: {d.severity}: {d.message}")
        return "\n".join(lines)


class FrontendError(Exception):
    """Parse or usage failure (the CLI exits 2). The message is already `file:line: text`."""


# ---------------------------------------------------------------------------------------------
# Flags


@dataclass(frozen=True)
class TargetAbi:
    """What clang must match to lay types out as a (cross) compiler does: found by query_target()."""

    cc: str  # the compiler as given (`arm-none-eabi-gcc`)
    triple: str  # its `-dumpmachine`
    include_dirs: tuple[str, ...]  # its system include directories, in search order
    clang_args: tuple[str, ...]  # --target, -nostdinc, -isystem of each directory, ABI flags
    macros: tuple[tuple[str, str], ...] = ()  # its predefined macros (`-dM -E`), sorted


@dataclass(frozen=True)
class ParseOptions:
    include_dirs: tuple[str, ...] = ()
    defines: tuple[str, ...] = ()
    std: str = "c11"
    extra_args: tuple[str, ...] = ()
    compile_commands: str | None = None
    builtin_include: str | None = None  # found by find_builtin_include() when None
    target: TargetAbi | None = None  # parse with this compiler's ABI and headers (--target-cc)
    clang_skip: tuple[str, ...] = ()  # the build's flags clang does not know (found by clang_unknown_args())
    all_types: bool = False  # record every struct type defined outside system headers (handle-based inputs)

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


_LAUNCHERS = ("ccache", "sccache", "distcc")  # compiler launchers a compile command may start with


def first_compile_args(db_path: str) -> list[str]:
    """The first entry's flags: what a header (no entry of its own) is parsed with, and the build's
    flags that --target-cc's compiler is asked with."""
    entries = json.loads(Path(db_path).read_text())
    return _clean_compile_args(entries[0])


def compile_args_sets(db_path: str) -> list[list[str]]:
    """The flags of the entries that bring flags no earlier entry had (in file order, the first entry
    always): what must be asked about to know every flag parsing will meet, without asking about
    each of a large build's entries (they mostly share one set)."""
    seen: set[str] = set()
    sets: list[list[str]] = []
    for entry in json.loads(Path(db_path).read_text()):
        args = _clean_compile_args(entry)
        if not sets or not seen.issuperset(args):
            sets.append(args)
            seen.update(args)
    return sets


def _clean_compile_args(entry: dict) -> list[str]:
    """Compiler flags of one entry with the compiler, -c, -o X and the source removed; relative
    include paths made absolute against the entry's directory."""
    directory = entry.get("directory", ".")
    raw = entry["arguments"] if "arguments" in entry else shlex.split(entry.get("command", ""))
    src = entry.get("file", "")
    out: list[str] = []
    i = 1  # skip the compiler (and a launcher before it: `ccache arm-none-eabi-gcc ...`)
    while i < len(raw) and os.path.basename(raw[i - 1]) in _LAUNCHERS:
        i += 1
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


# Left out of parsing: a build's -Werror judges the build compiler's warnings; clang warns about other
# things (a header parsed as a main file: `#pragma once in main file`), and under -Werror each of them
# would fail the input (what is an error in C stays one). Dependency-file flags (-MMD -MP, which make's
# builds carry) would have clang write a .d file per input into the current folder: the user's tree.
_NOT_FOR_PARSING = re.compile(r"^(-Werror(=.*)?|-pedantic-errors|-M|-MM|-MD|-MMD|-MP|-MG)$")
_NOT_FOR_PARSING_WITH_VALUE = ("-MF", "-MT", "-MQ")


def _for_parsing(flags: Iterable[str], skip: tuple[str, ...]) -> list[str]:
    """The build's flags as clang parses with them: without those it does not know, -Werror and the
    dependency-file flags."""
    out: list[str] = []
    drop_next = False
    for a in flags:
        if drop_next:
            drop_next = False
        elif a in _NOT_FOR_PARSING_WITH_VALUE:
            drop_next = True
        elif a not in skip and not _NOT_FOR_PARSING.match(a):
            out.append(a)
    return out


def args_for(opts: ParseOptions, source: str) -> list[str]:
    """Every clang argument for one input file (builtin headers first; with a target, its headers)."""
    if opts.target is not None:
        args = ["-x", "c", *opts.target.clang_args]
    else:
        args = ["-x", "c", "-isystem", opts.builtin_include or find_builtin_include()]
    if opts.compile_commands:
        db_args = _args_from_compile_commands(opts.compile_commands, source)
        # A header has no entry of its own: it takes the first entry's flags (docs/catalogue.md).
        args += _for_parsing(db_args if db_args is not None else first_compile_args(opts.compile_commands),
                             opts.clang_skip)
        if not any(a.startswith("-std=") for a in args):
            args.append(f"-std={opts.std}")
        args += [f"-I{d}" for d in opts.include_dirs] + [f"-D{d}" for d in opts.defines]
    else:
        args += opts.base_args()
    return args + _for_parsing(opts.extra_args, opts.clang_skip)


# ---------------------------------------------------------------------------------------------
# Target ABI (--target-cc)

# Flags of the build that change what the compiler predefines or how it lays types out: they go to
# the compiler when it is asked, as they go to clang when it parses.
_ABI_FLAG = re.compile(r"^(-m|-f|--specs=|--sysroot|-isysroot|-std=|-ansi$|-nostdinc)")
_CROSS_CC = re.compile(r"^[A-Za-z0-9_.]+(-[A-Za-z0-9_.]+){1,3}-(gcc|cc|clang)(-[0-9.]+)?$")


def abi_flags(args: Iterable[str]) -> list[str]:
    """The flags among `args` that change the ABI or the predefined macros (machine and -f flags)."""
    return [a for a in args if _ABI_FLAG.match(a)]


def is_cross_compiler(cc: str) -> bool:
    """A compiler named with a target prefix (`arm-none-eabi-gcc`, `aarch64-linux-gnu-gcc-12`)."""
    return bool(_CROSS_CC.match(os.path.basename(cc)))


def compile_commands_compiler(db_path: str) -> str | None:
    """The compiler of the first entry of compile_commands.json (None when it cannot be read)."""
    try:
        entry = json.loads(Path(db_path).read_text())[0]
        raw = entry["arguments"] if "arguments" in entry else shlex.split(entry.get("command", ""))
        while raw and os.path.basename(raw[0]) in _LAUNCHERS:
            raw = raw[1:]  # a compiler launcher: the compiler follows
        return raw[0] if raw else None
    except (OSError, ValueError, LookupError, TypeError):
        return None


def _ask(cc: str, args: list[str], cwd: str | None = None) -> subprocess.CompletedProcess[str]:
    try:
        return subprocess.run([cc, *args], capture_output=True, text=True, timeout=60, check=False,
                              stdin=subprocess.DEVNULL, cwd=cwd)
    except OSError as exc:
        raise FrontendError(f"error: --target-cc {cc}: cannot run it ({exc.strerror}); install it or give its "
                            "full path (e.g. `apt-get install gcc-arm-none-eabi`)") from None
    except subprocess.TimeoutExpired:
        raise FrontendError(f"error: --target-cc {cc}: no answer within 60 s") from None


def query_target(cc: str, flags: Iterable[str] = ()) -> TargetAbi:
    """Asks a (cross) compiler what clang must match: its target triple (`-dumpmachine`), its system
    include directories (`-E -v`), and its predefined macros (`-dM -E`: char signedness, the ARM
    EABI's minimal enum size, wchar_t size). `flags`: the build's machine flags (abi_flags())."""
    flags = list(flags)
    triple = _ask(cc, ["-dumpmachine"]).stdout.strip()
    if not triple:
        raise FrontendError(f"error: --target-cc {cc}: `{cc} -dumpmachine` printed no target; "
                            "give a GCC or clang driver")
    verbose = _ask(cc, [*flags, "-E", "-v", "-x", "c", os.devnull])
    if verbose.returncode != 0:
        raise FrontendError(f"error: --target-cc {cc} refuses the build's flags ({' '.join(flags)}): "
                            f"{_first_error(verbose.stderr)}")
    dirs: list[str] = []
    inside = False
    for line in verbose.stderr.splitlines():
        if line.startswith("#include <...> search starts here:"):
            inside = True
        elif line.startswith("End of search list."):
            break
        elif inside and line.startswith(" "):
            path = line.strip().removesuffix(" (framework directory)")
            if os.path.isdir(path):
                dirs.append(os.path.normpath(path))
    if not dirs:
        raise FrontendError(f"error: --target-cc {cc}: `{cc} -E -v` listed no system include directory")
    defs = _ask(cc, [*flags, "-dM", "-E", "-x", "c", os.devnull]).stdout
    macros = dict(m.groups() for m in re.finditer(r"^#define (\w+) ?(.*)$", defs, re.M))
    args = [f"--target={triple}", "-nostdinc"]
    for d in dirs:
        args += ["-isystem", d]
    args.append("-funsigned-char" if "__CHAR_UNSIGNED__" in macros else "-fsigned-char")
    if macros.get("__ARM_SIZEOF_MINIMAL_ENUM") == "1" or macros.get("__SIZEOF_ENUM__") == "1":
        args.append("-fshort-enums")  # the ARM EABI's variable-size enums (arm-none-eabi-gcc's default)
    if macros.get("__SIZEOF_WCHAR_T__") == "2":
        args.append("-fshort-wchar")
    return TargetAbi(cc, triple, tuple(dirs), tuple(args), tuple(sorted(macros.items())))


def _first_error(stderr: str) -> str:
    return next((ln.strip() for ln in stderr.splitlines() if "error" in ln), stderr.strip()[:200] or "no message")


# What clang and the target compiler must agree on, each with the flag that usually decides it. The
# probe is parsed by clang with the final arguments; the values clang finds become _Static_asserts
# that the target compiler checks (check_target_abi()).
_ABI_PROBE_TYPES = """
enum ub_abi_enum { UB_ABI_ENUM_A = 1 };
struct ub_abi_ll { char c; long long x; };
struct ub_abi_d { char c; double x; };
struct ub_abi_bf { unsigned char a : 3; unsigned int b : 7; };
"""
_ABI_CHECKS = (
    # (C expression, what it is, the flags that change it, the probe variable clang measures, how)
    ("sizeof(enum ub_abi_enum)", "enum size", "-fshort-enums / -fno-short-enums", "enum ub_abi_enum", "size"),
    ("sizeof(short)", "short size", "the target (--target-cc)", "short", "size"),
    ("sizeof(int)", "int size", "the target (--target-cc)", "int", "size"),
    ("sizeof(long)", "long size", "-m32 / -m64 / -mabi", "long", "size"),
    ("sizeof(void *)", "pointer size", "-m32 / -m64 / -mabi", "void *", "size"),
    ("sizeof(long double)", "long double size", "-mlong-double-64/80/128", "long double", "size"),
    ("sizeof(double)", "double size", "-mdouble / -fshort-double", "double", "size"),
    ("_Alignof(long long)", "long long alignment", "-malign-double / -m32", "long long", "align"),
    ("__builtin_offsetof(struct ub_abi_ll, x)", "long long alignment in structs", "-malign-double / -m32",
     "struct ub_abi_ll", "offset_x"),
    ("__builtin_offsetof(struct ub_abi_d, x)", "double alignment in structs", "-malign-double / -m32",
     "struct ub_abi_d", "offset_x"),
    ("sizeof(struct ub_abi_bf)", "bitfield layout", "-mms-bitfields / -fpack-struct", "struct ub_abi_bf", "size"),
    ("((char)-1 < 0)", "plain char signedness", "-funsigned-char / -fsigned-char", "char", "signed"),
)


def check_target_abi(opts: ParseOptions, flags: Iterable[str] | None = None) -> None:
    """Parses a probe with clang exactly as the inputs will be, then has the target compiler check
    every value clang found (one _Static_assert each): a disagreement that would misplace members is
    caught here, named with the flag that decides it, before any input is catalogued."""
    target = opts.target
    if target is None:
        return
    cc_flags = abi_flags(opts.extra_args if flags is None else flags)
    values = _clang_abi_values(opts, cc_flags)
    lines = [_ABI_PROBE_TYPES]
    for (expr, what, flag, _, _), value in zip(_ABI_CHECKS, values):
        lines.append(f'_Static_assert({expr} == {value}, "uavbus-abi: {what}: clang {value} ({flag})");')
    # In a folder of its own: the build's flags may make the compiler write files (-fstack-usage, -save-temps).
    with tempfile.TemporaryDirectory(prefix="uavbus-abi-") as tmp:
        probe = os.path.join(tmp, "probe.c")
        Path(probe).write_text("\n".join(lines) + "\n")
        proc = _ask(target.cc, [*cc_flags, "-std=gnu11", "-fsyntax-only", probe], cwd=tmp)
    wrong = re.findall(r"uavbus-abi: ([^\"]+)", proc.stderr)
    if wrong:
        raise FrontendError(
            f"error: clang and --target-cc {target.cc} lay types out differently: " + "; ".join(dict.fromkeys(wrong))
            + f". Pass the flag that decides it after `--` (the flags {target.cc} builds the firmware with)")
    if proc.returncode != 0:
        raise FrontendError(f"error: --target-cc {target.cc} cannot compile the ABI probe: {_first_error(proc.stderr)}")


_UNKNOWN_ARG = re.compile(r"^(?:unknown argument|unsupported option|unknown target CPU|unknown warning option|"
                          r"the clang compiler does not support|optimization flag):? '([^']+)'")


def clang_unknown_args(opts: ParseOptions, flags: Iterable[str]) -> tuple[str, ...]:
    """The build's flags that clang refuses (a GCC-only `-mno-thumb-interwork`, `--specs=nano.specs`):
    a cross build's command line is GCC's, and one unknown flag would fail every input. They change
    no layout clang must match (the ABI probe checks that), so parsing leaves them out."""
    target = opts.target
    base = ["-x", "c", *(target.clang_args if target else ("-isystem", opts.builtin_include or find_builtin_include()))]
    flags = _for_parsing(flags, ())
    path = "uavbus_flags_probe.c"
    with _quiet_stderr():  # libclang's driver prints what it refuses; the note says it once, with what is done
        tu = ci.Index.create().parse(path, args=[*base, *flags], unsaved_files=[(path, "int uavbus_flags_probe;\n")])
    unknown = [m.group(1) for d in tu.diagnostics if (m := _UNKNOWN_ARG.match(d.spelling))]
    return tuple(a for a in dict.fromkeys(unknown) if a in flags)


@contextlib.contextmanager
def _quiet_stderr() -> Iterator[None]:
    """Descriptor 2 to /dev/null for a while (libclang writes driver diagnostics there itself)."""
    saved = os.dup(2)
    try:
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def _clang_abi_values(opts: ParseOptions, flags: list[str]) -> list[int]:
    """What clang finds for each _ABI_CHECKS entry, from one probe variable per check."""
    target = opts.target
    assert target is not None
    src = _ABI_PROBE_TYPES + "".join(f"{decl} ub_abi_v{k};\n" for k, (_, _, _, decl, _) in enumerate(_ABI_CHECKS))
    path = "uavbus_abi_probe.c"
    args = ["-x", "c", *target.clang_args, *_for_parsing(flags, opts.clang_skip), "-std=gnu11"]
    tu = ci.Index.create().parse(path, args=args, unsaved_files=[(path, src)])
    errors = [d.spelling for d in tu.diagnostics if d.severity >= ci.Diagnostic.Error]
    if errors:
        raise FrontendError(f"error: clang cannot parse for --target-cc {target.cc} (--target={target.triple}): "
                            f"{errors[0]}")
    types = {cur.spelling: cur.type.get_canonical() for cur in tu.cursor.get_children()
             if cur.kind == ci.CursorKind.VAR_DECL and cur.spelling.startswith("ub_abi_v")}
    out = []
    for k, (_, _, _, _, how) in enumerate(_ABI_CHECKS):
        t = types[f"ub_abi_v{k}"]
        if how == "size":
            out.append(t.get_size())
        elif how == "align":
            out.append(t.get_align())
        elif how == "offset_x":
            out.append(t.get_offset("x") // 8)
        else:
            out.append(1 if t.kind == ci.TypeKind.CHAR_S else 0)
    return out


# ---------------------------------------------------------------------------------------------
# Parsing


def parse_inputs(files: Iterable[str], opts: ParseOptions) -> list[Union[FeUnit, FeFailure]]:
    """Parses every file as its own translation unit, in order: an FeUnit for each input that
    parsed without error, an FeFailure (every error, with its include chain) for each other."""
    if opts.builtin_include is None and opts.target is None:
        opts = ParseOptions(**{**opts.__dict__, "builtin_include": find_builtin_include()})
    index = ci.Index.create()
    return [_parse_one(index, f, opts) for f in files]


def parse_files(files: Iterable[str], opts: ParseOptions) -> list[FeUnit]:
    """Every input's records; raises FrontendError naming every failing input."""
    results = parse_inputs(files, opts)
    failures = [r for r in results if isinstance(r, FeFailure)]
    if failures:
        raise FrontendError("\n".join(f.format() for f in failures))
    return [r for r in results if isinstance(r, FeUnit)]


SOURCE_SUFFIXES = (".c", ".i")


def is_source(path: str) -> bool:
    """A translation unit's own source (`.c`): generated code can never #include it."""
    return path.endswith(SOURCE_SUFFIXES)


def _parse_one(index: ci.Index, path: str, opts: ParseOptions) -> Union[FeUnit, FeFailure]:
    if not os.path.isfile(path):
        return FeFailure(path, (FeDiagnostic("error", None, f"no such file: {path}"),))
    args = args_for(opts, path)
    try:
        tu = index.parse(path, args=args)
    except ci.TranslationUnitLoadError as exc:
        return FeFailure(path, (FeDiagnostic("error", None, f"clang could not parse the file ({exc})"),))
    errors = [d for d in tu.diagnostics if d.severity >= ci.Diagnostic.Error]
    if errors:
        parents = _include_parents(tu)
        return FeFailure(path, tuple(_diagnostic(d, parents) for d in errors))
    walker = _Walker(all_types=opts.all_types)
    walker.visit_tu(tu)
    search = _include_dirs(args)
    source = is_source(path)
    top: tuple[IncludeRef, ...] = ()
    via: tuple[tuple[str, int], ...] = ()
    if source:
        top, via = _source_includes(tu, path, walker.records, search)
    return FeUnit(
        file=path,
        records=tuple(walker.records.values()),
        instances=tuple(walker.instances),
        skipped_instances=tuple(walker.skipped),
        enums=tuple(walker.enums.values()),
        defined_types=tuple(walker.defined),
        is_source=source,
        self_include=None if source else IncludeRef(_quoted(_spell_path(path, search)), path),
        top_includes=top,
        record_via=via,
        named_records=tuple(walker.named),
    )


def _include_parents(tu: ci.TranslationUnit) -> dict[str, tuple[str, int, int]]:
    """Included file -> (including file, line of the #include, depth), first inclusion of each."""
    parents: dict[str, tuple[str, int, int]] = {}
    for inc in tu.get_includes():
        name = os.path.normpath(inc.include.name)
        if name not in parents and inc.location.file is not None:
            parents[name] = (os.path.normpath(inc.location.file.name), inc.location.line, inc.depth)
    return parents


def _chain(file: str, parents: dict[str, tuple[str, int, int]]) -> tuple[SourceLoc, ...]:
    """The #include lines leading from the main file to `file`, outermost first."""
    out: list[SourceLoc] = []
    cur = os.path.normpath(file)
    while cur in parents and len(out) < 200:
        src, line, _ = parents[cur]
        out.append(SourceLoc(src, line))
        cur = src
    return tuple(reversed(out))


def _diagnostic(diag: ci.Diagnostic, parents: dict[str, tuple[str, int, int]]) -> FeDiagnostic:
    severity = "fatal error" if diag.severity >= ci.Diagnostic.Fatal else "error"
    loc = diag.location
    if loc.file is None:
        return FeDiagnostic(severity, None, diag.spelling)
    return FeDiagnostic(severity, SourceLoc(loc.file.name, loc.line), diag.spelling, _chain(loc.file.name, parents))


def _include_dirs(args: list[str]) -> tuple[str, ...]:
    """The quote/angle search directories of a command line (-iquote, -I, -isystem, -idirafter), in
    clang's search order, absolute."""
    quote: list[str] = []
    angle: list[str] = []
    after: list[str] = []
    i = 0
    while i < len(args):
        arg = args[i]
        for flag, bucket in (("-iquote", quote), ("-isystem", angle), ("-idirafter", after), ("-I", angle)):
            if arg == flag and i + 1 < len(args):
                bucket.append(os.path.abspath(args[i + 1]))
                i += 1
                break
            if arg.startswith(flag) and len(arg) > len(flag) and not (flag == "-I" and arg.startswith("-include")):
                bucket.append(os.path.abspath(arg[len(flag):]))
                break
        i += 1
    return tuple(quote + angle + after)


def _quoted(spelled: str | None) -> str:
    return f'"{spelled}"' if spelled else ""


def _spell_path(path: str, search: tuple[str, ...]) -> str | None:
    """How `#include "..."` reaches `path` from anywhere: relative to the search directory that
    finds it first (shortest such spelling), else None (no -I finds it: the generated header then
    includes it by its path relative to itself)."""
    target = os.path.realpath(path)
    candidates = sorted({os.path.relpath(target, os.path.realpath(d)) for d in search
                         if os.path.commonpath([os.path.realpath(d), target]) == os.path.realpath(d)}, key=len)
    for rel in candidates:
        if _resolve(rel, search) == target:
            return rel.replace(os.sep, "/")
    return None


def _resolve(spelled: str, search: tuple[str, ...]) -> str | None:
    for d in search:
        cand = os.path.join(d, spelled)
        if os.path.isfile(cand):
            return os.path.realpath(cand)
    return None


_INCLUDE_LINE = re.compile(r'^\s*#\s*(?:include|include_next|import)\s*([<"][^>"]+[>"])')


def _source_includes(tu: ci.TranslationUnit, path: str, records: dict[str, FeRecord], search: tuple[str, ...]
                     ) -> tuple[tuple[IncludeRef, ...], tuple[tuple[str, int], ...]]:
    """A `.c` input's own #include lines (as the generated header can write them) and, for each
    record, the one that brings its definition in (-1: the record is defined in the .c file)."""
    parents = _include_parents(tu)
    main = os.path.normpath(path)
    try:
        lines = Path(path).read_text(errors="replace").splitlines()
    except OSError:
        lines = []
    top: list[tuple[int, IncludeRef]] = []
    for name, (src, line, depth) in parents.items():
        if depth != 1 or src != main:
            continue
        m = _INCLUDE_LINE.match(lines[line - 1]) if 0 < line <= len(lines) else None
        text = m.group(1) if m else _quoted(_spell_path(name, search))
        if text.startswith('"') and _resolve(text[1:-1], search) != os.path.realpath(name):
            # Found next to the .c file (or through a macro): spell it so the search path finds it.
            text = _quoted(_spell_path(name, search))
        top.append((line, IncludeRef(text, name)))
    top.sort(key=lambda x: x[0])
    index = {ref.path: k for k, (_, ref) in enumerate(top)}
    via = []
    for key, rec in records.items():
        chain = _chain(rec.loc.file, parents)
        if not chain:
            via.append((key, -1))  # defined in the main file
            continue
        # The outermost #include of the chain sits in the main file; it opened chain[1]'s file
        # (or the record's own file when the chain has one step).
        opened = os.path.normpath(chain[1].file) if len(chain) > 1 else os.path.normpath(rec.loc.file)
        via.append((key, index.get(opened, -1)))
    return tuple(ref for _, ref in top), tuple(via)


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

SKIP_STATIC = "static: internal linkage, not visible to other translation units (remove `static` to publish it)"
SKIP_UNKNOWN_BOUND = "array of unknown bound (declare its size, e.g. `extern T x[N];`, or define it in an input)"
SKIP_ZERO_LENGTH = "zero-length array (no element to publish)"


def _strip_qualifiers(spelling: str) -> str:
    words = [w for w in spelling.split(" ") if w not in ("const", "volatile", "restrict", "_Atomic")]
    return " ".join(words)


def _is_unnamed(decl: ci.Cursor) -> bool:
    return "(unnamed" in decl.spelling or "(anonymous" in decl.spelling or decl.spelling == ""


@dataclass
class _Walker:
    records: dict[str, FeRecord] = field(default_factory=dict)
    enums: dict[str, FeEnum] = field(default_factory=dict)
    instances: list[FeInstance] = field(default_factory=list)
    skipped: list[tuple[str, SourceLoc, str]] = field(default_factory=list)
    defined: list[tuple[str, SourceLoc]] = field(default_factory=list)
    all_types: bool = False
    named: list[tuple[str, str]] = field(default_factory=list)

    def visit_tu(self, tu: ci.TranslationUnit) -> None:
        for cur in tu.cursor.get_children():
            if cur.location.is_in_system_header:
                continue
            if cur.kind == ci.CursorKind.VAR_DECL:
                self._visit_var(cur)
            elif cur.kind in (ci.CursorKind.STRUCT_DECL, ci.CursorKind.TYPEDEF_DECL):
                self._note_type(cur)

    def _note_type(self, cur: ci.Cursor) -> None:
        if cur.kind == ci.CursorKind.STRUCT_DECL:
            spelling = cur.type.spelling  # "struct tag"; a typedef name for `typedef struct {...} t`
            if cur.is_definition() and spelling.startswith("struct ") and not _is_unnamed(cur):
                self.defined.append((spelling, _loc(cur)))
                self._name_record(spelling, cur.type.get_canonical())
            return
        under = cur.underlying_typedef_type.get_canonical()
        if under.kind == ci.TypeKind.RECORD and under.get_declaration().kind == ci.CursorKind.STRUCT_DECL:
            self.defined.append((cur.spelling, _loc(cur)))
            self._name_record(cur.spelling, under)

    def _name_record(self, name: str, ctype: ci.Type) -> None:
        """With all_types: records a struct type defined in the inputs under one of its names (the
        types of handle-based object systems have no global instance to lead to them)."""
        if not self.all_types or ctype.get_size() < 0 or "(unnamed" in ctype.spelling or "(anonymous" in ctype.spelling:
            return
        self.named.append((name, self._record(ctype, None)))

    def _visit_var(self, cur: ci.Cursor) -> None:
        ctype = cur.type.get_canonical()
        dims: list[int] = []
        unknown_bound = False
        while ctype.kind in (ci.TypeKind.CONSTANTARRAY, ci.TypeKind.INCOMPLETEARRAY):
            if ctype.kind == ci.TypeKind.INCOMPLETEARRAY:
                unknown_bound = True
            else:
                dims.append(ctype.element_count)
            ctype = ctype.element_type.get_canonical()
        if ctype.kind != ci.TypeKind.RECORD:
            return  # not a structure: not a directory
        static = cur.storage_class == ci.StorageClass.STATIC or cur.linkage != ci.LinkageKind.EXTERNAL
        decl = ctype.get_declaration()
        if decl.kind != ci.CursorKind.STRUCT_DECL:
            reason = "union"
        elif _is_unnamed(decl):
            reason = "unnamed struct type (give the type a tag or typedef)"
        elif ctype.get_size() < 0:
            reason = "incomplete struct type (no definition visible)"
        elif static:
            reason = SKIP_STATIC
        elif unknown_bound:
            reason = SKIP_UNKNOWN_BOUND
        elif 0 in dims:
            reason = SKIP_ZERO_LENGTH
        else:
            key = self._record(ctype, None)
            # A file-scope object without `extern` is a (possibly tentative) definition.
            definition = cur.is_definition() or cur.storage_class != ci.StorageClass.EXTERN
            self.instances.append(FeInstance(cur.spelling, key, tuple(dims), _loc(cur), definition))
            return
        self.skipped.append((cur.spelling, _loc(cur), reason))

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
            yield FeField(inner.name, inner.type, inner.dims, offset, inner.bit_width, inner.loc, inner.readonly,
                          inner.comment)

    def _field(self, ch: ci.Cursor, key: str, base_bits: int) -> FeField:
        ftype = ch.type.get_canonical()
        dims: list[int] = []
        # clang's canonical array types carry the elements' qualifiers on the array: look at every level.
        readonly = ftype.is_const_qualified()
        while ftype.kind == ci.TypeKind.CONSTANTARRAY:
            dims.append(ftype.element_count)
            ftype = ftype.element_type.get_canonical()
            readonly = readonly or ftype.is_const_qualified()
        width = ch.get_bitfield_width() if ch.is_bitfield() else None
        offset = ch.get_field_offsetof() + base_bits
        if ftype.kind == ci.TypeKind.INCOMPLETEARRAY or 0 in dims:
            # `T tail[]` (C99) and GNU's `T tail[0]`: storage past the end of the struct.
            return FeField(ch.spelling, FeOther("flexible", ch.type.spelling), (), offset, None, _loc(ch))
        # `const T m;`, `const T m[N]` and a typedef that carries the const all leave the canonical
        # element type const-qualified: unpack may not assign to such a member (docs/catalogue.md).
        return FeField(ch.spelling, self._type(ftype, f"{key}::{ch.spelling}"), tuple(dims), offset, width, _loc(ch),
                       readonly, _member_comment(ch))

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
            decl = ftype.get_declaration()
            int_kind = decl.enum_type.get_canonical().kind
            enum_key = self._enum(decl, spelling, unnamed_key)
            signed = int_kind in _SIGNED or int_kind == ci.TypeKind.CHAR_S
            return FeScalar("int", size, signed, spelling, is_enum=True, enum_key=enum_key)
        if kind in _POINTERS or kind == ci.TypeKind.FUNCTIONPROTO:
            return FeOther("pointer", spelling)
        if kind == ci.TypeKind.RECORD:
            decl = ftype.get_declaration()
            if decl.kind == ci.CursorKind.UNION_DECL:
                return FeOther("union", spelling)
            return FeRecordRef(self._record(ftype, unnamed_key if _is_unnamed(decl) else None))
        return FeOther("unsupported", spelling)

    def _enum(self, decl: ci.Cursor, spelling: str, unnamed_key: str) -> str:
        """Records an enum's constants; its key is `enum tag`, its typedef name, or the member's
        `<parent>::<member>` for an enum with neither (like unnamed struct members)."""
        key = unnamed_key if _is_unnamed(decl) and not re.match(r"^[A-Za-z_]\w*$", spelling) else spelling
        if key not in self.enums:
            consts = tuple((c.spelling, int(c.enum_value)) for c in decl.get_children()
                           if c.kind == ci.CursorKind.ENUM_CONSTANT_DECL)
            self.enums[key] = FeEnum(key, consts, _loc(decl))
        return key


_TRAILING = re.compile(r"^[^;]*;\s*(?:/\*+<?\s*(.*?)\s*\*+/|//+<?\s*(.*?)\s*$)")
_LINES: dict[str, list[str]] = {}


def _member_comment(ch: ci.Cursor) -> str | None:
    """What the header says about a member: its doc comment (`/** ... */` above it, `/**< ... */` after it),
    else a plain comment after it on the same line (`double p; /* rad/s */`). Units and descriptions are
    the model's business (model.parse_comment); this only finds the text."""
    raw = ch.raw_comment
    if raw:
        return _comment_text(raw)
    end = ch.extent.end
    if end.file is None:
        return None
    path = end.file.name
    lines = _LINES.get(path)
    if lines is None:
        try:
            lines = _LINES[path] = Path(path).read_text(encoding="utf-8", errors="replace").splitlines()
        except OSError:
            lines = _LINES[path] = []
    if not 0 < end.line <= len(lines):
        return None
    m = _TRAILING.match(lines[end.line - 1][end.column - 1:])
    if m is None:
        return None
    text = (m.group(1) if m.group(1) is not None else m.group(2) or "").strip()
    return text or None


def _comment_text(raw: str) -> str | None:
    """A doc comment without its markers: `/**< [m/s] speed */` -> `[m/s] speed`."""
    text = re.sub(r"^\s*(?:/\*+<?|//+<?)", "", raw.strip())
    text = re.sub(r"\*+/\s*$", "", text)
    parts = [re.sub(r"^\s*\*?\s?", "", line).strip() for line in text.splitlines()]
    joined = " ".join(p for p in parts if p)
    return joined or None


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
