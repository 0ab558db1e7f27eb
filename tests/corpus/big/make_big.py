#!/usr/bin/env python3
"""Writes a large synthetic flight-software tree: N instances of N/4 struct types in ten subsystem
headers (the selftest-at-scale corpus of issue #13; bench figure 5 at 1,000 and 10,000 instances).

    python tests/corpus/big/make_big.py OUTDIR [--instances 1000] [--types 250]

Deterministic (no randomness, no clock): the same arguments always give the same bytes. Each type
mixes what real telemetry and tables hold: every integer width, float/double, bool, enums,
bitfields, fixed arrays (1-D and 2-D), nested common types (time tag, vector, quaternion), a
`char` name (a string: skipped by default), a pointer and a union (skipped). Instances are plain
`extern` declarations and arrays of structs; names are unique under the paper's 8+8 ID rule.
Writes OUTDIR/include/<subsystem>.h, OUTDIR/include/big_common.h and OUTDIR/big_all.h (one
header that includes them all).
"""

from __future__ import annotations

import argparse
from pathlib import Path

SUBSYSTEMS = ["nav", "gnc", "pwr", "com", "pay", "thm", "adc", "prp", "fdr", "sch"]
SCALARS = ["uint8_t", "int8_t", "uint16_t", "int16_t", "uint32_t", "int32_t", "uint64_t", "int64_t",
           "float", "double", "bool"]
WORDS = ["state", "status", "cmd", "cfg", "limits", "stats", "est", "meas", "hk", "tbl"]

COMMON = """\
/* Common types of the synthetic tree (tests/corpus/big/make_big.py). */
#ifndef BIG_COMMON_H
#define BIG_COMMON_H

#include <stdbool.h>
#include <stdint.h>

typedef struct { uint32_t seconds; uint32_t subseconds; } bigTime_t;
typedef struct bigVec3 { float x, y, z; } bigVec3_t;
typedef struct bigQuat { double w, x, y, z; } bigQuat_t;
typedef enum { BIG_MODE_OFF = 0, BIG_MODE_SAFE = 1, BIG_MODE_NOMINAL = 2, BIG_MODE_TEST = 7 } bigMode_t;
enum bigHealth { BIG_HEALTH_OK, BIG_HEALTH_WARN, BIG_HEALTH_FAIL = -1 };

#endif
"""


SIZES = {"uint8_t": 1, "int8_t": 1, "uint16_t": 2, "int16_t": 2, "uint32_t": 4, "int32_t": 4, "uint64_t": 8,
         "int64_t": 8, "float": 4, "double": 8, "bool": 1}
BUDGET = 900  # packed bytes per type, strings included: every type fits the 1024-byte payload limit


def field_lines(sub: str, t: int) -> list[str]:
    """The members of type t: 6 to 40 of them, a deterministic mix, within BUDGET packed bytes."""
    lines = ["    bigTime_t time;"]
    used = 8
    n = 6 + (t * 7) % 35
    for k in range(n):
        kind = (t * 13 + k * 5) % 16
        scalar = SCALARS[(t + k) % len(SCALARS)]
        name = f"m{k:02d}"
        if kind < 8:
            more, size = [f"    {scalar} {name};"], SIZES[scalar]
        elif kind == 8:
            count = 2 + (t + k) % 7
            more, size = [f"    {scalar} {name}[{count}];"], SIZES[scalar] * count
        elif kind == 9:
            rows, cols = 2 + k % 3, 1 + t % 4
            more, size = [f"    int16_t {name}[{rows}][{cols}];"], 2 * rows * cols
        elif kind == 10:
            more, size = [f"    bigVec3_t {name};"], 12
        elif kind == 11:
            more, size = ([f"    bigQuat_t {name};"], 32) if t % 2 else ([f"    bigVec3_t {name}[{1 + k % 4}];"], 12 * (1 + k % 4))
        elif kind == 12:
            more, size = [f"    bigMode_t {name};" if k % 2 else f"    enum bigHealth {name};"], 4
        elif kind == 13:
            more = [f"    uint16_t {name}a : {1 + k % 7};", f"    uint16_t {name}b : {1 + t % 9};",
                    f"    int32_t {name}c : {2 + (t + k) % 20};", f"    bool {name}d : 1;"]
            size = 9
        elif kind == 14:
            more, size = [f"    uint8_t {name}[{8 << (t % 4)}];"], 8 << (t % 4)
        else:
            more, size = [f"    char {name}[{8 + (t + k) % 24}];"], 8 + (t + k) % 24
        if used + size > BUDGET:
            break
        lines += more
        used += size
    if t % 7 == 3 and used + 12 * 24 <= BUDGET:
        lines.append(f"    bigVec3_t track[{16 + t % 9}];")  # arrays of structs: tables, histories
        used += 12 * 24
    if t % 11 == 5 and used + 2 * 200 <= BUDGET:
        lines.append(f"    uint16_t words[{120 + t % 80}];")  # a command buffer / memory dump
    if t % 3 == 0:
        lines.append(f"    const struct {sub}Type{t:04d} *next;")
    if t % 4 == 1:
        lines.append("    union { uint32_t word; float value; } raw;")
    return lines


def instances_for(sub: str, t: int, per_type: int) -> list[str]:
    """`per_type` instances of type t: scalars and one array of structs."""
    tname = f"{sub}Type{t:04d}_t"
    out = []
    j = 0
    while j < per_type:
        word = WORDS[(t + j) % len(WORDS)]
        left = per_type - j
        if j == 0 and left >= 2 and t % 5 == 0:
            n = min(left, 4 if t % 10 == 0 else 2)
            out.append(f"extern {tname} {sub}{t:04d}{j}_{word}Tbl{t:04d}{j}[{n}];")
            j += n
        else:
            out.append(f"extern {tname} {sub}{t:04d}{j}_{word}{t:04d}{j};")
            j += 1
    return out


def write_tree(outdir: Path, instances: int, types: int) -> list[Path]:
    if instances < types:
        raise SystemExit("make_big: need at least one instance per type")
    inc = outdir / "include"
    inc.mkdir(parents=True, exist_ok=True)
    written = [inc / "big_common.h"]
    written[0].write_text(COMMON)
    per_sub: dict[str, list[int]] = {s: [] for s in SUBSYSTEMS}
    for t in range(types):
        per_sub[SUBSYSTEMS[t % len(SUBSYSTEMS)]].append(t)
    left = instances
    for idx, sub in enumerate(SUBSYSTEMS):
        guard = f"BIG_{sub.upper()}_H"
        lines = [f"/* Subsystem '{sub}' of the synthetic tree (tests/corpus/big/make_big.py). */",
                 f"#ifndef {guard}", f"#define {guard}", "", '#include "big_common.h"', ""]
        decls: list[str] = []
        for t in per_sub[sub]:
            lines += [f"typedef struct {sub}Type{t:04d} {{", *field_lines(sub, t), f"}} {sub}Type{t:04d}_t;", ""]
            share = instances // types + (1 if t < instances % types else 0)
            decls += instances_for(sub, t, share)
            left -= share
        lines += decls + ["", "#endif", ""]
        path = inc / f"big_{sub}.h"
        path.write_text("\n".join(lines))
        written.append(path)
    assert left == 0
    top = outdir / "big_all.h"
    top.write_text("/* Every subsystem of the synthetic tree. */\n#ifndef BIG_ALL_H\n#define BIG_ALL_H\n"
                   + "".join(f'#include "big_{s}.h"\n' for s in SUBSYSTEMS) + "#endif\n")
    return [top, *written]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("outdir", type=Path)
    ap.add_argument("--instances", type=int, default=1000)
    ap.add_argument("--types", type=int, default=None, help="default: instances / 4")
    args = ap.parse_args()
    write_tree(args.outdir, args.instances, args.types or max(1, args.instances // 4))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
