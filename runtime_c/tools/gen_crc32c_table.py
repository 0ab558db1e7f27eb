#!/usr/bin/env python3
"""Prints the slicing-by-8 CRC-32C tables that runtime_c/src/codec/ub_crc32c.c embeds.

Run at development time only; the C source holds the output as a `static const`
table, so the library never fills a table lazily at run time:

    python3 runtime_c/tools/gen_crc32c_table.py

Table 0 is the classic reflected byte table for the Castagnoli polynomial
(0x82F63B78); table k advances table k-1 by one more zero byte.
"""

POLY_REFLECTED = 0x82F63B78
SLICES = 8


def byte_table() -> list[int]:
    table = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = (crc >> 1) ^ (POLY_REFLECTED if crc & 1 else 0)
        table.append(crc)
    return table


def slice_tables() -> list[list[int]]:
    tables = [byte_table()]
    for _ in range(1, SLICES):
        prev = tables[-1]
        tables.append([(prev[i] >> 8) ^ tables[0][prev[i] & 0xFF] for i in range(256)])
    return tables


def render(tables: list[list[int]]) -> str:
    lines = [f"static const uint32_t crc32c_table[{SLICES}][256] = {{"]
    for table in tables:
        lines.append("    {")
        for row in range(0, 256, 6):
            words = ", ".join(f"0x{v:08X}u" for v in table[row:row + 6])
            lines.append(f"        {words},")
        lines.append("    },")
    lines.append("};")
    return "\n".join(lines)


if __name__ == "__main__":
    print(render(slice_tables()))
