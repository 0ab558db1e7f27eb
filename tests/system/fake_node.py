"""A stand-in speaking the uavbus_node stdin/stdout protocol (docs/program-protocol.md), for testing the harness alone.

    fake_node.py NAME [--fail MESSAGE] [--stats-ms N]
"""

from __future__ import annotations

import json
import os
import sys
import time


def emit(ev: dict) -> None:
    print(json.dumps(ev), flush=True)


def main() -> int:
    name = sys.argv[1]
    if "--fail" in sys.argv:
        print(f"fake_node.py:1: {sys.argv[sys.argv.index('--fail') + 1]}", file=sys.stderr, flush=True)
        return 2
    emit({"event": "ready", "node": name, "pid": os.getpid(), "ports": {}})
    n = 0
    for line in sys.stdin:
        cmd = line.split()
        if not cmd:
            continue
        if cmd[0] == "stats":
            n += 1
            emit({"event": "stats", "t_ms": int(time.monotonic() * 1000), "node": {"n": n}, "links": {}})
        elif cmd[0] == "rebind":
            emit({"event": "rebound", "port": cmd[1], "spec": cmd[2]})
        elif cmd[0] == "garbage":  # lines a supervisor must survive: not UTF-8, not JSON, a JSON array
            sys.stdout.buffer.write(b'{"event":"stats","bad":"\xff\xfe\xc3("}\n' b"not json at all\n" b"[1, 2]\n")
            sys.stdout.buffer.flush()
        elif cmd[0] == "quit":
            return 0
        else:
            emit({"event": "error", "message": f"unknown command {cmd[0]}"})
    time.sleep(60)  # EOF on stdin is ignored, as the real node does
    return 0


if __name__ == "__main__":
    sys.exit(main())
