#!/usr/bin/env python3
"""Coverage-guided fuzzing (atheris, libFuzzer) of the Python log tools: uavbus.logfile and `uavbus log info`.

fuzz_cli.py mutates inputs blindly; this harness lets libFuzzer keep what reaches new Python lines and
branches of uavbus.logfile, the log command (uavbus.tools.logcmd), the command line's error handling and
the catalogue code a log's header feeds. Each input is the bytes of a log file. For each one:

  - LogReader reads every record and decodes the header's catalogue: only LogFormatError (the file is
    not a log) or CatalogueError (its embedded catalogue is bad) may come out;
  - follow() reads the same file while it grows in pieces (cut where the input says), as `--follow` does:
    its records must be a prefix of LogReader's (follow waits for a partial tail, LogReader skips it);
  - `uavbus log info FILE` (uavbus.cli.main, in this process) must end with a documented exit status and
    no traceback (docs/tools.md; the same oracle as fuzz_cli.py).

Seeds are made here: a log recorded by the C writer (fuzz_cli.record_seed_log), copies damaged past their
checksums (fuzz_cli.deep_mutate_log), a cut one. A custom mutator reseals the header and record checksums
of half the inputs libFuzzer makes, so damage inside records reaches the frame and catalogue decoders.

    python fuzz/python/fuzz_logtools_atheris.py --seconds 60      # fuzz/run.sh interface
    python fuzz/python/fuzz_logtools_atheris.py --seconds 5 --corpus DIR
    python fuzz/python/fuzz_logtools_atheris.py --replay ARTIFACT           # a finding, run once

The run happens in a child process (libFuzzer ends the process when the time is up); this process
prints the summary line. A finding (an oracle failure, which atheris reports as an uncaught exception
with the input saved as a crash artifact) makes the run exit 1. Without atheris it says so and exits 2.
"""

from __future__ import annotations

import argparse
import os
import random
import re
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
NAME = "fuzz_logtools_atheris"
sys.path.insert(0, str(HERE))  # fuzz_cli: the seed log, its mutations and the command-line oracle


# ---------------------------------------------------------------- the fuzzed process

def reseal(data: bytes) -> bytes:
    """The header's checks and every record's recomputed, so damage gets past them (docs/log-format.md,
    format 3: the primary copy's crc at 16 and head_crc at 20, the spare made its copy again; a record's
    head_crc over record[0:20] at 20, the frame's crc continued from it at 24)."""
    from uavbus._bindings.ub_frame import ub_crc32c, ub_crc32c_update
    from uavbus.logfile import FILE_HEADER, MAGIC, RECORD_HEAD_SPAN, RECORD_HEADER_LEN

    if len(data) < FILE_HEADER.size or data[:len(MAGIC)] != MAGIC:
        return data
    _, meta_len, cat_len, _, _ = FILE_HEADER.unpack_from(data, 0)
    copy = FILE_HEADER.size + meta_len + cat_len
    end = 2 * copy
    if end > len(data):
        return data
    b = bytearray(data)
    struct.pack_into("<I", b, 16, ub_crc32c(bytes(b[FILE_HEADER.size:copy])))
    struct.pack_into("<I", b, 20, ub_crc32c(bytes(b[:20])))
    b[copy:end] = b[:copy]
    pos = end
    while pos + RECORD_HEADER_LEN <= len(b):
        frame_len = struct.unpack_from("<H", b, pos + 2)[0]
        f_end = pos + RECORD_HEADER_LEN + frame_len
        if f_end > len(b):
            break
        head = ub_crc32c(bytes(b[pos:pos + RECORD_HEAD_SPAN]))
        struct.pack_into("<II", b, pos + RECORD_HEAD_SPAN, head,
                         ub_crc32c_update(head, bytes(b[pos + RECORD_HEADER_LEN:f_end])))
        pos = f_end
    return bytes(b)


def fuzz_child(libfuzzer_argv: list[str], workdir: Path, counter: Path) -> None:
    import atheris

    with atheris.instrument_imports(include=["uavbus"]):
        from uavbus import cli, logfile  # noqa: F401 - cli: instrumented for run_one
        from uavbus.errors import CatalogueError, LogFormatError
        from uavbus.tools import logcmd  # noqa: F401 - imported here so cli.main's lazy import is instrumented
    from fuzz_cli import DOCUMENTED, run_one

    path = workdir / "input.ublog"
    fd = os.open(counter, os.O_WRONLY | os.O_CREAT, 0o644)
    runs = [0]

    def key(rec: logfile.LogRecord) -> tuple[int, int | None, bytes]:
        return rec.offset, rec.seq, bytes(rec.frame)

    def test_one_input(data: bytes) -> None:
        runs[0] += 1
        os.pwrite(fd, struct.pack("<Q", runs[0]), 0)  # the parent reads it: libFuzzer's exit skips Python
        path.write_bytes(data)
        try:
            log = logfile.LogReader(path)
        except LogFormatError:
            whole = None
        else:
            whole = [key(r) for r in log.records()]
            assert log.ignored_bytes >= 0
            try:
                log.catalogue()
            except CatalogueError:
                pass

        # follow(): the same bytes appended in pieces whenever it would wait; it stops once all are there.
        cuts = sorted({c % (len(data) + 1) for c in data[:4]})
        pieces = [data[a:b] for a, b in zip([0, *cuts], [*cuts, len(data)])]
        path.write_bytes(b"")

        def grow(_s: float) -> None:
            with open(path, "ab") as f:
                f.write(pieces.pop(0))

        try:
            followed = [key(r) for r in logfile.follow(path, stop=lambda: not pieces, sleep=grow, rotation=False)]
        except LogFormatError:
            followed = None
        if whole is None:
            assert followed is None or not followed, "follow() read records from a file LogReader refuses"
        else:
            assert followed is not None, "follow() refused a file LogReader reads"
            assert whole[:len(followed)] == followed, \
                f"follow() records are not a prefix of LogReader's: {len(followed)} vs {len(whole)}"

        code, _, err, escaped = run_one(["log", "info", str(path)])
        if escaped:
            raise AssertionError("an exception escaped uavbus.cli.main:\n" + escaped)
        if code not in DOCUMENTED:
            raise AssertionError(f"uavbus log info: exit status {code} (documented: {sorted(DOCUMENTED)}): {err}")
        if "Traceback (most recent call last)" in err:
            raise AssertionError("uavbus log info: a traceback on stderr:\n" + err)

    def mutator(data: bytes, max_size: int, seed: int) -> bytes:
        out = atheris.Mutate(data, max_size)
        return reseal(out) if seed & 1 else out

    atheris.Setup([sys.argv[0], *libfuzzer_argv], test_one_input, custom_mutator=mutator)
    atheris.Fuzz()


# ---------------------------------------------------------------- the driver (fuzz/run.sh interface)

def make_seeds(seed_dir: Path) -> None:
    from fuzz_cli import deep_mutate_log, record_seed_log

    log = seed_dir / "recorded.ublog"
    record_seed_log(log)
    data = log.read_bytes()
    (seed_dir / "cut.ublog").write_bytes(data[: len(data) * 2 // 3])
    rng = random.Random(2005)
    for k in range(6):
        (seed_dir / f"deep{k}.ublog").write_bytes(deep_mutate_log(rng, data))


def last(pattern: str, text: str) -> str:
    found = re.findall(pattern, text)
    return found[-1] if found else "?"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=60.0, help="libFuzzer's -max_total_time (default 60)")
    ap.add_argument("--corpus", type=Path, default=None, help="working corpus, kept between runs (default: "
                    "$UAVBUS_FUZZ_OUT/corpus/" + NAME + " under fuzz/run.sh, else a temporary directory)")
    ap.add_argument("--seed", type=int, default=0, help="libFuzzer's -seed (0: from the clock)")
    ap.add_argument("--replay", nargs="+", type=Path, default=None, metavar="FILE",
                    help="run these inputs once each (a finding's artifact) instead of fuzzing")
    ap.add_argument("--child", nargs=argparse.REMAINDER, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child is not None:
        workdir, counter, *lf = args.child
        fuzz_child(lf, Path(workdir), Path(counter))
        return 0
    try:
        import atheris  # noqa: F401
    except ImportError:
        print(f"{NAME}: atheris is not installed in {sys.executable}: `make test-fuzz` installs it "
              "(pip install atheris, the `fuzz` extra in pyproject.toml)")
        return 2
    out = os.environ.get("UAVBUS_FUZZ_OUT")
    with tempfile.TemporaryDirectory(prefix="uavbus-atheris-") as tmp:
        tmpd = Path(tmp)
        corpus = args.corpus or (Path(out) / "corpus" / NAME if out else tmpd / "corpus")
        artifacts = Path(out) / "artifacts" if out else Path(tempfile.mkdtemp(prefix="uavbus-atheris-findings-"))
        seeds = tmpd / "seeds"
        for d in (corpus, artifacts, seeds):
            d.mkdir(parents=True, exist_ok=True)
        make_seeds(seeds)
        counter = tmpd / "runs"
        lf = [f"-max_total_time={max(1, round(args.seconds))}", "-print_final_stats=1", "-timeout=20",
              "-rss_limit_mb=2048", f"-seed={args.seed}", f"-artifact_prefix={artifacts}/{NAME}-",
              str(corpus), str(seeds)]
        if args.replay:  # libFuzzer runs file arguments once each
            lf = ["-print_final_stats=1", *(str(f.resolve()) for f in args.replay)]
        started = time.monotonic()
        child = subprocess.run([sys.executable, __file__, "--child", str(tmpd), str(counter), *lf],
                               capture_output=True, text=True, env={**os.environ, "UAVBUS_DEBUG": ""})
        took = time.monotonic() - started
        log = child.stdout + child.stderr
        runs = struct.unpack("<Q", counter.read_bytes())[0] if counter.exists() and counter.stat().st_size else 0
        findings = 0 if child.returncode == 0 else 1
        if findings:
            print(log[-6000:], file=sys.stderr)
            print(f"{NAME}: FINDING (libFuzzer exit {child.returncode}); the input is under {artifacts}/{NAME}-*",
                  file=sys.stderr)
        cov, ft, corp = last(r" cov: (\d+)", log), last(r" ft: (\d+)", log), last(r" corp: (\S+)", log)
        print(f"{NAME}: {runs} runs in {took:.1f} s (libFuzzer: cov {cov}, ft {ft}, corpus {corp}); "
              f"{findings} finding(s)", flush=True)
        return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main())
