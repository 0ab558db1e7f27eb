"""`uavbus gen | check | selftest`: the only place that reads arguments, writes files or runs tools.

Exit codes: 0 success; 1 the catalogue is not unique (ID collisions, duplicate definitions);
2 parse or usage errors (clang errors are printed as `file:line: message`).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from uavbus._paths import RUNTIME_INCLUDE_DIR as RUNTIME_INCLUDE, RUNTIME_SOURCE_DIR  # package data

from . import frontend, model, render
from .catalogue_json import catalogue_json

RUNTIME_CATALOGUE_C = RUNTIME_SOURCE_DIR / "ub_catalogue.c"
SELFTEST_TIMEOUT_S = 300


class UsageError(Exception):
    pass


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="uavbus",
        description="C headers -> checked directory catalogue -> C and Python codecs.",
        epilog="Arguments after `--` go to clang unchanged (and to gcc in selftest), e.g. `-- -include prelude.h`.",
    )
    p.add_argument("command", choices=("gen", "check", "selftest"))
    p.add_argument("files", nargs="+", metavar="FILE", help="headers or .c files; each is its own translation unit")
    p.add_argument("-I", dest="include_dirs", action="append", default=[], metavar="DIR",
                   help="add DIR to the include path (as for the C compiler; repeatable)")
    p.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME[=VAL]",
                   help="define a macro for parsing, as the flight software is compiled (repeatable)")
    p.add_argument("--std", default="c11", help="C standard for clang (and gcc in selftest); default c11")
    p.add_argument("--name", default="catalogue", help="output base name and C/Python prefix; default 'catalogue'")
    p.add_argument("--id-scheme", choices=model.ids.ID_SCHEMES, default="paper",
                   help="content IDs: the paper's first-8+last-8 rule (default) or 'hashed' (7+7+CRC-16)")
    p.add_argument("--compile-commands", metavar="F", help="take each input's flags from this compile_commands.json")
    p.add_argument("-o", dest="outdir", metavar="OUTDIR", help="output directory (gen)")
    p.add_argument("--sanitize", action="store_true", help="selftest: build the C program with ASan/UBSan")
    p.add_argument("-v", "--verbose", action="store_true", help="print timings and skipped instances")
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
    opts = frontend.ParseOptions(tuple(ns.include_dirs), tuple(ns.defines), ns.std, tuple(clang_args), ns.compile_commands)
    return Job(ns.command, tuple(ns.files), opts, ns.name, ns.id_scheme, ns.outdir, ns.sanitize, ns.verbose)


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        return run(parse_args(argv))
    except UsageError as exc:
        return _fail(f"uavbus: error: {exc}", 2)
    except frontend.FrontendError as exc:
        return _fail(str(exc), 2)
    except model.ModelError as exc:
        return _fail(str(exc), exc.exit_code)
    except ValueError as exc:  # a model constructor refused the input
        return _fail(f"error: {exc}", 2)


def _fail(message: str, code: int) -> int:
    sys.stdout.flush()  # keep stdout and stderr in order when both go to one log
    print(message, file=sys.stderr)
    return code


def load(job: Job) -> model.Catalogue:
    units = frontend.parse_files(job.files, job.opts)
    cat = model.build_catalogue(units, job.id_scheme, model.make_relpath(list(job.files)))
    for skipped in cat.skipped_instances if job.verbose else ():
        print(f"{skipped.loc}: note: instance '{skipped.name}' not catalogued: {skipped.reason}", file=sys.stderr)
    return cat


def includes_for(job: Job) -> tuple[str, ...]:
    """How NAME.h includes each input header: relative to the first -I directory holding it, else by
    its file name (compile with -I of its directory). `.c` inputs are not included."""
    out = []
    for f in job.files:
        if f.endswith(".c"):
            continue
        absf = os.path.abspath(f)
        spelled = os.path.basename(f)
        for d in job.opts.include_dirs:
            absd = os.path.abspath(d)
            if os.path.commonpath([absd, absf]) == absd:
                spelled = os.path.relpath(absf, absd).replace(os.sep, "/")
                break
        if spelled not in out:
            out.append(spelled)
    return tuple(out)


def generate(job: Job, cat: model.Catalogue, with_selftest: bool = False) -> dict[str, str]:
    includes = includes_for(job)
    if f"{job.name}.h" in {os.path.basename(i) for i in includes}:
        raise UsageError(f"--name {job.name} would make {job.name}.h include itself instead of the input "
                         f"header of that name; choose another --name")
    renderer = render.Renderer(cat, render.RenderInputs(job.name, includes, catalogue_json(cat, job.name, compact=True)))
    files = renderer.render()
    files[f"{job.name}.catalogue.json"] = catalogue_json(cat, job.name)
    if with_selftest:
        files.update(renderer.render_selftest())
    return files


def write_files(outdir: str, files: dict[str, str]) -> None:
    os.makedirs(outdir, exist_ok=True)
    for rel, text in sorted(files.items()):
        with open(os.path.join(outdir, rel), "w", encoding="utf-8", newline="\n") as fh:
            fh.write(text)


def run(job: Job) -> int:
    started = time.perf_counter()
    cat = load(job)
    if job.command == "check":
        print(f"check: {len(cat.instances)} instances of {len(cat.named_types)} types, IDs unique ({job.id_scheme} rule)")
        _timing(job, "check", started)
        return 0
    if job.command == "gen":
        files = generate(job, cat)
        _timing(job, "generation", started)
        write_files(job.outdir or ".", files)
        print(f"gen: {len(cat.instances)} instances of {len(cat.named_types)} types -> "
              + ", ".join(os.path.join(job.outdir or ".", f) for f in sorted(files)))
        return 0
    return selftest(job, cat, started)


def _timing(job: Job, what: str, started: float) -> None:
    if job.verbose:
        sys.stdout.flush()
        print(f"{what} time: {time.perf_counter() - started:.3f} s", file=sys.stderr)


# ---------------------------------------------------------------------------------------------
# selftest


def selftest(job: Job, cat: model.Catalogue, started: float) -> int:
    files = generate(job, cat, with_selftest=True)
    _timing(job, "generation", started)
    expected = f"{model.expected_digest(cat):08x}"
    n = len(cat.named_types)
    with tempfile.TemporaryDirectory(prefix="uavbus-selftest-") as tmp:
        write_files(tmp, files)
        c_line = _run_c(job, tmp)
        py_line = _run_py(job, tmp)
    print(c_line or "selftest: C failed")
    print(py_line or "selftest: Python failed")
    want = [f"selftest: C {n} types ok, digest {expected}", f"selftest: Python {n} types ok, digest {expected}"]
    ok = [c_line, py_line] == want
    if not ok:
        print(f"selftest: FAILED (expected digest {expected} from the model's own encoder)", file=sys.stderr)
    _timing(job, "selftest", started)
    return 0 if ok else 1


def _run_c(job: Job, tmp: str) -> str | None:
    exe = os.path.join(tmp, f"{job.name}_selftest")
    # -O1 lets gcc's flow-based warnings run; sanitized builds use -O0, which compiles the large
    # generated self-test several times faster and keeps every check in place.
    cmd = ["gcc", f"-std={job.opts.std}", "-Wall", "-Wextra", "-Werror", "-O0" if job.sanitize else "-O1", "-g"]
    if job.opts.std.startswith("c"):
        cmd.append("-D_POSIX_C_SOURCE=200809L")
    if job.sanitize:
        cmd += ["-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer"]
    cmd += ["-I", str(RUNTIME_INCLUDE), "-I", tmp]
    # The inputs' own directories are system directories here: -Werror judges the generated code,
    # not warnings inside headers we were merely given (MAVLink's, for one).
    for d in [*job.opts.include_dirs, *(os.path.dirname(os.path.abspath(f)) for f in job.files)]:
        cmd += ["-isystem", d]
    cmd += [f"-D{d}" for d in job.opts.defines] + list(job.opts.extra_args)
    cmd += [os.path.join(tmp, f"{job.name}.c"), os.path.join(tmp, f"{job.name}_selftest.c"), str(RUNTIME_CATALOGUE_C)]
    cmd += ["-o", exe]
    build = subprocess.run(cmd, capture_output=True, text=True, timeout=SELFTEST_TIMEOUT_S, check=False)
    if build.returncode != 0:
        print(f"selftest: C build failed:\n{' '.join(cmd)}\n{build.stderr}", file=sys.stderr)
        return None
    return _last_line("C", [exe])


def _run_py(job: Job, tmp: str) -> str | None:
    return _last_line("Python", [sys.executable, os.path.join(tmp, f"{job.name}_selftest.py")])


def _last_line(lang: str, cmd: list[str]) -> str | None:
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=SELFTEST_TIMEOUT_S, check=False)
    lines = proc.stdout.strip().splitlines()
    if proc.returncode != 0 or not lines:
        print(f"selftest: {lang} check failed (exit {proc.returncode}):\n{proc.stdout}{proc.stderr}", file=sys.stderr)
        return None
    return lines[-1]
