"""`uavbus keys`: key files for signed and encrypted frames (docs/security.md).

    uavbus keys new FILE [--id N]    a new random key, written mode 0600 (never over an existing file);
                                     prints its id
    uavbus keys show FILE            the id of a key file (checks it as a node would; never the key)

The key is made and written by the C runtime (ub_secfile.h, through cffi), the same code that
uavbus_node and Node use to read it.
"""

from __future__ import annotations

import argparse
import sys

from uavbus._bindings import ub_sec
from uavbus._bindings.ub_error import UbError


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="uavbus keys", description="key files for signed frames (docs/security.md)")
    sub = parser.add_subparsers(dest="cmd", required=True)
    new = sub.add_parser("new", help="write a new random key to FILE (mode 0600) and print its id")
    new.add_argument("file")
    new.add_argument("--id", type=int, default=0, metavar="N",
                     help="key id 1..255 (default: random); receivers tell keys apart by it")
    show = sub.add_parser("show", help="print the id of a key file (checked as a node reads it)")
    show.add_argument("file")
    args = parser.parse_args(argv)
    try:
        if args.cmd == "new":
            if not 1 <= args.id <= 255 and args.id != 0:
                print(f"uavbus keys: --id {args.id}: a key id is 1..255", file=sys.stderr)
                return 2
            print(ub_sec.ub_keyfile_new(args.file, args.id))
        else:
            key_id, _ = ub_sec.ub_keyfile_load(args.file)
            print(key_id)
    except UbError as e:
        # the C message already names the file and says what to do; the code name adds nothing
        print(str(e).removeprefix(f"{e.name}: "), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())


def x25519_public_key(secret: bytes) -> bytes:
    """The X25519 public key of an entity's 32-byte secret key (origin authentication, docs/security.md):
    what the identity store hands its peers. Any 32 random bytes are a secret key (a key file's, too)."""
    from uavbus._bindings import ub_origin

    return ub_origin.ub_origin_public_key(secret)
