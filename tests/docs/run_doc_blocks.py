#!/usr/bin/env python3
"""Runs every shell and Python block of Markdown documents, verbatim, in document order.

    run_doc_blocks.py [--lo-up] [--keep] DOC.md...

Each document gets its own working directory that looks like a checkout after `make demo`: links to the
repository's files and folders (`.venv`, `build`, `examples`, `runtime_c`, ...), so a block writes only
into that directory (gen/, my_fsw/, logs). Its blocks run in two long-lived sessions, like a reader at a
terminal: one bash for the ```sh / ```bash blocks (so `cmd &` started in one block is `%1` in a later
one), one Python interpreter for the ```python blocks (so later blocks see earlier names). A shell block
fails at its first failing command (errexit); a Python block fails on any exception or a non-zero
SystemExit. After the last block, every background job the blocks started is stopped.

A block preceded by `<!-- doc-test: skip (reason) -->` is not run (the reason is printed).

The blocks use fixed ports (e.g. 127.0.0.1:5001), as a reader would. tests/docs/test_doc_blocks.py runs
this script inside a private network namespace (`unshare -rn`), where those ports cannot collide with
anything else on the machine; --lo-up brings that namespace's loopback interface up.

Exit status 0 when every block ran; 1 with the failing block, its output and its line otherwise.
"""

from __future__ import annotations

import argparse
import fcntl
import os
import re
import select
import shutil
import socket
import struct
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
FENCE = re.compile(r"^```([A-Za-z0-9_+-]*)\s*$")
SKIP = re.compile(r"<!--\s*doc-test:\s*skip\b(.*?)-->")
SHELLS = {"sh", "bash", "shell", "console"}
PYTHONS = {"python", "py", "python3"}
END = "__DOC_BLOCK_END__"
BLOCK_TIMEOUT_S = 300
# What a reader's checkout holds after `make demo`; the working directory links to these.
LINKED = (".venv", "build", "examples", "runtime_c", "runtime_py", "generator", "templates", "schemas", "cmake",
          "docs", "tests", "bench", "fuzz", "CMakeLists.txt", "Makefile", "pyproject.toml", "setup.py", "README.md",
          "LICENSE")


@dataclass
class Block:
    doc: Path
    line: int
    lang: str
    text: str
    skip: str | None


def blocks_of(doc: Path) -> list[Block]:
    out: list[Block] = []
    lines = doc.read_text(encoding="utf-8").splitlines()
    i = 0
    previous = ""
    while i < len(lines):
        m = FENCE.match(lines[i])
        if m is None:
            if lines[i].strip():
                previous = lines[i]
            i += 1
            continue
        lang, start = m.group(1).lower(), i + 1
        j = start
        while j < len(lines) and not lines[j].startswith("```"):
            j += 1
        skip = SKIP.search(previous)
        if lang in SHELLS | PYTHONS:
            out.append(Block(doc, start, "sh" if lang in SHELLS else "python", "\n".join(lines[start:j]) + "\n",
                             skip.group(1).strip(" ()") if skip else None))
        previous = ""
        i = j + 1
    return out


def loopback_up() -> None:
    """`ip link set lo up`, without iproute2: SIOCGIFFLAGS / SIOCSIFFLAGS on a socket."""
    siocgifflags, siocsifflags, iff_up = 0x8913, 0x8914, 0x1
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        ifr = struct.pack("16sH14s", b"lo", 0, bytes(14))
        flags = struct.unpack("16sH", fcntl.ioctl(s, siocgifflags, ifr)[:18])[1]
        fcntl.ioctl(s, siocsifflags, struct.pack("16sH14s", b"lo", flags | iff_up, bytes(14)))


def workdir_for(doc: Path, root: Path) -> Path:
    wd = root / doc.stem
    wd.mkdir(parents=True)
    for name in LINKED:
        if (REPO / name).exists():
            (wd / name).symlink_to(REPO / name)
    return wd


PY_DRIVER = r'''
import sys, traceback
namespace = {"__name__": "__main__"}
while True:
    header = sys.stdin.readline()
    if not header:
        break
    source = sys.stdin.read(int(header))
    status = "ok"
    try:
        exec(compile(source, sys.argv[1] + ":" + sys.argv[2], "exec"), namespace)
    except SystemExit as exc:
        if exc.code not in (None, 0):
            print(f"SystemExit: {exc.code}", flush=True)
            status = "fail"
    except BaseException:
        traceback.print_exc(file=sys.stdout)
        status = "fail"
    sys.stdout.flush()
    sys.stderr.flush()
    print(f"\n__DOC_BLOCK_END__ {status}", flush=True)
'''


class Session:
    """A long-lived interpreter whose combined output is read up to the end marker of each block."""

    def __init__(self, argv: list[str], cwd: Path, env: dict[str, str]) -> None:
        self.proc = subprocess.Popen(argv, cwd=cwd, env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.STDOUT, start_new_session=True)
        self.buffer = b""

    def read_until_end(self, timeout: float) -> tuple[str, str]:
        assert self.proc.stdout is not None
        fd = self.proc.stdout.fileno()
        deadline = time.monotonic() + timeout
        while True:
            m = re.search(rb"\n?" + END.encode() + rb" (\w+)\n", self.buffer)
            if m is not None:
                text, self.buffer = self.buffer[:m.start()], self.buffer[m.end():]
                return text.decode("utf-8", "replace"), m.group(1).decode()
            left = deadline - time.monotonic()
            if left <= 0:
                return self.buffer.decode("utf-8", "replace"), "timeout"
            ready, _, _ = select.select([fd], [], [], min(left, 1.0))
            if ready:
                chunk = os.read(fd, 65536)
                if not chunk:
                    return self.buffer.decode("utf-8", "replace"), "exited"
                self.buffer += chunk

    def send(self, data: bytes) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(data)
        self.proc.stdin.flush()

    def close(self) -> None:
        try:
            if self.proc.stdin is not None:
                self.proc.stdin.close()
            self.proc.wait(timeout=10)
        except (OSError, subprocess.TimeoutExpired):
            pass
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, 9)
            self.proc.wait()


def run_doc(doc: Path, root: Path) -> bool:
    wd = workdir_for(doc, root)
    env = dict(os.environ)
    env.pop("UAVBUS_CATALOGUE", None)
    python = str(REPO / ".venv" / "bin" / "python")
    bash = Session(["bash", "--noprofile", "--norc"], wd, env)
    py = Session([python, "-u", "-c", PY_DRIVER, str(doc.relative_to(REPO)), "0"], wd, env)
    ok = True
    try:
        bash.send(b"exec 2>&1\n")
        for n, block in enumerate(blocks_of(doc), 1):
            where = f"{doc.relative_to(REPO)}:{block.line}"
            if block.skip is not None:
                print(f"-- {where}: {block.lang} block skipped ({block.skip})")
                continue
            print(f"-- {where}: {block.lang} block {n}", flush=True)
            if block.lang == "sh":
                script = wd / f".doc-block-{n}.sh"
                script.write_text(block.text)
                bash.send(f"set -e\nsource {script.name}\nset +e\necho; echo {END} ok\n".encode())
                output, status = bash.read_until_end(BLOCK_TIMEOUT_S)
            else:
                source = block.text.encode()
                py.send(f"{len(block.text)}\n".encode() + source)
                output, status = py.read_until_end(BLOCK_TIMEOUT_S)
            sys.stdout.write("".join(f"   | {line}\n" for line in output.strip("\n").splitlines()))
            if status != "ok":
                print(f"FAILED: {where}: the {block.lang} block {'timed out' if status == 'timeout' else 'failed'}"
                      f"{' (the shell exited at a failing command)' if status == 'exited' else ''}:\n{block.text}")
                ok = False
                break
    finally:
        # Stop what the blocks left running (e.g. a vehicle started with `&`), then the sessions.
        if bash.proc.poll() is None:
            bash.send(b"kill $(jobs -p) 2>/dev/null; wait 2>/dev/null; exit 0\n")
        bash.close()
        py.close()
    return ok


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("docs", nargs="+", type=Path)
    ap.add_argument("--lo-up", action="store_true", help="bring the loopback interface up (in a new netns)")
    ap.add_argument("--keep", action="store_true", help="keep the working directories (their path is printed)")
    args = ap.parse_args(argv)
    if args.lo_up:
        loopback_up()
    root = Path(tempfile.mkdtemp(prefix="uavbus-doc-blocks-"))
    try:
        results = {doc: run_doc(doc.resolve(), root) for doc in args.docs}
    finally:
        if args.keep:
            print(f"working directories kept in {root}")
        else:
            shutil.rmtree(root, ignore_errors=True)
    for doc, ok in results.items():
        print(f"{'ok    ' if ok else 'FAILED'} {doc}")
    return 0 if all(results.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
