"""The `uavbus` command: dispatches to the generator (gen/check/selftest) and, later, runtime tools."""

from __future__ import annotations

import sys


# Runtime tools (room F): command -> (module, function taking the remaining argv).
TOOLS = {
    "log": ("uavbus.tools.logcmd", "main"),
    "spy": ("uavbus.tools.live", "spy_main"),
    "echo": ("uavbus.tools.live", "echo_main"),
    "hz": ("uavbus.tools.live", "hz_main"),
    "tables": ("uavbus.tools.tables", "main"),
    "tui": ("uavbus.tui.app", "main"),
    "sim": ("uavbus.sim.run_scenario", "main"),
    "keys": ("uavbus.keys", "main"),
}


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help"):
        print("usage: uavbus {gen,check,selftest,log,spy,echo,hz,tables,tui,sim,keys} ...\n\n"
              "  gen       C headers -> catalogue + C and Python codecs\n"
              "  check     the same inputs; checks ID uniqueness, writes nothing\n"
              "  selftest  generate, build and round-trip every type in C and Python\n"
              "  log       info | export | play a binary log\n"
              "  spy       every directory seen: name, source, rate, last values\n"
              "  echo      the values of one directory as they arrive\n"
              "  hz        the rate of one directory\n"
              "  tables    entity, publish/subscribe and administration tables\n"
              "  tui       terminal variable browser (Textual)\n"
              "  sim       run a fleet scenario file (vehicles, links, events; docs/scenarios.md)\n"
              "  keys      new FILE [--id N]: a key for signed frames (docs/security.md)\n")
        return 0 if argv else 2
    cmd, rest = argv[0], argv[1:]
    if cmd in ("gen", "check", "selftest"):
        from uavbus_gen.cli import main as gen_main

        return gen_main([cmd, *rest])
    if cmd in TOOLS:
        import importlib

        module_name, func = TOOLS[cmd]
        return int(getattr(importlib.import_module(module_name), func)(rest))
    print(f"uavbus: unknown command '{cmd}' (try: uavbus --help)", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
