"""`uavbus gen | check | selftest`: the only place that reads arguments, writes files or runs tools.

Exit codes: 0 success; 1 the inputs parse but the catalogue cannot be used as is (ID collisions,
one name defined two ways, a type over the payload limit); 2 parse or usage errors, nothing
written (clang errors are printed as `file:line: message`, with their `#include` chain);
3 `--keep-going` wrote a catalogue without the inputs or instances it lists (`--exit-zero`: 0).
"""

from __future__ import annotations

import argparse
import fnmatch
import os
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
    p.add_argument("--compile-commands", metavar="F", help="take each input's flags from this compile_commands.json")
    p.add_argument("--exclude", action="append", default=[], metavar="GLOB",
                   help="leave out inputs matching GLOB (a pattern with '/' matches the path, else the file name)")
    p.add_argument("-k", "--keep-going", action="store_true",
                   help="catalogue the inputs that parse and list the others; exit 3 when some were left out")
    p.add_argument("--exit-zero", action="store_true", help="with --keep-going: exit 0 even when inputs were left out")
    p.add_argument("--max-payload", type=int, default=model.DEFAULT_MAX_PAYLOAD, metavar="BYTES",
                   help=f"largest packed type a node carries: the runtime's UB_MAX_DIRECTORY (default {model.DEFAULT_MAX_PAYLOAD})")
    p.add_argument("--strings", choices=(model.STRINGS_SKIP, model.STRINGS_BYTES), default=model.STRINGS_SKIP,
                   help="char arrays: skip them (the paper's rule, default) or send their bytes")
    p.add_argument("--string-field", action="append", default=[], metavar="TYPE.MEMBER",
                   help="send these char arrays as bytes (fnmatch pattern on '<type name>.<member>', repeatable)")
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
    opts = frontend.ParseOptions(tuple(ns.include_dirs), tuple(ns.defines), ns.std, tuple(clang_args), ns.compile_commands)
    build = model.BuildOptions(ns.id_scheme, ns.strings, tuple(ns.string_field), ns.max_payload, ns.keep_going)
    return Job(ns.command, tuple(ns.files), opts, ns.name, ns.id_scheme, ns.outdir, ns.sanitize, ns.verbose, build,
               tuple(ns.exclude), ns.keep_going, ns.exit_zero, ns.jobs, ns.timeout)


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
    --exclude applied (a pattern with '/' matches the path as given, else the file name)."""
    files: list[str] = []
    for f in job.files:
        if os.path.isdir(f):
            found = sorted(str(p) for p in Path(f).rglob("*") if p.suffix in (".h", ".c") and p.is_file())
            if not found:
                raise UsageError(f"{f}: directory holds no .h or .c file")
            files += found
        else:
            files.append(f)
    kept = []
    used: set[str] = set()
    for f in files:
        posix = os.path.normpath(f).replace(os.sep, "/")
        hit = [pat for pat in job.exclude
               if fnmatch.fnmatchcase(posix if "/" in pat else os.path.basename(posix), pat.rstrip("/"))]
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


@dataclass(frozen=True)
class Loaded:
    cat: model.Catalogue
    files: tuple[str, ...]
    failed: tuple[frontend.FeFailure, ...]

    @property
    def partial(self) -> bool:
        """Something the inputs hold is missing from the catalogue because of --keep-going."""
        return bool(self.failed) or any("payload limit" in s.reason for s in self.cat.skipped_instances)


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
    cat = model.build_catalogue(units, job.id_scheme, rel, job.build)
    for note in cat.notes:
        _say(str(note))
    _summarise(job, cat)
    return Loaded(cat, tuple(files), failed)


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


def generate(job: Job, cat: model.Catalogue, with_selftest: bool = False) -> dict[str, str]:
    if any(inc.strip('"<>').split("/")[-1] == f"{job.name}.h" for inc in cat.includes):
        raise UsageError(f"--name {job.name} would make {job.name}.h include itself instead of the input "
                         f"header of that name; choose another --name")
    renderer = render.Renderer(cat, render.RenderInputs(job.name, catalogue_json(cat, job.name, compact=True)))
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
    loaded = load(job)
    cat = loaded.cat
    done = EXIT_PARTIAL if loaded.partial and not job.exit_zero else 0
    if job.command == "check":
        print(f"check: {len(cat.instances)} instances of {len(cat.named_types)} types, IDs unique ({job.id_scheme} rule)"
              + (f"; {len(loaded.failed)} inputs left out" if loaded.failed else ""))
        _timing(job, "check", started)
        return done
    if job.command == "gen":
        files = generate(job, cat)
        _timing(job, "generation", started)
        write_files(job.outdir or ".", files)
        print(f"gen: {len(cat.instances)} instances of {len(cat.named_types)} types -> "
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
    files = generate(job, cat, with_selftest=True)
    _timing(job, "generation", started)
    expected = f"{model.expected_digest(cat):08x}"
    n = len(cat.named_types)
    deadline = time.monotonic() + job.timeout
    c_line = py_line = None
    with tempfile.TemporaryDirectory(prefix="uavbus-selftest-") as tmp:
        write_files(tmp, files)
        sources = sorted(f for f in files if f.endswith(".c"))
        with ThreadPoolExecutor(max_workers=max(1, job.jobs)) as pool:
            # Python runs beside the C compilers; each compiler gets its own worker.
            py_future = pool.submit(_run_py, job, tmp, deadline)
            try:
                c_line = _run_c(job, tmp, sources, loaded.files, deadline, pool)
            except SelftestError as exc:
                _say(f"selftest: error: {exc}")
            try:
                py_line = py_future.result()
            except SelftestError as exc:
                _say(f"selftest: error: {exc}")
    print(c_line or "selftest: C failed")
    print(py_line or "selftest: Python failed")
    want = [f"selftest: C {n} types ok, digest {expected}", f"selftest: Python {n} types ok, digest {expected}"]
    ok = [c_line, py_line] == want
    if not ok:
        _say(f"selftest: FAILED (expected digest {expected} from the model's own encoder)")
    _timing(job, "selftest", started)
    return 0 if ok else 1


def _gcc_base(job: Job, tmp: str, inputs: tuple[str, ...]) -> list[str]:
    # -O0: the self-test is large straight-line code; gcc's optimisers would take most of the time.
    cmd = ["gcc", f"-std={job.opts.std}", "-Wall", "-Wextra", "-Werror", "-O0", "-g0"]
    if job.opts.std.startswith("c"):
        cmd.append("-D_POSIX_C_SOURCE=200809L")
    if job.sanitize:
        cmd += ["-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer"]
    cmd += ["-I", str(RUNTIME_INCLUDE), "-I", tmp]
    # The inputs' own directories are system directories here: -Werror judges the generated code,
    # not warnings inside headers we were merely given (MAVLink's, for one).
    dirs = [*job.opts.include_dirs, *(os.path.dirname(os.path.abspath(f)) for f in inputs)]
    for d in dict.fromkeys(dirs):
        cmd += ["-isystem", d]
    return cmd + [f"-D{d}" for d in job.opts.defines] + list(job.opts.extra_args)


def _run_c(job: Job, tmp: str, sources: list[str], inputs: tuple[str, ...], deadline: float,
           pool: ThreadPoolExecutor) -> str | None:
    base = _gcc_base(job, tmp, inputs)
    units = [os.path.join(tmp, s) for s in sources] + [str(RUNTIME_CATALOGUE_C)]
    objects = [os.path.join(tmp, f"{k}_{Path(u).stem}.o") for k, u in enumerate(units)]
    builds = [pool.submit(_tool, base + ["-c", u, "-o", o], deadline, f"C build of {Path(u).name}")
              for u, o in zip(units, objects)]
    for unit, future in zip(units, builds):
        proc = future.result()
        if proc.returncode != 0:
            first = next((line for line in proc.stderr.splitlines() if ": error:" in line), "see below")
            _say(f"selftest: error: C build failed: {Path(unit).name}: {first.strip()}; check that the inputs "
                 "compile with these flags (pass theirs with -I/-D, after `--`, or --compile-commands)\n"
                 f"{' '.join(base + ['-c', unit])}\n{_tail(proc.stderr)}")
            return None
    exe = os.path.join(tmp, f"{job.name}_selftest")
    link = _tool(base[:1] + [a for a in base if a.startswith("-fsanitize")] + objects + ["-o", exe], deadline, "C link")
    if link.returncode != 0:
        _say(f"selftest: error: linking the C self-test failed:\n{_tail(link.stderr)}")
        return None
    return _last_line("C", _tool([exe], deadline, "C self-test run"))


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
