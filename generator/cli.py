"""`uavbus gen | check | selftest`: the only place that reads arguments, writes files or runs tools.

Exit codes: 0 success; 1 the inputs parse but the catalogue cannot be used as is (ID collisions,
one name defined two ways, a type over the payload limit); 2 parse or usage errors, nothing
written (clang errors are printed as `file:line: message`, with their `#include` chain);
3 `--keep-going` wrote a catalogue without the inputs or instances it lists (`--exit-zero`: 0).
"""

from __future__ import annotations

import argparse
import dataclasses
import fnmatch
import os
import platform
import re
import shutil
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

from uavbus._paths import RUNTIME_INCLUDE_DIR as RUNTIME_INCLUDE, RUNTIME_SOURCE_DIR  # package data

from . import frontend, model, render
from .catalogue_json import catalogue_json

RUNTIME_CATALOGUE_C = RUNTIME_SOURCE_DIR / "codec" / "ub_catalogue.c"
SELFTEST_TIMEOUT_S = 300
EXIT_PARTIAL = 3


class UsageError(Exception):
    pass


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="uavbus",
        description="C headers -> checked directory catalogue -> C and Python codecs.",
        epilog="Arguments after `--` go to clang unchanged (and to gcc in selftest), e.g. `-- -include prelude.h`.",
    )
    p.add_argument("command", choices=("gen", "check", "selftest"))
    p.add_argument("files", nargs="+", metavar="FILE",
                   help="headers or .c files, each its own translation unit; a directory means every .h and .c below it")
    p.add_argument("-I", dest="include_dirs", action="append", default=[], metavar="DIR",
                   help="add DIR to the include path (as for the C compiler; repeatable)")
    p.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME[=VAL]",
                   help="define a macro for parsing, as the flight software is compiled (repeatable)")
    p.add_argument("--std", default="c11", help="C standard for clang (and gcc in selftest); default c11")
    p.add_argument("--name", default="catalogue", help="output base name and C/Python prefix; default 'catalogue'")
    p.add_argument("--id-scheme", choices=model.ids.ID_SCHEMES, default="paper",
                   help="content IDs: the paper's first-8+last-8 rule (default) or 'hashed' (7+7+CRC-16)")
    p.add_argument("--compile-commands", metavar="F", help="take each input's flags from this compile_commands.json "
                   "(a cross compiler named there, e.g. arm-none-eabi-gcc, is used as --target-cc)")
    p.add_argument("--target-cc", metavar="CC",
                   help="parse with the ABI and system headers of this (cross) compiler, e.g. arm-none-eabi-gcc "
                        "(its target, include directories, enum size, char signedness; checked before parsing); "
                        "selftest builds with it too")
    p.add_argument("--cc", metavar="CC",
                   help="selftest: the C compiler that builds the self-test (default: --target-cc, else gcc)")
    p.add_argument("--exclude", action="append", default=[], metavar="GLOB",
                   help="leave out inputs matching GLOB: a pattern with '/' matches the path as given, relative "
                        "to the current folder or to the directory input it is under (a trailing '/' takes the "
                        "whole folder); else the file name")
    p.add_argument("-k", "--keep-going", action="store_true",
                   help="catalogue the inputs that parse and list the others; exit 3 when some were left out")
    p.add_argument("--exit-zero", action="store_true", help="with --keep-going: exit 0 even when inputs were left out")
    p.add_argument("--max-payload", type=int, default=model.DEFAULT_MAX_PAYLOAD, metavar="BYTES",
                   help=f"largest packed type a node carries: the runtime's UB_MAX_DIRECTORY (default {model.DEFAULT_MAX_PAYLOAD})")
    p.add_argument("--strings", choices=(model.STRINGS_SKIP, model.STRINGS_BYTES), default=model.STRINGS_SKIP,
                   help="char arrays: skip them (the paper's rule, default) or send their bytes")
    p.add_argument("--string-field", action="append", default=[], metavar="TYPE.MEMBER",
                   help="send these char arrays as bytes (fnmatch pattern on '<type name>.<member>', repeatable)")
    p.add_argument("--instance-per-type", action="append", default=[], metavar="REGEX",
                   help="handle-based objects (UAVObjects, uORB): one instance per struct type whose name matches "
                        "REGEX in full, named by its first group (e.g. '(\\w+)Data', 'struct (\\w+)_s'), else by the "
                        "type name; the application binds its storage at run time (repeatable)")
    p.add_argument("--instances-from", metavar="FILE",
                   help="instances to make from types, one per line: `NAME TYPE` ('#' starts a comment)")
    p.add_argument("-o", dest="outdir", metavar="OUTDIR", help="output directory (gen)")
    p.add_argument("--sanitize", action="store_true", help="selftest: build the C program with ASan/UBSan")
    p.add_argument("-j", "--jobs", type=int, default=os.cpu_count() or 1, metavar="N",
                   help="selftest: compilers run in parallel (default: the number of CPUs)")
    p.add_argument("--timeout", type=float, default=SELFTEST_TIMEOUT_S, metavar="S",
                   help=f"selftest: give up after S seconds (default {SELFTEST_TIMEOUT_S})")
    p.add_argument("-v", "--verbose", action="store_true",
                   help="print timings, every skipped member per type and every instance not catalogued")
    return p


@dataclass(frozen=True)
class Job:
    command: str
    files: tuple[str, ...]
    opts: frontend.ParseOptions
    name: str
    id_scheme: str
    outdir: str | None
    sanitize: bool
    verbose: bool
    build: model.BuildOptions = model.BuildOptions()
    exclude: tuple[str, ...] = ()
    keep_going: bool = False
    exit_zero: bool = False
    jobs: int = 1
    timeout: float = SELFTEST_TIMEOUT_S
    target_cc: str | None = None
    cc: str | None = None

    @property
    def selftest_cc(self) -> str:
        return self.cc or self.target_cc or "gcc"


def parse_args(argv: list[str]) -> Job:
    clang_args: list[str] = []
    if "--" in argv:
        cut = argv.index("--")
        argv, clang_args = argv[:cut], argv[cut + 1:]
    ns = _parser().parse_intermixed_args(argv)
    if ns.command == "gen" and not ns.outdir:
        raise UsageError("gen needs -o OUTDIR")
    if not model.is_identifier(ns.name):
        raise UsageError(f"--name '{ns.name}' is not a C identifier")
    if ns.exit_zero and not ns.keep_going:
        raise UsageError("--exit-zero only applies with --keep-going")
    if ns.max_payload <= 0 or ns.jobs <= 0 or ns.timeout <= 0:
        raise UsageError("--max-payload, --jobs and --timeout must be positive")
    listed = read_instance_list(ns.instances_from) if ns.instances_from else ()
    handles = bool(ns.instance_per_type or ns.instances_from)
    opts = frontend.ParseOptions(tuple(ns.include_dirs), tuple(ns.defines), ns.std, tuple(clang_args),
                                 ns.compile_commands, all_types=handles)
    build = model.BuildOptions(ns.id_scheme, ns.strings, tuple(ns.string_field), ns.max_payload, ns.keep_going,
                               tuple(ns.instance_per_type), listed)
    return Job(ns.command, tuple(ns.files), opts, ns.name, ns.id_scheme, ns.outdir, ns.sanitize, ns.verbose, build,
               tuple(ns.exclude), ns.keep_going, ns.exit_zero, ns.jobs, ns.timeout, ns.target_cc, ns.cc)


def read_instance_list(path: str) -> tuple[tuple[str, str, model.SourceLoc], ...]:
    """`NAME TYPE` per line (TYPE may be `struct tag`); blank lines and '#' comments are ignored."""
    try:
        lines = Path(path).read_text().splitlines()
    except OSError as exc:
        raise UsageError(f"--instances-from {path}: cannot read it ({exc.strerror})") from None
    out = []
    for n, line in enumerate(lines, 1):
        words = line.split("#", 1)[0].split()
        if not words:
            continue
        if len(words) < 2:
            raise UsageError(f"{path}:{n}: expected `NAME TYPE`, e.g. `AttitudeState AttitudeStateData`")
        out.append((words[0], " ".join(words[1:]), model.SourceLoc(os.path.abspath(path), n)))
    return tuple(out)


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        return run(parse_args(argv))
    except UsageError as exc:
        return _fail(f"uavbus: error: {exc}", 2)
    except frontend.FrontendError as exc:
        return _fail(str(exc), 2)
    except model.ModelError as exc:
        for note in getattr(exc, "notes", ()):
            _say(str(note))
        return _fail(str(exc), exc.exit_code)
    except SelftestError as exc:
        return _fail(f"selftest: error: {exc}", 2)
    except ValueError as exc:  # a model constructor refused the input
        return _fail(f"error: {exc}", 2)


def _fail(message: str, code: int) -> int:
    sys.stdout.flush()  # keep stdout and stderr in order when both go to one log
    print(message, file=sys.stderr)
    return code


def _say(message: str) -> None:
    sys.stdout.flush()
    print(message, file=sys.stderr)


# ---------------------------------------------------------------------------------------------
# Inputs


def expand_inputs(job: Job) -> list[str]:
    """The inputs in order: directories replaced by every .h and .c below them (sorted), then
    --exclude applied (exclude_hit())."""
    files: list[tuple[str, str | None]] = []  # (file, the directory input it was found under)
    for f in job.files:
        if os.path.isdir(f):
            found = sorted(str(p) for p in Path(f).rglob("*") if p.suffix in (".h", ".c") and p.is_file())
            if not found:
                raise UsageError(f"{f}: directory holds no .h or .c file")
            files += [(x, f) for x in found]
        else:
            files.append((f, None))
    kept = []
    used: set[str] = set()
    for f, root in files:
        hit = [pat for pat in job.exclude if exclude_hit(pat, f, root)]
        used.update(hit)
        if not hit:
            kept.append(f)
    for pat in job.exclude:
        if pat not in used:
            _say(f"warning: --exclude '{pat}' matches no input")
    if job.exclude and job.verbose:
        _say(f"note: --exclude left out {len(files) - len(kept)} of {len(files)} inputs")
    if not kept:
        raise UsageError("every input is excluded")
    return kept


def excluded_inputs(job: Job) -> list[str]:
    """The files --exclude leaves out of the directory inputs (for the left-out-header rule)."""
    if not job.exclude:
        return []
    out = []
    for f in job.files:
        if os.path.isdir(f):
            out += [str(p) for p in Path(f).rglob("*") if p.suffix in (".h", ".c") and p.is_file()
                    and any(exclude_hit(pat, str(p), f) for pat in job.exclude)]
    return out


def exclude_hit(pattern: str, path: str, root: str | None, cwd: str | None = None) -> bool:
    """Whether --exclude `pattern` leaves out `path`. A pattern without '/' matches the file name; one
    with '/' matches the path as given, relative to the current folder, or relative to the directory
    input it was found under (`lib/*` for `fw/lib/x.h` of input `fw`); a trailing '/' means everything
    below that folder.

    >>> exclude_hit("lib/", "fw/lib/a/x.h", "fw"), exclude_hit("*.c", "fw/x.h", "fw")
    (True, False)
    """
    pat = pattern[:-1] + "/*" if pattern.endswith("/") else pattern
    posix = os.path.normpath(path).replace(os.sep, "/")
    if "/" not in pat:
        return fnmatch.fnmatchcase(posix.rsplit("/", 1)[-1], pat)
    pat = os.path.normpath(pat).replace(os.sep, "/") if not pat.startswith("/") else pat
    here = os.path.abspath(cwd or os.getcwd())
    candidates = {posix, os.path.abspath(path).replace(os.sep, "/"),
                  os.path.relpath(os.path.abspath(path), here).replace(os.sep, "/")}
    if root is not None:
        candidates.add(os.path.relpath(os.path.abspath(path), os.path.abspath(root)).replace(os.sep, "/"))
    return any(fnmatch.fnmatchcase(c, pat) for c in candidates)


@dataclass(frozen=True)
class Loaded:
    cat: model.Catalogue
    files: tuple[str, ...]
    failed: tuple[frontend.FeFailure, ...]
    types_seen: int = 0  # struct types the inputs define (outside system headers)

    def counts(self) -> str:
        """`N instances of M types`, and when nothing came out, how many types were seen."""
        text = f"{len(self.cat.instances)} instances of {len(self.cat.named_types)} types"
        if not self.cat.instances:
            text += (f" ({self.types_seen} struct types seen in the inputs, none with an instance: see the warning)"
                     if self.types_seen else " (no struct type in the inputs)")
        return text

    @property
    def partial(self) -> bool:
        """Something the inputs hold is missing from the catalogue because of --keep-going."""
        return bool(self.failed) or any("payload limit" in s.reason for s in self.cat.skipped_instances)


def with_target(job: Job) -> Job:
    """The job with the target compiler's ABI resolved (--target-cc, or a cross compiler named by
    --compile-commands) and checked against clang's; with or without one, the build's flags clang does not
    know are found (they are left out of parsing)."""
    cc = job.target_cc
    if cc is None and job.opts.compile_commands:
        named = frontend.compile_commands_compiler(job.opts.compile_commands)
        if named and frontend.is_cross_compiler(named):
            cc = named
            _say(f"note: parsing with the ABI of {named}, the compiler of {job.opts.compile_commands} (--target-cc)")
    flags = list(job.opts.extra_args)
    # Every entry's flags are asked about, not only the first one's: a build compiles some files
    # with flags of their own (betaflight: its speed-optimised files), and one flag clang does not
    # know fails every input that carries it.
    flag_sets = ([s + flags for s in frontend.compile_args_sets(job.opts.compile_commands)]
                 if job.opts.compile_commands else [flags])
    flags = flag_sets[0]
    opts = job.opts
    if cc is not None:
        opts = dataclasses.replace(opts, target=frontend.query_target(cc, frontend.abi_flags(flags)))
    skip = tuple(dict.fromkeys(a for fs in flag_sets if fs for a in frontend.clang_unknown_args(opts, fs)))
    if skip:
        whose = f"flags of {cc}" if cc else "flags of the build"
        _say(f"note: clang does not know {', '.join(skip)} ({whose}): left out of parsing; they still "
             "reach the compiler in selftest")
        opts = dataclasses.replace(opts, clang_skip=skip)
    if cc is None:
        return dataclasses.replace(job, opts=opts)
    target = opts.target
    assert target is not None
    frontend.check_target_abi(opts, flags)
    if job.verbose:
        _say(f"note: --target-cc {cc}: {target.triple}, clang {' '.join(target.clang_args)}")
    return dataclasses.replace(job, opts=opts, target_cc=cc)


def load(job: Job) -> Loaded:
    files = expand_inputs(job)
    rel = model.make_relpath(files)
    results = frontend.parse_inputs(files, job.opts)
    failed = tuple(r for r in results if isinstance(r, frontend.FeFailure))
    units = [r for r in results if isinstance(r, frontend.FeUnit)]
    for failure in failed:
        _say(failure.format(rel))
    if failed and not job.keep_going:
        raise frontend.FrontendError(
            f"error: {len(failed)} of {len(files)} inputs cannot be parsed; nothing was written "
            "(fix them, leave them out with --exclude, or catalogue the others with --keep-going)")
    if failed:
        _say(f"warning: {len(failed)} of {len(files)} inputs cannot be parsed and are not catalogued (--keep-going): "
             + ", ".join(rel(f.file) for f in failed))
    if not units:
        raise frontend.FrontendError("error: no input could be parsed; nothing to catalogue")
    # Instances declared only in inputs left out (unparsable, excluded) cannot be referred to by the
    # generated C: the model leaves them out (or catalogues them from another place) and says so.
    left_out = tuple(os.path.abspath(f) for f in [*(x.file for x in failed), *excluded_inputs(job)])
    target = job.opts.target
    build = dataclasses.replace(job.build, left_out=left_out,
                                abi=f"{os.path.basename(target.cc)} ({target.triple})" if target else "")
    cat = model.build_catalogue(units, job.id_scheme, rel, build)
    for note in cat.notes:
        _say(str(note))
    _summarise(job, cat)
    seen = len({name for unit in units for name, _ in unit.defined_types})
    return Loaded(cat, tuple(files), failed, seen)


def _summarise(job: Job, cat: model.Catalogue) -> None:
    """One line per skip reason for members (every member per type with -v); the same for
    instances not catalogued (each with -v)."""
    by_reason = cat.skipped_fields()
    if by_reason:
        counts = ", ".join(f"{len(v)} {reason}" for reason, v in by_reason.items())
        _say(f"note: skipped members (not on the wire): {counts}" + ("" if job.verbose else " (-v lists them per type)"))
        if job.verbose:
            for t in cat.types:
                skipped = [f for f in t.fields if f.skipped]
                if skipped:
                    _say(f"{t.loc}: note: {t.name}: " + ", ".join(f"{f.name or '(anonymous)'} ({f.skipped})" for f in skipped))
    if cat.skipped_instances:
        reasons: dict[str, int] = {}
        for s in cat.skipped_instances:
            key = s.reason.split(" (")[0].split(":")[0]
            reasons[key] = reasons.get(key, 0) + 1
        counts = ", ".join(f"{n} {r}" for r, n in sorted(reasons.items()))
        _say(f"note: instances not catalogued: {counts}" + ("" if job.verbose else " (-v lists them)"))
        if job.verbose:
            for s in cat.skipped_instances:
                _say(f"{s.loc}: note: instance '{s.name}' not catalogued: {s.reason}")


def generate(job: Job, cat: model.Catalogue, with_selftest: bool = False, outdir: str | None = None) -> dict[str, str]:
    """Every output file's text; `outdir`: where they go (inputs no -I finds are included relative to it)."""
    # An input header included by its path relative to the output is only shadowed when it lies there.
    names = [render.c_include(inc, outdir).strip('"') if isinstance(inc, model.IncludeFile)
             else inc.strip('"<>').split("/")[-1] for inc in cat.includes]
    if f"{job.name}.h" in names:
        raise UsageError(f"--name {job.name} would make {job.name}.h include itself instead of the input "
                         f"header of that name; choose another --name")
    renderer = render.Renderer(cat, render.RenderInputs(job.name, catalogue_json(cat, job.name, compact=True), outdir))
    out = renderer.render()
    out[f"{job.name}.catalogue.json"] = catalogue_json(cat, job.name)
    if with_selftest:
        out.update(renderer.render_selftest())
    return out


def write_files(outdir: str, files: dict[str, str]) -> None:
    os.makedirs(outdir, exist_ok=True)
    for rel, text in sorted(files.items()):
        with open(os.path.join(outdir, rel), "w", encoding="utf-8", newline="\n") as fh:
            fh.write(text)


def run(job: Job) -> int:
    started = time.perf_counter()
    job = with_target(job)
    loaded = load(job)
    cat = loaded.cat
    done = EXIT_PARTIAL if loaded.partial and not job.exit_zero else 0
    if job.command == "check":
        print(f"check: {loaded.counts()}, IDs unique ({job.id_scheme} rule)"
              + (f"; {len(loaded.failed)} inputs left out" if loaded.failed else ""))
        _timing(job, "check", started)
        return done
    if job.command == "gen":
        files = generate(job, cat, outdir=job.outdir or ".")
        _timing(job, "generation", started)
        write_files(job.outdir or ".", files)
        print(f"gen: {loaded.counts()} -> "
              + ", ".join(os.path.join(job.outdir or ".", f) for f in sorted(files)))
        return done
    code = selftest(job, loaded, started)
    return code if code else done


def _timing(job: Job, what: str, started: float) -> None:
    if job.verbose:
        _say(f"{what} time: {time.perf_counter() - started:.3f} s")


# ---------------------------------------------------------------------------------------------
# selftest


class SelftestError(Exception):
    """A build or run problem: one line saying what happened and what to do."""


def selftest(job: Job, loaded: Loaded, started: float) -> int:
    cat = loaded.cat
    expected = f"{model.expected_digest(cat):08x}"
    n = len(cat.named_types)
    deadline = time.monotonic() + job.timeout
    c_line = py_line = None
    plan = run_plan(job)
    if job.sanitize and plan.shim:
        raise UsageError("--sanitize needs a self-test built for this machine; leave it out with a cross compiler")
    with tempfile.TemporaryDirectory(prefix="uavbus-selftest-") as tmp:
        files = generate(job, cat, with_selftest=True, outdir=tmp)
        if plan.shim:
            renderer = render.Renderer(cat, render.RenderInputs(job.name, "", tmp))
            files.update(renderer.render_selftest_linux_arm())
        _timing(job, "generation", started)
        write_files(tmp, files)
        sources = sorted(f for f in files if f.endswith(".c"))
        with ThreadPoolExecutor(max_workers=max(1, job.jobs)) as pool:
            # Python runs beside the C compilers; each compiler gets its own worker.
            py_future = pool.submit(_run_py, job, tmp, deadline)
            try:
                c_line = _run_c(job, tmp, sources, plan, deadline, pool, n)
            except SelftestError as exc:
                _say(f"selftest: error: {exc}")
            try:
                py_line = py_future.result()
            except SelftestError as exc:
                _say(f"selftest: error: {exc}")
    print(c_line or "selftest: C failed")
    print(py_line or "selftest: Python failed")
    want_c = f"selftest: C {n} types ok, digest {expected}"
    want = [want_c, f"selftest: Python {n} types ok, digest {expected}"]
    if plan.skip and c_line == f"selftest: C {n} types built ({plan.triple}), run skipped: {plan.skip}":
        ok = py_line == want[1]  # built (every layout assertion held) and stated as not run
    else:
        ok = [c_line, py_line] == want
    if not ok:
        _say(f"selftest: FAILED (expected digest {expected} from the model's own encoder)")
    _timing(job, "selftest", started)
    return 0 if ok else 1


@dataclass(frozen=True)
class RunPlan:
    """How the C self-test is built and run: by which compiler, for which target, and where."""

    cc: str
    triple: str
    runner: tuple[str, ...] = ()  # prefix of the run command (qemu-arm ...); () runs the program directly
    skip: str | None = None  # why the program cannot run here (it is still built: the layout assertions hold)
    shim: bool = False  # bare-metal ARM: link the Linux system-call shim and run under qemu-arm


# Target architecture (from the compiler's predefined macros) -> qemu user-mode emulator (Debian qemu-user).
_QEMU = (("__aarch64__", "__AARCH64EB__", "qemu-aarch64", "qemu-aarch64_be"),
         ("__arm__", "__ARMEB__", "qemu-arm", "qemu-armeb"),
         ("__powerpc64__", "__LITTLE_ENDIAN__", "qemu-ppc64", "qemu-ppc64le"),
         ("__powerpc__", None, "qemu-ppc", None),
         ("__mips64", "__MIPSEL__", "qemu-mips64", "qemu-mips64el"),
         ("__mips__", "__MIPSEL__", "qemu-mips", "qemu-mipsel"),
         ("__s390x__", None, "qemu-s390x", None),
         ("__riscv_xlen 64", None, "qemu-riscv64", None),
         ("__riscv_xlen 32", None, "qemu-riscv32", None))
_HOST_ARCH = {"x86_64": ("__x86_64__", "__i386__"), "amd64": ("__x86_64__", "__i386__"),
              "aarch64": ("__aarch64__",), "arm64": ("__aarch64__",)}


def run_plan(job: Job) -> RunPlan:
    """Where the self-test built by job.selftest_cc with the build's flags can run: on this machine,
    under a qemu user-mode emulator, or nowhere here (stated, with the reason)."""
    cc = job.selftest_cc
    if shutil.which(cc) is None and not os.path.isfile(cc):
        raise SelftestError(f"cannot run {cc}: not found; install it (e.g. `apt-get install gcc`) or pass --cc")
    try:
        triple = subprocess.run([cc, "-dumpmachine"], capture_output=True, text=True, timeout=60,
                                check=False).stdout.strip() or "unknown"
        defs = subprocess.run([cc, *frontend.abi_flags(build_flags(job)), "-dM", "-E", "-x", "c", os.devnull],
                              capture_output=True, text=True, timeout=60, check=False, stdin=subprocess.DEVNULL).stdout
    except (OSError, subprocess.SubprocessError) as exc:
        raise SelftestError(f"cannot run {cc} ({exc})") from None
    # Names, and `NAME VALUE` for the few an architecture tells by value (__riscv_xlen 32 or 64).
    macros = set(re.findall(r"^#define (\w+)", defs, re.M)) | set(re.findall(r"^#define (\w+ \w+)$", defs, re.M))
    host = _HOST_ARCH.get(platform.machine().lower(), ())
    linux = "__linux__" in macros
    if linux and any(m in macros for m in host):
        return RunPlan(cc, triple)
    for arch, alt_macro, emu, alt_emu in _QEMU:
        if arch not in macros:
            continue
        emulator = alt_emu if alt_macro and alt_macro in macros and alt_emu else emu
        if not linux and not (arch == "__arm__" and "__ARMEB__" not in macros and "__linux__" not in macros
                              and _has_newlib(cc, job)):
            return RunPlan(cc, triple, skip=f"{triple} is bare metal and only bare-metal little-endian ARM with "
                                            "newlib runs under qemu user mode here")
        if shutil.which(emulator) is None:
            return RunPlan(cc, triple, skip=f"{emulator} is not installed (apt-get install qemu-user)")
        if linux:
            sysroot = f"/usr/{triple}"
            return RunPlan(cc, triple, (emulator, "-L", sysroot) if os.path.isdir(sysroot) else (emulator,))
        return RunPlan(cc, triple, (emulator,), shim=True)
    return RunPlan(cc, triple, skip=f"no emulator for {triple} on this {platform.machine()} machine")


def _has_newlib(cc: str, job: Job) -> bool:
    """The compiler links newlib's nosys.specs (what the qemu-arm shim builds on)."""
    try:
        out = subprocess.run([cc, *frontend.abi_flags(build_flags(job)), "-print-file-name=nosys.specs"],
                             capture_output=True, text=True, timeout=60, check=False).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return False
    return os.path.isabs(out) and os.path.isfile(out)


# Flags of a compile command that the self-test leaves out: its own optimisation level and debug
# information (-O0 -g0 keep a large straight-line test fast to build), -Werror (warnings are judged by
# where they are), LTO, and dependency files.
_NOT_FOR_SELFTEST = re.compile(r"^(-O.*|-g.*|-Werror(=.*)?|-pedantic-errors|-flto.*|-fuse-linker-plugin|-M[MDP]|-MMD)$")
_NOT_FOR_SELFTEST_WITH_VALUE = ("-MF", "-MT", "-MQ")


def build_flags(job: Job) -> list[str]:
    """The build's flags the self-test compiles and links with: with --compile-commands, its first entry's
    (the ones headers are parsed with: -mcpu, -mfloat-abi, -D, -I...), then everything after `--`."""
    out: list[str] = []
    if job.opts.compile_commands:
        args = frontend.first_compile_args(job.opts.compile_commands)
        i = 0
        while i < len(args):
            if args[i] in _NOT_FOR_SELFTEST_WITH_VALUE:
                i += 2
                continue
            if not _NOT_FOR_SELFTEST.match(args[i]):
                out.append(args[i])
            i += 1
    return out + list(job.opts.extra_args)


def _cc_base(job: Job, tmp: str, cc: str) -> list[str]:
    # -O0: the self-test is large straight-line code; the optimisers would take most of the time. No
    # -Werror: warnings are judged by where they are (_own_warnings), so an input header's own warnings
    # do not fail the test, and the inputs' folders need not be system directories (a header named like
    # a system one, `common/time.h`, would then shadow <time.h>).
    cmd = [cc, f"-std={job.opts.std}", "-Wall", "-Wextra", "-O0", "-g0"]
    if job.opts.std.startswith("c"):
        cmd.append("-D_POSIX_C_SOURCE=200809L")
    if job.sanitize:
        cmd += ["-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer"]
    cmd += ["-I", str(RUNTIME_INCLUDE), "-I", tmp]
    for d in dict.fromkeys(job.opts.include_dirs):
        cmd += ["-I", d]
    return cmd + [f"-D{d}" for d in job.opts.defines] + build_flags(job)


_WARNING = re.compile(r"^(?P<file>[^:\n]+):\d+(?::\d+)?: (?:warning|error): .*$", re.M)


def _own_warnings(stderr: str, tmp: str) -> list[str]:
    """Warnings in the generated files or the runtime (what -Werror would judge), not in the inputs."""
    ours = (os.path.realpath(tmp), os.path.realpath(RUNTIME_INCLUDE), os.path.realpath(RUNTIME_SOURCE_DIR))
    return [m.group(0) for m in _WARNING.finditer(stderr)
            if os.path.realpath(m.group("file")).startswith(ours)]


def _run_c(job: Job, tmp: str, sources: list[str], plan: RunPlan, deadline: float,
           pool: ThreadPoolExecutor, n_types: int) -> str | None:
    base = _cc_base(job, tmp, plan.cc)
    units = [os.path.join(tmp, s) for s in sources] + [str(RUNTIME_CATALOGUE_C)]
    objects = [os.path.join(tmp, f"{k}_{Path(u).stem}.o") for k, u in enumerate(units)]
    builds = [pool.submit(_tool, base + ["-c", u, "-o", o], deadline, f"C build of {Path(u).name}")
              for u, o in zip(units, objects)]
    for unit, future in zip(units, builds):
        proc = future.result()
        own = _own_warnings(proc.stderr, tmp)
        if proc.returncode != 0 or own:
            first = next((line for line in proc.stderr.splitlines() if ": error:" in line),
                         own[0] if own else "see below")
            _say(f"selftest: error: C build failed: {Path(unit).name}: {first.strip()}; check that the inputs "
                 "compile with these flags (pass theirs with -I/-D, after `--`, or --compile-commands)\n"
                 f"{' '.join(base + ['-c', unit])}\n{_tail(proc.stderr)}")
            return None
    exe = os.path.join(tmp, f"{job.name}_selftest")
    # The build's own flags reach the link too (-m32, -mcpu/-mfloat-abi pick the libraries).
    link_cmd = [plan.cc, *(a for a in base if a.startswith("-fsanitize")), *objects, *build_flags(job)]
    if plan.shim:
        link_cmd += ["--specs=nosys.specs", "-nostartfiles"]
    link = _tool(link_cmd + ["-o", exe], deadline, "C link")
    if link.returncode != 0:
        _say(f"selftest: error: linking the C self-test failed:\n{' '.join(link_cmd)}\n{_tail(link.stderr)}")
        return None
    if plan.skip:
        _say(f"selftest: note: the C self-test was built for {plan.triple} with {plan.cc} (every layout assertion "
             f"held) but not run: {plan.skip}")
        return f"selftest: C {n_types} types built ({plan.triple}), run skipped: {plan.skip}"
    return _last_line("C", _tool([*plan.runner, exe], deadline, "C self-test run"))


def _run_py(job: Job, tmp: str, deadline: float) -> str | None:
    proc = _tool([sys.executable, os.path.join(tmp, f"{job.name}_selftest.py")], deadline, "Python self-test")
    return _last_line("Python", proc)


def _tool(cmd: list[str], deadline: float, what: str) -> subprocess.CompletedProcess[str]:
    left = deadline - time.monotonic()
    if left <= 0:
        raise SelftestError(f"{what}: no time left within --timeout; rerun with a larger --timeout")
    try:
        return subprocess.run(cmd, capture_output=True, text=True, timeout=left, check=False)
    except subprocess.TimeoutExpired:
        raise SelftestError(f"{what} did not finish within --timeout (the limit of this run); rerun with a "
                            "larger --timeout S or more --jobs, or split the catalogue") from None
    except OSError as exc:
        raise SelftestError(f"{what}: cannot run {cmd[0]} ({exc.strerror}); install gcc (`apt-get install gcc`)") from None


def _tail(text: str, lines: int = 40) -> str:
    rows = text.rstrip().splitlines()
    return "\n".join(rows[:lines] + ([f"... ({len(rows) - lines} more lines)"] if len(rows) > lines else []))


def _last_line(lang: str, proc: subprocess.CompletedProcess[str]) -> str | None:
    lines = proc.stdout.strip().splitlines()
    if proc.returncode != 0 or not lines:
        _say(f"selftest: {lang} check failed (exit {proc.returncode}):\n{_tail(proc.stdout + proc.stderr)}")
        return None
    return lines[-1]
