"""Writes a synthetic flight-software header with N directory instances (bench figure 5).

    python bench/tools/gen_synth.py N OUT.h

Twenty struct types of 4-12 scalar fields (every integer width, float, double), one nested
struct and one array field each, and N `extern` instances spread over them. Names are unique
under the paper's first-8 + last-8 character rule.
"""
import sys

SCALARS = ["uint8_t", "int16_t", "uint32_t", "int64_t", "float", "double", "uint16_t", "int32_t"]


def header(n: int) -> str:
    out = ["#ifndef SYNTH_H", "#define SYNTH_H", "#include <stdint.h>", "",
           "typedef struct synthVec { double x; double y; double z; } synthVec_t;", ""]
    for t in range(20):
        fields = [f"    {SCALARS[(t + k) % len(SCALARS)]} f{k};" for k in range(4 + t % 9)]
        fields += ["    synthVec_t v;", f"    float a[{2 + t % 5}];"]
        out += [f"typedef struct synthType{t:02d} {{", *fields, f"}} synthType{t:02d}_t;", ""]
    out += [f"extern synthType{i % 20:02d}_t s{i:07d}Dir{i:07d};" for i in range(n)]
    out += ["", "#endif", ""]
    return "\n".join(out)


if __name__ == "__main__":
    with open(sys.argv[2], "w", encoding="utf-8") as f:
        f.write(header(int(sys.argv[1])))
