#!/usr/bin/env python3
"""Writes stand-ins for pbrt-v4's two large generated tables when a source tree lacks them.

  gen-pbrt-v4-tables.py pmj02tables OUT.cpp   # 5 sets x 65536 points of a (0,2)-sequence
  gen-pbrt-v4-tables.py bluenoise OUT.cpp     # 48 textures of 128x128 stratified white noise

The points are the first two Sobol dimensions (a (0,2)-sequence in base 2), each set given its own
random digital shift, which keeps every elementary-interval stratification; they lack the
original's extra blue-noise optimisation. The "blue noise" textures are random permutations of
evenly spaced values: uniform marginals, but white, not blue, in space. Deterministic (fixed seed).
"""
import random
import sys

kind, out = sys.argv[1], sys.argv[2]
rng = random.Random(20260614)


def reverse32(i):
    return int(f"{i:032b}"[::-1], 2)


def sobol_dim1(i):
    # Second Sobol dimension: direction numbers of the primitive polynomial x + 1 (v_k = v_{k-1}
    # xor v_{k-1} >> 1, starting from 1 << 31), applied to the bits of i.
    v, x = 1 << 31, 0
    while i:
        if i & 1:
            x ^= v
        i >>= 1
        v ^= v >> 1
    return x


with open(out, "w") as f:
    f.write("// Generated stand-in; see gen-pbrt-v4-tables.py.\n")
    if kind == "pmj02tables":
        n_sets, n = 5, 65536
        f.write("#include <pbrt/util/pmj02tables.h>\n\nnamespace pbrt {\n")
        f.write(f"PBRT_CONST uint32_t pmj02bnSamples[{n_sets}][{n}][2] = {{\n")
        for _ in range(n_sets):
            sx, sy = rng.getrandbits(32), rng.getrandbits(32)
            f.write("{\n")
            for i in range(n):
                f.write(f"{{{reverse32(i) ^ sx:#x}u,{sobol_dim1(i) ^ sy:#x}u}},")
                if i % 8 == 7:
                    f.write("\n")
            f.write("},\n")
        f.write("};\n}  // namespace pbrt\n")
    elif kind == "bluenoise":
        n_tex, res = 48, 128
        f.write("#include <pbrt/util/bluenoise.h>\n\nnamespace pbrt {\n")
        f.write(f"PBRT_CONST uint16_t BlueNoiseTextures[{n_tex}][{res}][{res}] = {{\n")
        for _ in range(n_tex):
            values = [(k * 65536 + 32768) // (res * res) for k in range(res * res)]
            rng.shuffle(values)
            f.write("{\n")
            for y in range(res):
                f.write("{" + ",".join(map(str, values[y * res:(y + 1) * res])) + "},\n")
            f.write("},\n")
        f.write("};\n}  // namespace pbrt\n")
    else:
        sys.exit(f"unknown table {kind}")
