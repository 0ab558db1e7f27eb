"""Node configuration files: the paper's entity table (AIAA 2005-6309 III.D, Tables 1 and 2) as JSON.

`load_config(path)` reads, checks and returns a frozen `Config`, or raises `ConfigError` whose text is
``file:line: entity 'name', field 'path': what is wrong and what to do`` -- word for word what the C loader
(runtime_c/include/ub/ub_nodecfg.h) says for the same file. To keep the two in step this module scans JSON
itself (same grammar, same messages, same line numbers) and applies the checks in the same order as
runtime_c/src/ub_nodecfg.c; afterwards the result is validated against schemas/config.schema.json too.

Format: docs/config-format.md.  Run ``python -m uavbus.config FILE [NODE]`` to check a file.
"""

from __future__ import annotations

import json
import re
import sys
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, NoReturn

import jsonschema

__all__ = [
    "Config", "ConfigError", "Entity", "Limits", "Port", "format_mask_hex", "load_config", "parse_config",
    "parse_mask_hex",
]

SCHEMA_PATH = Path(__file__).resolve().parents[2] / "schemas" / "config.schema.json"

HEX_HINT = "(each hex digit is one link: 0x00000110 means links 1 and 2)"
NAME_CHARS = "A-Z a-z 0-9 _ . -"
MASK_SHAPE = 'a mask is a hex string such as "0x00000110" or a list of links such as [1, 2] or ["linkName"]'
MAX_DEPTH = 32
ENTITY_ID_LEN = 12
NAME_MAX = 31
TEXT_MAX = 63
ECHO_MAX = 40
TOP_FIELDS = ("system", "entities", "hosts", "nodes", "ports")
ENTITY_FIELDS = ("name", "links", "linktoentity")
_NAME_RE = re.compile(rb"[A-Za-z0-9_.-]+")
_WORD_RE = re.compile(rb"[a-z][a-z0-9_]{0,14}")


@dataclass(frozen=True)
class Limits:
    """Build capacities; the defaults equal runtime_c/include/ub/ub_config.h and ub_nodecfg.h."""

    max_entities: int = 16
    max_links_per_entity: int = 8
    max_local_entities: int = 4
    max_ports: int = 32
    max_port_params: int = 4


class ConfigError(ValueError):
    """An invalid configuration file; str() is the one-line ``file:line: ...`` message."""

    def __init__(self, message: str, path: str = "", line: int = 0) -> None:
        super().__init__(message)
        self.path = path
        self.line = line


@dataclass(frozen=True)
class Entity:
    """One entity-table row: its links (the paper's link[i]) and masks[j] toward Config.entities[j]."""

    name: str
    links: tuple[str, ...]
    masks: tuple[int, ...]
    line: int


@dataclass(frozen=True)
class Port:
    """A "ports" entry (reserved for the links issue): link name -> transport and text parameters."""

    name: str
    transport: str
    params: dict[str, str]
    line: int


@dataclass(frozen=True)
class Config:
    """A validated configuration. `hosts` are the entities this process hosts."""

    path: str
    system: str
    entities: tuple[Entity, ...]
    hosts: tuple[str, ...] = ()
    nodes: dict[str, tuple[str, ...]] = field(default_factory=dict)
    ports: tuple[Port, ...] = ()

    def index(self, name: str) -> int:
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
        """The same configuration hosting the entities of `node` (from "nodes")."""
        if node not in self.nodes:
            known = ", ".join(self.nodes) or "none"
            raise ConfigError(f"no node named '{_echo(node.encode())}' in 'nodes' (known: {known})", self.path)
        return replace(self, hosts=self.nodes[node])


# ---------------------------------------------------------------- masks

def parse_mask_hex(text: str) -> int:
    """The paper's hex notation -> bits: parse_mask_hex("0x00000110") == 0b110. Raises ValueError."""
    return _hex_parse(text.encode("utf-8"))


def format_mask_hex(mask: int) -> str:
    """Bits -> the paper's 8-digit notation: format_mask_hex(0b110) == "0x00000110"."""
    if not 0 <= mask <= 0xFF:
        raise ValueError(f"mask {mask} does not fit 8 links")
    return "0x" + "".join("1" if mask >> link & 1 else "0" for link in range(7, -1, -1))


def _hex_parse(s: bytes) -> int:
    if len(s) < 2 or s[0:1] != b"0" or s[1:2] not in (b"x", b"X"):
        raise ValueError(f'a hex mask starts with "0x" {HEX_HINT}')
    digits = s[2:]
    if not 1 <= len(digits) <= 16:
        raise ValueError(f'a hex mask has 1 to 16 digits after "0x" {HEX_HINT}')
    for c in digits:
        if c in b"01":
            continue
        if chr(c) in "23456789abcdefABCDEF":
            raise ValueError(f"hex digit '{chr(c)}' is not 0 or 1 {HEX_HINT}")
        if 0x20 <= c <= 0x7E and c != ord("'"):
            raise ValueError(f"'{chr(c)}' is not a hex digit {HEX_HINT}")
        raise ValueError(f"byte 0x{c:02x} is not a hex digit {HEX_HINT}")
    bits = 0
    for i, c in enumerate(digits):
        link = len(digits) - 1 - i
        if c != ord("1"):
            continue
        if link >= 8:
            raise ValueError(f"hex digit for link {link} is set, but links are numbered 0 to 7 {HEX_HINT}")
        bits |= 1 << link
    return bits


# ---------------------------------------------------------------- JSON scanner (mirrors runtime_c/src/ub_json.c)

@dataclass
class JValue:
    """A scanned JSON value. Strings are kept as the decoded UTF-8 bytes, numbers as their literal text."""

    kind: str  # object array string number true false null
    line: int
    value: Any = None  # object: list[(JValue key, JValue)], array: list[JValue], string: bytes, number: str


class _JsonError(Exception):
    def __init__(self, line: int, message: str) -> None:
        super().__init__(message)
        self.line = line


class _Scanner:
    def __init__(self, data: bytes) -> None:
        self.data = data
        self.pos = 0
        self.line = 1

    def fail(self, line: int, message: str) -> NoReturn:
        raise _JsonError(line, "invalid JSON: " + message)

    def peek(self) -> int:
        return self.data[self.pos] if self.pos < len(self.data) else -1

    def found(self) -> str:
        c = self.peek()
        if c < 0:
            return "end of file"
        return f"'{chr(c)}'" if 0x20 <= c <= 0x7E else f"byte 0x{c:02x}"

    def fail_found(self, expected: str) -> NoReturn:
        self.fail(self.line, f"expected {expected}, found {self.found()}")

    def skip_ws(self) -> None:
        while self.pos < len(self.data):
            c = self.data[self.pos]
            if c == 0x0A:
                self.line += 1
            elif c not in (0x20, 0x09, 0x0D):
                return
            self.pos += 1

    def read_u4(self, at: int) -> int:
        chunk = self.data[at:at + 4]
        if len(chunk) < 4 or any(chr(c) not in "0123456789abcdefABCDEF" for c in chunk):
            return -1
        return int(chunk, 16)

    def scan_string(self) -> bytes:
        start_line = self.line
        self.pos += 1
        out = bytearray()
        unterminated = "unterminated string (missing closing '\"')"
        while True:
            c = self.peek()
            if c < 0:
                self.fail(start_line, unterminated)
            if c == 0x22:
                self.pos += 1
                return bytes(out)
            if c < 0x20:
                self.fail(self.line, f"control character 0x{c:02x} in string (write it as an escape such as \\n)")
            if c != 0x5C:
                out.append(c)
                self.pos += 1
                continue
            if self.pos + 1 >= len(self.data):
                self.fail(start_line, unterminated)
            e = chr(self.data[self.pos + 1])
            simple = {'"': '"', "\\": "\\", "/": "/", "b": "\b", "f": "\f", "n": "\n", "r": "\r", "t": "\t"}
            if e in simple:
                out += simple[e].encode()
                self.pos += 2
                continue
            if e != "u":
                self.fail(self.line, "invalid escape in string (valid: \\\" \\\\ \\/ \\b \\f \\n \\r \\t \\uXXXX)")
            out += self.scan_u_escape().encode("utf-8")

    def scan_u_escape(self) -> str:
        cp = self.read_u4(self.pos + 2)
        if cp < 0:
            self.fail(self.line, "invalid \\u escape (it needs 4 hex digits)")
        self.pos += 6
        if 0xDC00 <= cp <= 0xDFFF:
            self.fail(self.line, "unpaired surrogate in \\u escape")
        if 0xD800 <= cp <= 0xDBFF:
            low = -1
            if self.data[self.pos:self.pos + 2] == b"\\u":
                low = self.read_u4(self.pos + 2)
            if not 0xDC00 <= low <= 0xDFFF:
                self.fail(self.line, "unpaired surrogate in \\u escape")
            self.pos += 6
            cp = 0x10000 + ((cp - 0xD800) << 10) + (low - 0xDC00)
        return chr(cp)

    def at_digit(self) -> bool:
        return 0x30 <= self.peek() <= 0x39

    def scan_digits(self) -> None:
        if not self.at_digit():
            self.fail(self.line, "invalid number")
        while self.at_digit():
            self.pos += 1

    def scan_number(self) -> str:
        start = self.pos
        if self.peek() == ord("-"):
            self.pos += 1
        if not self.at_digit():
            self.fail(self.line, "invalid number")
        if self.peek() == ord("0"):
            self.pos += 1
        else:
            self.scan_digits()
        if self.peek() == ord("."):
            self.pos += 1
            self.scan_digits()
        if self.peek() in (ord("e"), ord("E")):
            self.pos += 1
            if self.peek() in (ord("+"), ord("-")):
                self.pos += 1
            self.scan_digits()
        return self.data[start:self.pos].decode("ascii")

    def scan_literal(self, word: str) -> None:
        if self.data[self.pos:self.pos + len(word)] != word.encode():
            self.fail(self.line, "invalid literal (expected true, false or null)")
        self.pos += len(word)

    def scan_container(self, depth: int, is_object: bool) -> list[Any]:
        close = "}" if is_object else "]"
        if depth > MAX_DEPTH:
            self.fail(self.line, f"nesting deeper than {MAX_DEPTH} levels")
        self.pos += 1
        self.skip_ws()
        members: list[Any] = []
        if self.peek() == ord(close):
            self.pos += 1
            return members
        while True:
            self.skip_ws()
            if is_object:
                if self.peek() != ord('"'):
                    self.fail_found("a string key")
                key = JValue("string", self.line)
                key.value = self.scan_string()
                self.skip_ws()
                if self.peek() != ord(":"):
                    self.fail_found("':' after the key")
                self.pos += 1
                members.append((key, self.scan_value(depth + 1)))
            else:
                members.append(self.scan_value(depth + 1))
            self.skip_ws()
            if self.peek() == ord(close):
                self.pos += 1
                return members
            if self.peek() != ord(","):
                self.fail_found(f"',' or '{close}'")
            self.pos += 1
            self.skip_ws()
            if self.peek() == ord(close):
                self.fail(self.line, f"trailing ',' before '{close}' (JSON does not allow one)")

    def scan_value(self, depth: int) -> JValue:
        self.skip_ws()
        c = self.peek()
        if c < 0:
            self.fail_found("a value")
        v = JValue("", self.line)
        ch = chr(c)
        if ch in "{[":
            v.kind = "object" if ch == "{" else "array"
            v.value = self.scan_container(depth, ch == "{")
        elif ch == '"':
            v.kind, v.value = "string", self.scan_string()
        elif ch == "-" or ch.isdigit() and c < 0x80:
            v.kind, v.value = "number", self.scan_number()
        elif ch in "tfn":
            v.kind = {"t": "true", "f": "false", "n": "null"}[ch]
            self.scan_literal(v.kind)
        else:
            self.fail_found("a value")
        return v

    def document(self) -> JValue:
        root = self.scan_value(1)
        self.skip_ws()
        if self.pos < len(self.data):
            self.fail_found("end of file after the top-level value")
        return root


# ---------------------------------------------------------------- checks (mirror runtime_c/src/ub_nodecfg.c)

def _is_name(b: bytes, limit: int) -> bool:
    return 1 <= len(b) <= limit and _NAME_RE.fullmatch(b) is not None


def _is_word(b: bytes) -> bool:
    return _WORD_RE.fullmatch(b) is not None


def _echo(b: bytes) -> str:
    if not 1 <= len(b) <= ECHO_MAX or any(c < 0x20 or c > 0x7E or c == ord("'") for c in b):
        return "?"
    return b.decode("ascii")


def _number_text(literal: str) -> str:
    return literal[:20] + "..." if len(literal) > 24 else literal


def _is_integer_literal(literal: str) -> bool:
    return not any(c in literal for c in ".eE")


def _describe_links(count: int) -> str:
    if count == 0:
        return "no links"
    if count == 1:
        return "1 link (link 0)"
    return f"{count} links (link 0 to link {count - 1})"


@dataclass
class _EntityRow:
    name: str
    line: int
    links: list[str] = field(default_factory=list)
    masks: list[int] = field(default_factory=list)


@dataclass
class _Checker:
    path: str
    limits: Limits
    rows: list[_EntityRow] = field(default_factory=list)
    hosts: tuple[str, ...] = ()
    nodes: dict[str, tuple[str, ...]] = field(default_factory=dict)
    ports: list[Port] = field(default_factory=list)

    def fail(self, line: int, message: str, entity: str | None = None, fld: str | None = None) -> NoReturn:
        text = f"{self.path}:{line}: "
        if entity is not None:
            text += f"entity '{entity}', "
        if fld is not None:
            text += f"field '{fld}': "
        raise ConfigError(text + message, self.path, line)

    def find(self, name: bytes) -> int:
        for i, row in enumerate(self.rows):
            if row.name.encode() == name:
                return i
        return -1

    def check_fields(self, obj: JValue, fields: tuple[str, ...], entity: str | None) -> dict[str, JValue]:
        values: dict[str, JValue] = {}
        first_line: dict[str, int] = {}
        expected = ", ".join(fields)
        for key, val in obj.value:
            name = key.value.decode("utf-8", "replace") if key.value in [f.encode() for f in fields] else None
            if name is None:
                self.fail(key.line, f"unknown field (expected one of: {expected})", entity, _echo(key.value))
            if name in first_line:
                self.fail(key.line, f"duplicate field (first given on line {first_line[name]})", entity, name)
            first_line[name] = key.line
            values[name] = val
        return values

    # -- masks
    def mask_list(self, row: _EntityRow, lst: JValue, fld: str) -> int:
        bits = 0
        links = _describe_links(len(row.links))
        for k, v in enumerate(lst.value):
            path = f"{fld}[{k}]"
            if v.kind == "number":
                text = _number_text(v.value)
                if not _is_integer_literal(v.value) or v.value.startswith("-"):
                    self.fail(v.line, f"link index {text} must be a whole number 0 to 7", row.name, path)
                if len(v.value) > 3 or int(v.value) >= len(row.links):
                    self.fail(v.line, f"link index {text} is out of range: this entity has {links}", row.name, path)
                link = int(v.value)
            elif v.kind == "string" and _is_name(v.value, NAME_MAX):
                name = v.value.decode("ascii")
                if name not in row.links:
                    self.fail(v.line, f"no link named '{name}' in this entity's 'links'", row.name, path)
                link = row.links.index(name)
            else:
                self.fail(v.line, "list elements are link indices (0 to 7) or link names", row.name, path)
            if bits >> link & 1:
                self.fail(v.line, f"link {link} is listed twice", row.name, path)
            bits |= 1 << link
        return bits

    def parse_mask(self, self_index: int, target: int, v: JValue, fld: str) -> None:
        row = self.rows[self_index]
        if v.kind == "string":
            try:
                bits = _hex_parse(v.value)
            except ValueError as exc:
                self.fail(v.line, str(exc), row.name, fld)
            for link in range(len(row.links), 8):
                if bits >> link & 1:
                    self.fail(v.line, f"link {link} is set, but this entity has {_describe_links(len(row.links))}",
                              row.name, fld)
        elif v.kind == "array":
            bits = self.mask_list(row, v, fld)
        else:
            self.fail(v.line, MASK_SHAPE, row.name, fld)
        if self_index == target and bits != 0:
            self.fail(v.line, "an entity's mask to itself must be 0x00000000 (frames for a local entity are "
                      "delivered, not sent)", row.name, fld)
        row.masks[target] = bits

    def parse_linktoentity(self, self_index: int, lte: JValue) -> None:
        name = self.rows[self_index].name
        if lte.kind == "object":
            first_line: dict[int, int] = {}
            for key, v in lte.value:
                if not _is_name(key.value, ENTITY_ID_LEN):
                    self.fail(key.line, "'linktoentity' keys are entity names (1 to 12 characters from "
                              f"{NAME_CHARS})", name, "linktoentity")
                target_name = key.value.decode("ascii")
                path = f"linktoentity.{target_name}"
                target = self.find(key.value)
                if target < 0:
                    self.fail(key.line, f"no entity named '{target_name}' in 'entities'", name, path)
                if target in first_line:
                    self.fail(key.line, f"duplicate field (first given on line {first_line[target]})", name, path)
                first_line[target] = key.line
                self.parse_mask(self_index, target, v, path)
            return
        if lte.kind != "array":
            self.fail(lte.line, "must be an object keyed by entity name or a list with one mask per entity", name,
                      "linktoentity")
        if len(lte.value) != len(self.rows):
            self.fail(lte.line, f"has {len(lte.value)} masks but 'entities' lists {len(self.rows)}; give one mask "
                      "per entity in 'entities' order, or key the masks by entity name", name, "linktoentity")
        for target, v in enumerate(lte.value):
            self.parse_mask(self_index, target, v, f"linktoentity[{target}]")

    # -- entities
    def parse_links(self, row: _EntityRow, links: JValue) -> None:
        if links.kind != "array":
            self.fail(links.line, "must be a list of link names", row.name, "links")
        for k, v in enumerate(links.value):
            path = f"links[{k}]"
            if k == self.limits.max_links_per_entity:
                self.fail(v.line, f"too many links: at most {self.limits.max_links_per_entity} per entity (the "
                          "paper's limit is 8; UB_MAX_LINKS_PER_ENTITY)", row.name, path)
            if v.kind != "string" or not _is_name(v.value, NAME_MAX):
                self.fail(v.line, f"link names are 1 to {NAME_MAX} characters from {NAME_CHARS}", row.name, path)
            name = v.value.decode("ascii")
            if name in row.links:
                self.fail(v.line, f"duplicate link name '{name}' (first at links[{row.links.index(name)}])",
                          row.name, path)
            row.links.append(name)

    def parse_entity(self, index: int, obj: JValue) -> JValue | None:
        if obj.kind != "object":
            self.fail(obj.line, 'must be an object {"name": ..., "links": [...], "linktoentity": ...}', None,
                      f"entities[{index}]")
        path = f"entities[{index}].name"
        name_value = next((v for k, v in obj.value if k.value == b"name"), None)
        if name_value is None:
            self.fail(obj.line, "missing (every entity needs a name: its 12-byte ID)", None, path)
        if name_value.kind != "string" or not _is_name(name_value.value, ENTITY_ID_LEN):
            self.fail(name_value.line, f"entity names are 1 to 12 characters from {NAME_CHARS} (the name is the "
                      "12-byte entity ID)", None, path)
        name = name_value.value.decode("ascii")
        first = self.find(name_value.value)
        if first >= 0:
            self.fail(name_value.line, f"duplicate entity name (first defined on line {self.rows[first].line})",
                      name, "name")
        row = _EntityRow(name, obj.line)
        self.rows.append(row)
        values = self.check_fields(obj, ENTITY_FIELDS, name)
        if "links" in values:
            self.parse_links(row, values["links"])
        return values.get("linktoentity")

    def parse_entities(self, arr: JValue) -> None:
        if arr.kind != "array":
            self.fail(arr.line, "must be a list of entity objects", None, "entities")
        ltes: list[JValue | None] = []
        for i, v in enumerate(arr.value):
            if i == self.limits.max_entities:
                self.fail(v.line, f"too many entities: this build holds {self.limits.max_entities} (raise "
                          "UB_MAX_ENTITIES in ub_config.h)", None, f"entities[{i}]")
            ltes.append(self.parse_entity(i, v))
        if not arr.value:
            self.fail(arr.line, "must list at least one entity", None, "entities")
        for row in self.rows:
            row.masks = [0] * len(self.rows)
        for i, lte in enumerate(ltes):
            if lte is not None:
                self.parse_linktoentity(i, lte)

    # -- hosts, nodes
    def parse_entity_list(self, lst: JValue, fld: str, check_nodes: bool) -> tuple[str, ...]:
        if lst.kind != "array":
            self.fail(lst.line, "must be a list of entity names", None, fld)
        out: list[str] = []
        for k, v in enumerate(lst.value):
            path = f"{fld}[{k}]"
            if k == self.limits.max_local_entities:
                self.fail(v.line, f"too many hosted entities: this build holds {self.limits.max_local_entities} "
                          "(raise UB_MAX_LOCAL_ENTITIES in ub_config.h)", None, path)
            if v.kind != "string" or not _is_name(v.value, ENTITY_ID_LEN):
                self.fail(v.line, "must be an entity name", None, path)
            name = v.value.decode("ascii")
            if self.find(v.value) < 0:
                self.fail(v.line, f"no entity named '{name}' in 'entities'", None, path)
            if name in out:
                self.fail(v.line, f"entity '{name}' is listed twice", None, path)
            for node, members in (self.nodes.items() if check_nodes else ()):
                if name in members:
                    self.fail(v.line, f"entity '{name}' is already hosted by node '{node}'", None, path)
            out.append(name)
        return tuple(out)

    def parse_nodes(self, obj: JValue) -> None:
        if obj.kind != "object":
            self.fail(obj.line, "must be an object mapping node names to lists of entity names", None, "nodes")
        first_line: dict[str, int] = {}
        for key, v in obj.value:
            if not _is_name(key.value, NAME_MAX):
                self.fail(key.line, f"node names are 1 to {NAME_MAX} characters from {NAME_CHARS}", None, "nodes")
            name = key.value.decode("ascii")
            path = f"nodes.{name}"
            if name in first_line:
                self.fail(key.line, f"duplicate field (first given on line {first_line[name]})", None, path)
            if len(self.nodes) == self.limits.max_entities:
                self.fail(key.line, f"too many nodes: this build holds {self.limits.max_entities} (UB_MAX_ENTITIES)",
                          None, path)
            first_line[name] = key.line
            members = self.parse_entity_list(v, path, check_nodes=True)
            if not members:
                self.fail(v.line, "must list at least one entity", None, path)
            self.nodes[name] = members

    # -- ports
    def parse_port_param(self, v: JValue, path: str) -> str:
        text: str | None = None
        if v.kind == "string" and len(v.value) <= TEXT_MAX and b"\0" not in v.value:
            text = v.value.decode("utf-8", "replace")
        elif v.kind == "number" and _is_integer_literal(v.value) and len(v.value) <= TEXT_MAX:
            text = v.value
        elif v.kind in ("true", "false"):
            text = v.kind
        if text is None:
            self.fail(v.line, f"must be a string of up to {TEXT_MAX} characters, a whole number or true/false",
                      None, path)
        return text

    def parse_port(self, name: str, key_line: int, obj: JValue, port_path: str) -> Port:
        if obj.kind != "object":
            self.fail(obj.line, 'must be an object with a "transport" string', None, port_path)
        transport: str | None = None
        first_line: dict[str, int] = {}
        params: dict[str, str] = {}
        for key, v in obj.value:
            if not _is_word(key.value):
                self.fail(key.line, 'parameter names are lower-case words of 1 to 15 characters such as "connect"',
                          None, port_path)
            pname = key.value.decode("ascii")
            path = f"{port_path}.{pname}"
            if pname in first_line:
                self.fail(key.line, f"duplicate field (first given on line {first_line[pname]})", None, path)
            first_line[pname] = key.line
            if pname == "transport":
                if v.kind != "string" or not _is_word(v.value):
                    self.fail(v.line, 'must be a lower-case word of 1 to 15 characters such as "tcp"', None, path)
                transport = v.value.decode("ascii")
                continue
            if len(params) == self.limits.max_port_params:
                self.fail(key.line, f"too many parameters: this build holds {self.limits.max_port_params} per port "
                          "(UB_NODECFG_MAX_PORT_PARAMS)", None, path)
            params[pname] = self.parse_port_param(v, path)
        if transport is None:
            self.fail(obj.line, 'missing (for example "tcp", "udp", "serial" or "mem")', None,
                      f"{port_path}.transport")
        return Port(name, transport, params, key_line)

    def parse_ports(self, obj: JValue) -> None:
        if obj.kind != "object":
            self.fail(obj.line, 'must be an object mapping link names to {"transport": ...} (reserved for the links '
                      "issue)", None, "ports")
        for key, v in obj.value:
            if not _is_port_key(key.value):
                self.fail(key.line, 'port keys are link names, optionally qualified as "entity:link"', None, "ports")
            name = key.value.decode("ascii")
            path = f"ports.{name}"
            for port in self.ports:
                if port.name == name:
                    self.fail(key.line, f"duplicate field (first given on line {port.line})", None, path)
            if len(self.ports) == self.limits.max_ports:
                self.fail(key.line, f"too many ports: this build holds {self.limits.max_ports} (UB_NODECFG_MAX_PORTS)",
                          None, path)
            self.ports.append(self.parse_port(name, key.line, v, path))

    # -- top level
    def parse_document(self, root: JValue) -> str:
        if root.kind != "object":
            self.fail(root.line, 'the top level must be an object {"entities": [...], ...} (see '
                      "docs/config-format.md)")
        values = self.check_fields(root, TOP_FIELDS, None)
        system = values.get("system")
        if system is not None and (system.kind != "string" or not 1 <= len(system.value) <= TEXT_MAX
                                   or b"\0" in system.value):
            self.fail(system.line, f"must be a string of 1 to {TEXT_MAX} characters", None, "system")
        if "entities" not in values:
            self.fail(root.line, "missing (list every entity this node knows)", None, "entities")
        self.parse_entities(values["entities"])
        if "hosts" in values:
            self.hosts = self.parse_entity_list(values["hosts"], "hosts", check_nodes=False)
        if "nodes" in values:
            self.parse_nodes(values["nodes"])
        if "ports" in values:
            self.parse_ports(values["ports"])
        return system.value.decode("utf-8", "replace") if system is not None else ""


def _is_port_key(b: bytes) -> bool:
    entity, colon, link = b.partition(b":")
    if not colon:
        return _is_name(b, NAME_MAX)
    return _is_name(entity, ENTITY_ID_LEN) and _is_name(link, NAME_MAX)


# ---------------------------------------------------------------- schema and entry points

def _plain(v: JValue) -> Any:
    """The scanned value as ordinary Python data, for jsonschema."""
    if v.kind == "object":
        return {k.value.decode("utf-8", "replace"): _plain(x) for k, x in v.value}
    if v.kind == "array":
        return [_plain(x) for x in v.value]
    if v.kind == "string":
        return v.value.decode("utf-8", "replace")
    if v.kind == "number":
        return int(v.value) if _is_integer_literal(v.value) else float(v.value)
    return {"true": True, "false": False, "null": None}[v.kind]


def _line_of(root: JValue, path: list[Any]) -> int:
    node = root
    for part in path:
        if node.kind == "object":
            node = next((x for k, x in node.value if k.value.decode("utf-8", "replace") == part), node)
        elif node.kind == "array" and isinstance(part, int) and part < len(node.value):
            node = node.value[part]
    return node.line


def _check_schema(path: str, root: JValue) -> None:
    schema = json.loads(SCHEMA_PATH.read_text(encoding="utf-8"))
    validator = jsonschema.Draft202012Validator(schema)
    error = jsonschema.exceptions.best_match(validator.iter_errors(_plain(root)))
    if error is not None:
        where = ".".join(str(p) for p in error.absolute_path) or "(top level)"
        line = _line_of(root, list(error.absolute_path))
        raise ConfigError(f"{path}:{line}: field '{where}': {error.message} "
                          f"(schemas/config.schema.json)", path, line)


def parse_config(data: bytes, path: str = "<config>", limits: Limits = Limits()) -> Config:
    """Checks `data` (the bytes of a config file) named `path` in messages; raises ConfigError."""
    try:
        root = _Scanner(data).document()
    except _JsonError as exc:
        raise ConfigError(f"{path}:{exc.line}: {exc}", path, exc.line) from None
    checker = _Checker(path, limits)
    system = checker.parse_document(root)
    _check_schema(path, root)
    entities = tuple(Entity(r.name, tuple(r.links), tuple(r.masks), r.line) for r in checker.rows)
    return Config(path, system, entities, checker.hosts, dict(checker.nodes), tuple(checker.ports))


def load_config(path: str | Path, node: str | None = None, limits: Limits = Limits()) -> Config:
    """Reads and checks a config file; with `node`, hosts that node's entities. Raises ConfigError."""
    name = str(path)
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise ConfigError(f"{name}: cannot open: {exc.strerror}", name) from None
    config = parse_config(data, name, limits)
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
