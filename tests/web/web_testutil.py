"""Helpers of the console's browser tests."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import pytest


def wait_for(cond: Callable[[], Any], timeout: float, what: str, step: float = 0.1) -> Any:
    """Polls cond() until it is truthy; fails naming `what` and the last value otherwise."""
    deadline = time.monotonic() + timeout
    last: Any = None
    while True:
        try:
            last = cond()
        except Exception as exc:  # noqa: BLE001 - a page still changing: try again
            last = exc
        if last and not isinstance(last, Exception):
            return last
        if time.monotonic() > deadline:
            pytest.fail(f"{what}: not within {timeout:g} s (last: {last!r})")
        time.sleep(step)


def identity_security(out: Any, roles_of: dict[str, str]) -> dict[str, Any]:
    """Table 2's security section with signed frames and an identity per entity, its certificate saying
    `roles_of[entity]` (uavbus keys: an authority, one certificate each, every node its own copy of the
    fleet's certificates). Absolute paths: the nodes run from the repository."""
    import json
    import shutil
    from pathlib import Path

    from uavbus import keys
    from uavbus.sim.build import REPO
    from uavbus.sim.secure import signed_config

    out = Path(out)
    kdir = out / "keys"
    keys.authority_create(str(kdir))
    for entity, roles in roles_of.items():
        keys.issue(entity, roles, 30, None, str(kdir), None, False)
    cfg = signed_config(REPO / "examples" / "configs" / "table2.json", out)
    for entity in roles_of:
        shutil.copyfile(kdir / "fleet.certs", out / "state" / f"{entity}.certs")
    sec: dict[str, Any] = json.loads(cfg.read_text(encoding="utf-8"))["security"]
    state = (out / "state").resolve()
    sec.update({"counter_file": f"{state}/{{entity}}.counter", "authority": str((kdir / "authority.pub").resolve()),
                "identity": f"{kdir.resolve()}/{{entity}}.id", "certificates": f"{state}/{{entity}}.certs",
                "revocations": f"{state}/{{entity}}.revocations.ubr"})
    return sec
