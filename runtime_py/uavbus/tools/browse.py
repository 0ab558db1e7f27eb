"""`uavbus get` and `uavbus set`: the variable browser for scripts (uavbus.remote over a live node).

    uavbus get fcs20 airData.staticPressurePa --config table2.json --node gcs --catalogue flightsw.catalogue.json
    uavbus set fcs20 fcsSet.mode 3 --config table2.json --node gcs --catalogue ...

The value printed is JSON (a directory as an object). A refusal (NACK) or silence ends in one line on
stderr and exit status 1: `uavbus get: fcs20: write airData: refused (not_authorized)`.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import IO, Any

from uavbus.tools.common import ArgumentParser, positive
from uavbus.tools.source import add_node_args, open_node

EXIT_REFUSED = 1  # the command ran and the target said no (NACK) or did not answer


def _parser(prog: str, doc: str) -> argparse.ArgumentParser:
    p = ArgumentParser(prog=prog, description=doc)
    p.add_argument("entity", help="the remote entity, e.g. fcs20")
    p.add_argument("name", help="a directory or one of its fields, e.g. gpsOut or onboardSet.mode")
    add_node_args(p)
    p.add_argument("--timeout", type=positive(float), default=3.0, help="seconds to wait for the answer (default 3)")
    return p


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, bytes):
        return value.hex()
    if isinstance(value, int) and not isinstance(value, bool):
        return int(value)  # IntEnum members print as their number
    return value


def _run(args: argparse.Namespace, prog: str, action: Any, out: IO[str]) -> int:
    from uavbus.errors import NoAnswerError, RefusedError

    session = open_node(args)
    try:
        remote = session.node.remote(args.entity, timeout=args.timeout)
        try:
            result = action(remote)
        except (RefusedError, NoAnswerError) as exc:
            print(f"{prog}: {exc.detail}", file=sys.stderr)
            return EXIT_REFUSED
        print(json.dumps(_jsonable(result)), file=out)
        return 0
    finally:
        session.close()


def get_main(argv: list[str] | None = None, out: IO[str] | None = None) -> int:
    p = _parser("uavbus get", "read a directory (or one field) of a remote entity once, over the bus")
    args = p.parse_args(argv)
    return _run(args, "uavbus get", lambda r: r.get(args.name), out or sys.stdout)


def parse_value(text: str) -> Any:
    """A JSON value (3, 1.5, true, {"a": 1}, [1, 2]); anything else is taken as a string."""
    try:
        return json.loads(text)
    except ValueError:
        return text


def set_main(argv: list[str] | None = None, out: IO[str] | None = None) -> int:
    p = _parser("uavbus set", "write a directory or one field of a remote entity, over the bus")
    p.add_argument("value", help="the new value, JSON: 3, 1.5, true, or a whole directory as an object")
    args = p.parse_args(argv)
    value = parse_value(args.value)
    return _run(args, "uavbus set", lambda r: {"changed": r.set(args.name, value)}, out or sys.stdout)
