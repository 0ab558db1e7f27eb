"""Signed variants of a node configuration, made at run time (keys are never committed).

    cfg = signed_config(REPO / "examples/configs/table2.json", tmp_path)   # keys/, state/, table2.signed.json
    Hitl(HitlOptions(config=cfg))                                          # every process signs

The keys are written by the C runtime (`uavbus keys new`'s code: mode 0600), next to the config with
the counter files (`state/{entity}.counter`), so the directory is the fleet's whole secret state.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from uavbus._bindings import ub_sec

__all__ = ["signed_config", "new_key"]


def new_key(directory: Path, key_id: int, name: str | None = None) -> Path:
    """A new key file `directory/<name or fleet-<id>.key>` with id `key_id`; returns its path."""
    directory.mkdir(parents=True, exist_ok=True, mode=0o700)
    path = directory / (name or f"fleet-{key_id}.key")
    ub_sec.ub_keyfile_new(str(path), key_id)
    return path


def signed_config(source: Path, out_dir: Path, key_ids: tuple[int, ...] = (1,), tx_key: int | None = None,
                  require_signed: bool = True, links: dict[str, dict[str, bool]] | None = None,
                  name: str | None = None, keys_dir: Path | None = None) -> Path:
    """Writes `source` with a "security" section into `out_dir` and returns the new file's path.

    `key_ids`: a key file per id under `keys_dir` (default out_dir/keys; existing files are reused, so
    several configs can share a fleet's keys); `tx_key`: the signing key (default the first);
    `links`: per-link settings, e.g. {"gcsPortDatalink1": {"encrypt": True}}."""
    out_dir.mkdir(parents=True, exist_ok=True)
    keys_dir = keys_dir or out_dir / "keys"
    (out_dir / "state").mkdir(exist_ok=True)
    key_paths = []
    for key_id in key_ids:
        path = keys_dir / f"fleet-{key_id}.key"
        if not path.exists():
            new_key(keys_dir, key_id)
        key_paths.append(path)
    doc: dict[str, Any] = json.loads(Path(source).read_text(encoding="utf-8"))
    security: dict[str, Any] = {
        "keys": [str(p.resolve()) for p in key_paths],
        "tx_key": tx_key or key_ids[0],
        "require_signed": require_signed,
        "counter_file": "state/{entity}.counter",
    }
    if links:
        security["links"] = links
    doc["security"] = {**doc.get("security", {}), **security}   # keeps an authorization policy already there
    target = out_dir / (name or f"{Path(source).stem}.signed.json")
    target.write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
    return target
