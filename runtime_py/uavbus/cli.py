"""The `uavbus` command: the generator (gen/check/selftest) and the runtime tools.

Every user error ends in one line on stderr, `uavbus <command>: <what is wrong and what to do>`, and a
documented exit status (EXIT_CODES, docs/tools.md); no traceback reaches the user. A bug shows as one
`internal error` line too, with UAVBUS_DEBUG=1 to get the traceback. Output cut short by the reader
(`| head`) ends quietly.
"""

from __future__ import annotations

import importlib
import os
import sys
import traceback
from collections.abc import Callable

# Runtime tools: command -> (module, function taking the remaining argv).
TOOLS = {
    "log": ("uavbus.tools.logcmd", "main"),
    "spy": ("uavbus.tools.live", "spy_main"),
    "echo": ("uavbus.tools.live", "echo_main"),
    "hz": ("uavbus.tools.live", "hz_main"),
    "bw": ("uavbus.tools.live", "bw_main"),
    "tables": ("uavbus.tools.tables", "main"),
    "tui": ("uavbus.tui.app", "main"),
    "web": ("uavbus.web.server", "main"),
    "list": ("uavbus.tools.discover", "main"),
    "get": ("uavbus.tools.browse", "get_main"),
    "set": ("uavbus.tools.browse", "set_main"),
    "sim": ("uavbus.sim.run_scenario", "main"),
    "keys": ("uavbus.keys", "main"),
    "bridge": ("uavbus.bridges.zenoh_bridge", "main"),
}

# Exit statuses of the runtime tools (the generator commands, gen/check/selftest, keep their own, documented
# by the generator; any exception they let escape still ends as one line here).
EXIT_OK = 0
EXIT_USAGE = 2        # bad command line: unknown command or option, a malformed or missing argument
EXIT_INPUT = 3        # a file that cannot be read or is not what it should be (config, catalogue, log, spec)
EXIT_ENVIRONMENT = 4  # the system refused: a port, socket or device that cannot be opened, output not writable
EXIT_INTERNAL = 70    # a bug in uavbus (EX_SOFTWARE): please report the line
EXIT_INTERRUPTED = 130
EXIT_BROKEN_PIPE = 141  # the reader went away (`| head`): nothing more is printed

EXIT_CODES = {
    EXIT_OK: "success",
    1: "the command ran and the answer is no (gen/check: ID collisions; selftest: a round trip failed)",
    EXIT_USAGE: "bad command line: unknown command or option, a missing or malformed argument",
    EXIT_INPUT: "bad input: a file that cannot be read or is not valid (config, catalogue, log, port spec)",
    EXIT_ENVIRONMENT: "the system refused: a port, socket or device cannot be opened, or output cannot be written",
    EXIT_INTERNAL: "internal error (a bug): one line; UAVBUS_DEBUG=1 prints the traceback",
    EXIT_INTERRUPTED: "interrupted (Ctrl-C)",
    EXIT_BROKEN_PIPE: "the output was closed early (e.g. | head)",
}

USAGE = """usage: uavbus [--version] {gen,check,selftest,log,spy,echo,hz,bw,tables,tui,web,list,get,set,sim,keys,bridge} ...

  gen       C headers -> catalogue + C and Python codecs
  check     the same inputs; checks ID uniqueness, writes nothing
  selftest  generate, build and round-trip every type in C and Python
  log       info | export | play a binary log
  spy       every directory seen: name, source, messages, duplicates, rate, last values
  echo      the values of one directory as they arrive (--field a.b picks members)
  hz        the rate of one directory
  bw        bytes per second, per content and per link
  tables    entity, publish/subscribe and administration tables
  tui       terminal variable browser (Textual)
  web       the operator's console in the browser: fleet map, administration table, variables, plots
  list      ENTITY: what it offers before subscribing (directories it hosts, its flows now)
  get       ENTITY NAME[.FIELD]: read a directory of a remote entity over the bus (C or Python)
  set       ENTITY NAME.FIELD VALUE: write it (docs/inspect.md)
  sim       run a fleet scenario file (vehicles, links, events; docs/scenarios.md)
  keys      new FILE | show FILE | authority create | issue ENTITY | revoke ENTITY | fleet CONFIG --out DIR:
            keys and identities (docs/security.md)
  bridge    zenoh: join uavbus sites through Zenoh sessions (docs/bridges.md)

`uavbus COMMAND --help` says more. Exit status: 0 ok, 1 no (check/selftest), 2 bad command line,
3 bad input file, 4 the system refused (port, device, output), 70 internal error, 130 interrupted,
141 output closed early (docs/tools.md)."""


def _version() -> str:
    from uavbus import __version__

    return f"uavbus {__version__}"


def _classify(exc: BaseException) -> tuple[int, str] | None:
    """(exit status, message) for an error a user can cause, or None for a bug."""
    from uavbus.errors import CatalogueError, ConfigError, EncodeError, LogFormatError, UbError

    if isinstance(exc, (ConfigError, CatalogueError, LogFormatError)):
        return EXIT_INPUT, str(exc)
    try:
        from uavbus.tools.common import FieldPathError
        from uavbus.tools.endpoint import SpecError
    except ImportError:  # pragma: no cover - the tools are part of the package
        FieldPathError = SpecError = ValueError  # type: ignore[misc,assignment]
    if isinstance(exc, (SpecError, FieldPathError, EncodeError)):
        return EXIT_USAGE, str(exc)
    if isinstance(exc, UbError):
        # The C runtime refused: a port that cannot be opened is the environment, the rest is input.
        text = exc.detail
        if exc.name in ("UB_ERR_IO", "UB_ERR_CLOSED", "UB_ERR_AGAIN"):
            return EXIT_ENVIRONMENT, text
        return EXIT_INPUT, text
    if isinstance(exc, KeyError) and exc.args and isinstance(exc.args[0], str) and " " in exc.args[0]:
        return EXIT_INPUT, exc.args[0]  # our lookups say what is missing: "catalogue flightsw has no instance 'x'"
    if isinstance(exc, (FileNotFoundError, IsADirectoryError, NotADirectoryError)):
        where = f"{exc.filename}: " if exc.filename else ""
        return EXIT_INPUT, f"{where}{exc.strerror or exc} (check the path)"
    if isinstance(exc, PermissionError):
        where = f"{exc.filename}: " if exc.filename else ""
        return EXIT_ENVIRONMENT, f"{where}{exc.strerror or exc} (check its permissions)"
    if isinstance(exc, OSError):
        where = f"{exc.filename}: " if exc.filename else ""
        return EXIT_ENVIRONMENT, f"{where}{exc.strerror or exc}"
    if isinstance(exc, UnicodeDecodeError):
        return EXIT_INPUT, f"not text in the expected encoding ({exc.reason} at byte {exc.start})"
    return None


def _one_line(text: str) -> str:
    return " ".join(str(text).split()) or "(no message)"


def run_tool(command: str, func: Callable[[list[str]], int], argv: list[str]) -> int:
    """Runs one command with the uniform error handling described in the module docstring."""
    try:
        return int(func(argv) or 0)
    except SystemExit as exc:  # argparse (status 2, message already printed) and the tools' own messages
        code = exc.code
        if code is None:
            return EXIT_OK
        if isinstance(code, int):
            return code
        message = _one_line(str(code))
        prefix = f"uavbus {command}: "
        print(message if message.startswith("uavbus") else prefix + message, file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print(f"uavbus {command}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        _quiet_stdout()
        return EXIT_BROKEN_PIPE
    except Exception as exc:  # noqa: BLE001 - the one place that turns every failure into one line
        known = _classify(exc)
        if known is not None:
            code, message = known
            print(f"uavbus {command}: {_one_line(message)}", file=sys.stderr)
            return code
        if os.environ.get("UAVBUS_DEBUG"):
            traceback.print_exc()
        print(f"uavbus {command}: internal error: {type(exc).__name__}: {_one_line(str(exc))} (a bug in uavbus: "
              "please report this line; UAVBUS_DEBUG=1 shows the traceback)", file=sys.stderr)
        return EXIT_INTERNAL


def _quiet_stdout() -> None:
    """After a broken pipe: point stdout at /dev/null so the interpreter's final flush stays silent."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError):
        pass


def _dispatch(argv: list[str]) -> int:
    if not argv or argv[0] in ("-h", "--help", "help"):
        print(USAGE)
        return EXIT_OK if argv else EXIT_USAGE
    if argv[0] in ("--version", "-V", "version"):
        print(_version())
        return EXIT_OK
    cmd, rest = argv[0], argv[1:]
    if cmd in ("gen", "check", "selftest"):
        from uavbus_gen.cli import main as gen_main

        return run_tool(cmd, lambda a: gen_main([cmd, *a]), rest)
    if cmd in TOOLS:
        module_name, func = TOOLS[cmd]
        if "--version" in rest:
            print(_version())
            return EXIT_OK
        return run_tool(cmd, lambda a: getattr(importlib.import_module(module_name), func)(a), rest)
    print(f"uavbus: unknown command '{cmd}' (commands: gen, check, selftest, {', '.join(TOOLS)}; "
          "try: uavbus --help)", file=sys.stderr)
    return EXIT_USAGE


def main(argv: list[str] | None = None) -> int:
    """Entry point of the `uavbus` script; returns the exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    code = _dispatch(argv)
    try:
        sys.stdout.flush()
    except BrokenPipeError:
        _quiet_stdout()
        return EXIT_BROKEN_PIPE
    return code


if __name__ == "__main__":
    sys.exit(main())
