#!/usr/bin/env python3
"""Seeded mutation fuzzing of the `uavbus` command line and the log tools on damaged input.

Oracle (docs/tools.md): whatever the arguments and whatever the bytes of the files they name, a command
ends with a documented exit status (0, 1, 2, 3, 4, 141) and never prints a Python traceback; an
`internal error` (status 70) or an exception escaping `uavbus.cli.main` is a finding.

Inputs, all made here from the product itself (no files downloaded or checked in):
  - a log recorded by the C log writer through uavbus.Node (tests/fixtures/enums catalogue, so enum
    names and nested arrays are on the decode path), then damaged: byte flips, cuts, duplicated or
    dropped chunks, random insertions, and "deep" mutations that rewrite a record's frame or the header's
    catalogue/metadata and fix the CRCs so the damage gets past the checksums;
  - configuration files (examples/configs) and catalogue JSON, damaged the same way;
  - argument vectors drawn from the commands' own options, good and bad values mixed.

    python fuzz/python/fuzz_cli.py --iterations 300 --seed 1     # what `make test` runs (about 20 s)
    python fuzz/python/fuzz_cli.py --seconds 600                 # the longer run (`make fuzz`)

Every command runs in this process (uavbus.cli.main), so thousands of runs fit in minutes. A finding
prints the seed, the iteration, the argument vector and where its damaged input was saved, and the run
exits 1. Live sources are bounded (--duration), `log play` sends only to 127.0.0.1 (a closed port).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import random
import shutil
import struct
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[2]
ENUMCAT = REPO / "tests" / "fixtures" / "enums" / "enumcat.catalogue.json"
CONFIGS = [REPO / "examples" / "configs" / "table1.json", REPO / "examples" / "configs" / "table2.json"]
DOCUMENTED = {0, 1, 2, 3, 4, 141}


def record_seed_log(path: Path) -> None:
    """A real log: two nodes over a memlink, the receiver records with the C writer."""
    from uavbus import Catalogue, MemLink, Node

    cat = Catalogue.load(ENUMCAT)
    clock = [0]
    air, gcs = Node(cat, clock=lambda: clock[0]), Node(cat, clock=lambda: clock[0])
    for node, me, other, link in ((air, "uav1", "gcs1", "air0"), (gcs, "gcs1", "uav1", "gnd0")):
        node.add_entity(me, local=True)
        node.add_entity(other)
        node.add_link(me, 0, link)
        node.set_mask(me, other, 1)
    MemLink(air, "air0", gcs, "gnd0")
    gcs.bind("vehicleState")
    gcs.record(path, tx=True)
    d = air.bind("vehicleState")
    for k in range(40):
        d.tMs, d.mode = k, k % 6
        d.motors[k % 4].rpm = 1000.0 + k
        d.history[k % 3] = k % 5
        air.send("uav1", "vehicleState", to="gcs1")
        clock[0] += 20
        gcs.poll(0)
    gcs.stop_recording()
    air.close()
    gcs.close()


# ---------------------------------------------------------------- mutations

def mutate_bytes(rng: random.Random, data: bytes) -> bytes:
    b = bytearray(data)
    for _ in range(rng.randint(1, 6)):
        op = rng.randrange(7)
        if not b:
            b = bytearray(rng.randbytes(rng.randint(1, 64)))
        pos = rng.randrange(len(b))
        if op == 0:
            b[pos] ^= 1 << rng.randrange(8)
        elif op == 1:
            b[pos] = rng.choice((0, 0xFF, 0x7F, 0x80, rng.randrange(256)))
        elif op == 2:
            del b[pos:]  # a cut, as a crash leaves it
        elif op == 3:
            n = rng.randint(1, 64)
            b[pos:pos] = b[pos:pos + n]  # a duplicated chunk
        elif op == 4:
            del b[pos:pos + rng.randint(1, 64)]
        elif op == 5:
            b[pos:pos] = rng.randbytes(rng.randint(1, 32))
        else:
            n = min(len(b) - pos, rng.randint(1, 8))
            b[pos:pos + n] = rng.choice((b"\xff", b"\x00")) * n  # a length field at its extremes
    return bytes(b)


def deep_mutate_log(rng: random.Random, data: bytes) -> bytes:
    """Damage past the checksums: rewrite the header's JSON or one record's frame, then fix the CRCs.
    Uses the log format's constants from uavbus.logfile; if they change shape, falls back to bytes."""
    try:
        from uavbus._bindings.ub_frame import ub_crc32c, ub_crc32c_update
        from uavbus.logfile import FILE_HEADER, MAGIC, RECORD_HEAD_SPAN, RECORD_HEADER_LEN

        magic, meta_len, cat_len, _, _ = FILE_HEADER.unpack_from(data, 0)
        if magic != MAGIC:
            return mutate_bytes(rng, data)
        start = FILE_HEADER.size
        body = bytearray(data[start:start + meta_len + cat_len])
        rest = bytearray(data[2 * (start + meta_len + cat_len):])  # format 3: the header twice
        if rng.random() < 0.4:
            text = body.decode("utf-8", "replace")
            cuts = [("\"abi_version\":2", "\"abi_version\":99"), ("\"packed_size\":", "\"packed_size\":-"),
                    ("\"wire\":\"u32\"", "\"wire\":\"u33\""), ("\"enums\":", "\"enums\":[],\"x\":"),
                    ("\"id\":\"", "\"id\":\"zz"), ("\"MODE_AUTO\":3", "\"MODE_AUTO\":\"3\""),
                    ("\"links\":", "\"links\":7,\"y\":"), ("\"start_unix_ms\":", "\"start_unix_ms\":-1e400,\"z\":")]
            old, new = rng.choice(cuts)
            text = text.replace(old, new, 1) if old in text else text[: max(1, len(text) - rng.randint(1, 40))]
            new_body = text.encode()
            meta_len = min(meta_len, len(new_body))
            body = bytearray(new_body)
            cat_len = len(body) - meta_len
        elif rest:
            pos = 0
            offsets = []
            while pos + RECORD_HEADER_LEN <= len(rest):
                frame_len = struct.unpack_from("<H", rest, pos + 2)[0]
                offsets.append((pos, frame_len))
                pos += RECORD_HEADER_LEN + frame_len
            if offsets:
                pos, frame_len = rng.choice(offsets)
                f0 = pos + RECORD_HEADER_LEN
                frame = bytearray(rest[f0:f0 + frame_len])
                if frame:
                    frame[rng.randrange(len(frame))] ^= 1 << rng.randrange(8)
                rest[f0:f0 + frame_len] = frame
                # Format 2 (docs/log-format.md): head_crc over the record header, crc continued over the frame.
                head = ub_crc32c(bytes(rest[pos:pos + RECORD_HEAD_SPAN]))
                struct.pack_into("<II", rest, pos + RECORD_HEAD_SPAN, head, ub_crc32c_update(head, bytes(frame)))
        fixed = struct.pack("<8sIII", MAGIC, meta_len, cat_len, ub_crc32c(bytes(body)))
        copy = fixed + struct.pack("<I", ub_crc32c(fixed)) + bytes(body)
        return copy + copy + bytes(rest)
    except (ImportError, AttributeError, struct.error, ValueError):
        return mutate_bytes(rng, data)


def mutate_json(rng: random.Random, data: bytes) -> bytes:
    if rng.random() < 0.5:
        return mutate_bytes(rng, data)
    try:
        doc = json.loads(data)
    except ValueError:
        return mutate_bytes(rng, data)
    weird: list[Any] = [None, -1, 2 ** 70, 1.5, "", "x" * 300, [], {}, True, "0x2", ["nope"], {"a": 1}]

    def walk(node: Any, depth: int) -> Any:
        if isinstance(node, dict) and node:
            key = rng.choice(list(node))
            if rng.random() < 0.3 or depth > 6:
                node[key] = rng.choice(weird)
            elif rng.random() < 0.1:
                del node[key]
            else:
                node[key] = walk(node[key], depth + 1)
        elif isinstance(node, list) and node:
            k = rng.randrange(len(node))
            node[k] = rng.choice(weird) if rng.random() < 0.3 else walk(node[k], depth + 1)
        return node

    return json.dumps(walk(doc, 0)).encode()


# ---------------------------------------------------------------- argument vectors

class Inputs:
    def __init__(self, root: Path) -> None:
        self.root = root
        self.log = root / "seed.ublog"
        record_seed_log(self.log)
        self.log_bytes = self.log.read_bytes()
        self.catalogue = root / "enumcat.catalogue.json"
        shutil.copy(ENUMCAT, self.catalogue)
        self.damaged_log = root / "damaged.ublog"
        self.damaged_config = root / "damaged.json"
        self.damaged_catalogue = root / "damaged.catalogue.json"
        self.out = root / "out"


def random_argv(rng: random.Random, inp: Inputs) -> list[str]:
    log = str(inp.damaged_log)
    config = str(inp.damaged_config)
    junk = ["", "-", "--", "x" * 200, "\u00e9", "-1", "0", "1e9", "nan", "gpsOut,", ",", "a.b[", "[0]", "--help"]
    names = ["vehicleState", "gpsOut", "nope", rng.choice(junk)]
    fields = ["mode", "motors[2].rpm", "cells[1][2]", "history[-1]", "motors[9].rpm", "mode.x", rng.choice(junk)]
    kind = rng.randrange(10)
    if kind == 0:
        argv = ["log", "info", log]
    elif kind == 1:
        argv = ["log", "export", log, rng.choice(["--csv", "--jsonl"])]
        argv += rng.choice([[], ["--only", rng.choice(names)], ["--admin"], ["--numeric"],
                            ["-o", str(inp.out / "export.csv")]])
    elif kind == 2:
        argv = ["log", "play", log, "--into", rng.choice(["udp:peer=127.0.0.1:9", "udp:peer=127.0.0.1:0",
                                                          "tcp:connect=127.0.0.1:9", "serial:device=/dev/null",
                                                          "udp:host=1", rng.choice(junk)]), "--fast"]
        argv += rng.choice([[], ["--only", rng.choice(names)], ["--dir", rng.choice(["rx", "tx", "all", "up"])]])
    elif kind in (3, 4):
        tool = rng.choice(["spy", "echo", "hz", "bw"])
        argv = [tool] + ([rng.choice(names)] if tool in ("echo", "hz") or rng.random() < 0.3 else [])
        argv += ["--log", log]
        if tool == "echo" and rng.random() < 0.6:
            argv += ["--field", rng.choice(fields)]
        argv += rng.choice([[], ["--count", rng.choice(["1", "0", "-3", "x"])], ["--numeric"], ["--all"],
                            ["--window", rng.choice(["0", "-1", "1", "nan"])]])
    elif kind == 5:
        argv = ["tables", "--static", "--config", config, "--node", rng.choice(["gcs", "A", "nobody", ""])]
    elif kind == 6:
        # A live node from a damaged configuration and catalogue: bounded, no port unless given.
        argv = [rng.choice(["spy", "tables", "hz"]), *(["gpsOut"] if rng.random() < 0.3 else []),
                "--config", rng.choice([config, str(CONFIGS[1])]), "--node", rng.choice(["gcs", "primary", "x"]),
                "--catalogue", rng.choice([str(inp.damaged_catalogue), str(inp.catalogue)]), "--duration", "0.02"]
        argv += rng.choice([[], ["--port", "gcsPortDatalink1=" + rng.choice(["udp:bind=127.0.0.1:0",
                                                                              "udp:bind=nope", "tcp:x=1", "mem"])],
                            ["--subscribe", rng.choice(["vehicleState@uav1/100", "x@y/0", "junk"])]])
    elif kind == 7:
        argv = rng.choice([["--version"], ["bw", "--version"], ["frob"], [], ["log"], ["log", "frob", log],
                           ["echo"], ["hz", "--log"], ["spy", "--follow"], ["log", "info"], ["--help"],
                           ["log", "export", log], ["echo", "x", "--log", log, "--field"]])
    elif kind == 8:
        argv = ["log", rng.choice(["info", "export", "play"]), str(inp.damaged_catalogue)]
        argv += ["--csv"] if argv[1] == "export" else (["--into", "udp:peer=127.0.0.1:9"] if argv[1] == "play" else [])
    else:
        argv = [rng.choice(["spy", "echo", "hz", "bw", "log", "tables"])]
        argv += [rng.choice(junk + names + ["--log", log, "--config", config, "--field", "--only", "--count"])
                 for _ in range(rng.randint(0, 5))]
    return argv


def prepare_inputs(rng: random.Random, inp: Inputs) -> None:
    data = inp.log_bytes
    inp.damaged_log.write_bytes(data if rng.random() < 0.1 else
                                deep_mutate_log(rng, data) if rng.random() < 0.4 else mutate_bytes(rng, data))
    cfg = rng.choice(CONFIGS).read_bytes()
    inp.damaged_config.write_bytes(mutate_json(rng, cfg) if rng.random() < 0.9 else cfg)
    cat = inp.catalogue.read_bytes()
    inp.damaged_catalogue.write_bytes(mutate_json(rng, cat) if rng.random() < 0.9 else cat)


# ---------------------------------------------------------------- the loop

def run_one(argv: list[str]) -> tuple[int | None, str, str, str]:
    """Runs `uavbus ARGV` in this process: (status, stdout, stderr, escaped exception text)."""
    from uavbus import cli

    out, err = io.StringIO(), io.StringIO()
    escaped = ""
    code: int | None = None
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = cli.main(list(argv))
        except SystemExit as exc:  # main() returns its status; a SystemExit here escaped it
            escaped = f"SystemExit({exc.code!r}) escaped cli.main"
        except BaseException as exc:  # noqa: BLE001 - this is what the fuzzer looks for
            import traceback

            escaped = "".join(traceback.format_exception(exc))
    return code, out.getvalue(), err.getvalue(), escaped


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--iterations", type=int, default=None, help="stop after this many runs")
    ap.add_argument("--seconds", type=float, default=None, help="stop after this long (default: 60 s without "
                    "--iterations)")
    ap.add_argument("--findings", type=Path, default=None, help="where damaged inputs of findings are saved "
                    "(default: a temporary directory, printed)")
    ap.add_argument("-q", "--quiet", action="store_true")
    args = ap.parse_args(argv)
    if args.iterations is None and args.seconds is None:
        args.seconds = 60.0
    rng = random.Random(args.seed)
    started = time.monotonic()
    codes: dict[int, int] = {}
    findings = 0
    with tempfile.TemporaryDirectory(prefix="uavbus-fuzz-") as tmp:
        inp = Inputs(Path(tmp))
        inp.out.mkdir()
        i = 0
        while True:
            if args.iterations is not None and i >= args.iterations:
                break
            if args.seconds is not None and time.monotonic() - started >= args.seconds:
                break
            prepare_inputs(rng, inp)
            cmd = random_argv(rng, inp)
            code, _, err, escaped = run_one(cmd)
            problem = ""
            if escaped:
                problem = "an exception escaped uavbus.cli.main:\n" + escaped
            elif code not in DOCUMENTED:
                problem = f"exit status {code} (documented: {sorted(DOCUMENTED)})"
            elif "Traceback (most recent call last)" in err:
                problem = "a traceback on stderr"
            if problem:
                findings += 1
                where = Path(args.findings or tempfile.mkdtemp(prefix="uavbus-fuzz-finding-"))
                where.mkdir(parents=True, exist_ok=True)
                for f in (inp.damaged_log, inp.damaged_config, inp.damaged_catalogue):
                    shutil.copy(f, where / f"{i}-{f.name}")
                print(f"FINDING seed={args.seed} iteration={i}: uavbus {' '.join(cmd)}\n  {problem.strip()}\n"
                      f"  stderr: {err.strip()[:2000]}\n  inputs saved in {where} (prefix {i}-)", file=sys.stderr)
            codes[code if code is not None else -1] = codes.get(code if code is not None else -1, 0) + 1
            i += 1
    took = time.monotonic() - started
    if not args.quiet:
        summary = ", ".join(f"{k}: {v}" for k, v in sorted(codes.items()))
        print(f"fuzz_cli: {i} runs in {took:.1f} s (seed {args.seed}); exit statuses {summary}; "
              f"{findings} finding(s)")
    return 1 if findings else 0


if __name__ == "__main__":
    os.environ.setdefault("UAVBUS_FUZZ", "1")
    sys.exit(main())
