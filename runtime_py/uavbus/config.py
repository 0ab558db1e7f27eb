"""Node configuration files: the paper's entity table (AIAA 2005-6309 III.D, Tables 1 and 2) as JSON.

There is one configuration loader in uavbus, the C one (``runtime_c/src/config/ub_nodecfg.c``). This module
is a thin layer over it: `load_config()` / `parse_config()` hand the file to the C loader through cffi
and read the parsed table back into frozen dataclasses; `Node(config=...)` applies that same C table to
the router. So a file that a C flight-software process accepts is exactly the file Python accepts, with
the same ``file:line: entity 'name', field 'path': what is wrong and what to do`` message when not, and
every section the C loader learns (e.g. ``"security"``) reaches Python with no change here.

Format: docs/config-format.md.  Run ``python -m uavbus.config FILE [NODE]`` to check a file.
"""

from __future__ import annotations

import re
import sys
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from uavbus._paths import SCHEMAS_DIR
from uavbus.errors import ConfigError, UbError

__all__ = [
    "Config", "ConfigError", "Entity", "Limits", "Port", "SCHEMA_PATH", "format_mask_hex", "load_config",
    "parse_config", "parse_mask_hex",
]

#: The JSON Schema of the format (structure only; the C loader checks everything).
SCHEMA_PATH = SCHEMAS_DIR / "config.schema.json"

_HEX_HINT = "(each hex digit is one link: 0x00000110 means links 1 and 2)"


@dataclass(frozen=True)
class Limits:
    """Capacities to check a file against; the defaults are this build's (ub_config.h, ub_nodecfg.h).

    Smaller values check a file meant for a smaller build (e.g. a microcontroller's ub_config.h);
    larger ones than the build's are refused (`ConfigError`), since the C tables could not hold them."""

    max_entities: int = 0          # 0 = the build's UB_MAX_ENTITIES
    max_links_per_entity: int = 0  # UB_MAX_LINKS_PER_ENTITY
    max_local_entities: int = 0    # UB_MAX_LOCAL_ENTITIES
    max_ports: int = 0             # UB_NODECFG_MAX_PORTS
    max_port_params: int = 0       # UB_NODECFG_MAX_PORT_PARAMS

    @classmethod
    def build(cls) -> Limits:
        """This build's capacities, as the C runtime was compiled."""
        from uavbus._bindings import ub_nodecfg

        return cls(**ub_nodecfg.build_limits())


@dataclass(frozen=True)
class Entity:
    """One entity-table row: its links (the paper's link[i]) and masks[j] toward Config.entities[j]."""

    name: str
    links: tuple[str, ...]
    masks: tuple[int, ...]
    line: int


@dataclass(frozen=True)
class Port:
    """A "ports" entry: link name (or "entity:link") -> transport and its parameters as text."""

    name: str
    transport: str
    params: dict[str, str]
    line: int


@dataclass(frozen=True)
class Config:
    """A configuration the C loader accepted. `hosts` are the entities this process hosts.

    `c_config` is the parsed C table (``ub_nodecfg_t``) that `uavbus.Node` applies."""

    path: str
    system: str
    entities: tuple[Entity, ...]
    hosts: tuple[str, ...] = ()
    nodes: dict[str, tuple[str, ...]] = field(default_factory=dict)
    ports: tuple[Port, ...] = ()
    c_config: Any = field(default=None, repr=False, compare=False)

    def index(self, name: str) -> int:
        """Position of entity `name` in `entities` (the paper's entity index)."""
        for i, entity in enumerate(self.entities):
            if entity.name == name:
                return i
        raise KeyError(f"no entity named '{name}' in {self.path}")

    def entity(self, name: str) -> Entity:
        return self.entities[self.index(name)]

    def mask(self, source: str, destination: str) -> int:
        """Bit i set: `source` sends frames for `destination` over its link[i]."""
        return self.entity(source).masks[self.index(destination)]

    def select_node(self, node: str) -> Config:
        """The same configuration hosting the entities of `node` (from "nodes"); ConfigError if none."""
        from uavbus._bindings import ub_nodecfg

        c = ub_nodecfg.copy(self.c_config)
        try:
            ub_nodecfg.ub_nodecfg_select_node(c, node)
        except UbError as exc:
            raise ConfigError(exc.detail, self.path) from None
        return replace(self, hosts=ub_nodecfg.hosted_entities(c), c_config=c)


# ---------------------------------------------------------------- masks (ub_link.h)

def parse_mask_hex(text: str) -> int:
    """The paper's hex notation -> bits: parse_mask_hex("0x00000110") == 0b110. Raises ValueError."""
    from uavbus._bindings import ub_nodecfg

    bits = ub_nodecfg.mask_parse(text)
    if bits is None:
        raise ValueError(f'link mask {text!r}: expected "0x" and 1 to 16 digits, each 0 or 1, links 0 to 7 '
                         f"{_HEX_HINT}")
    return bits


def format_mask_hex(mask: int) -> str:
    """Bits -> the paper's 8-digit notation: format_mask_hex(0b110) == "0x00000110"."""
    from uavbus._bindings import ub_nodecfg

    if not isinstance(mask, int) or not 0 <= mask <= 0xFF:
        raise ValueError(f"mask {mask!r} does not fit 8 links (0 to 255)")
    return ub_nodecfg.mask_format(mask)


# ---------------------------------------------------------------- loading (ub_nodecfg.h)

_LOCATED = re.compile(r"(\d+):")


def _error(exc: UbError, path: str) -> ConfigError:
    """The C loader's message as a ConfigError, with the line it names."""
    message = exc.detail
    line = 0
    if message.startswith(path + ":"):
        m = _LOCATED.match(message, len(path) + 1)
        line = int(m.group(1)) if m else 0
    return ConfigError(message, path, line)


def _config(c: Any, path: str) -> Config:
    from uavbus._bindings import ub_nodecfg

    entities, ports = ub_nodecfg.rows(c)
    return Config(path=path, system=ub_nodecfg.text(c.system),
                  entities=tuple(Entity(**e) for e in entities),
                  hosts=ub_nodecfg.hosted_entities(c), nodes=ub_nodecfg.nodes(c),
                  ports=tuple(Port(**p) for p in ports), c_config=c)


def parse_config(data: bytes | str, path: str = "<config>", limits: Limits | None = None) -> Config:
    """Checks `data` (the text of a config file) named `path` in messages; raises ConfigError."""
    from uavbus._bindings import ub_nodecfg

    raw = data.encode("utf-8") if isinstance(data, str) else bytes(data)
    try:
        c = ub_nodecfg.parse(raw, path, None if limits is None else vars(limits))
    except UbError as exc:
        raise _error(exc, path) from None
    return _config(c, path)


def load_config(path: str | Path, node: str | None = None, limits: Limits | None = None) -> Config:
    """Reads and checks a config file; with `node`, hosts that node's entities. Raises ConfigError."""
    from uavbus._bindings import ub_nodecfg

    name = str(path)
    try:
        c = ub_nodecfg.load_file(name, None if limits is None else vars(limits))
    except UbError as exc:
        raise _error(exc, name) from None
    config = _config(c, name)
    return config.select_node(node) if node is not None else config


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if not 1 <= len(args) <= 2:
        print("usage: python -m uavbus.config FILE [NODE]", file=sys.stderr)
        return 2
    try:
        config = load_config(args[0], args[1] if len(args) == 2 else None)
    except ConfigError as exc:
        print(exc, file=sys.stderr)
        return 1
    for entity in config.entities:
        masks = " ".join(format_mask_hex(m) for m in entity.masks)
        host = "*" if entity.name in config.hosts else " "
        print(f"{host} {entity.name:<12} links={list(entity.links)} linktoentity={masks}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
