"""The `uavbus` command: dispatches to the generator (gen/check/selftest) and, later, runtime tools."""

from __future__ import annotations

import sys


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help"):
        print("usage: uavbus {gen,check,selftest} ...\n\n"
              "  gen       C headers -> catalogue + C and Python codecs\n"
              "  check     the same inputs; checks ID uniqueness, writes nothing\n"
              "  selftest  generate, build and round-trip every type in C and Python\n")
        return 0 if argv else 2
    cmd, rest = argv[0], argv[1:]
    if cmd in ("gen", "check", "selftest"):
        from uavbus_gen.cli import main as gen_main

        return gen_main([cmd, *rest])
    print(f"uavbus: unknown command '{cmd}' (try: uavbus --help)", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
