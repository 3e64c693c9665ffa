#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Writes the seed corpus of tests/fuzz/fuzz_boost.c into tests/fuzz/corpus/boost/ (standard library only).

Version-4 .vdm blobs (docs/model-format.md, "Boosted kind"): the shipped models/vd_boost.vdm behind the
harness's control byte (its CRC fixes, padding, a wider crop stride; the plain file is replayed by CTest
from models/ as it is), and small generated models (a 4x4 and an 8x8 crop, 5x5 convolutions as paper 003,
maps of several tensors, stumps at every map's first and last value) with their CNN from gen_cnn_seeds.pack.
Deterministic: `python3 tests/fuzz/gen_boost_seeds.py` rewrites the same bytes.
"""
import random
import struct
import sys
import zlib
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from gen_cnn_seeds import CONV5, POOL, PW, copy, pack as pack_cnn, weighted  # noqa: E402


def al4(n):
    return (n + 3) & ~3


def pack(cnn, maps, stumps, threshold=0, name=b"seed"):
    """maps: [(tensor, channel)]; stumps: [(pos, map, thr, left, right)]. Layout of the exporter: header,
    maps, stumps, CNN."""
    maps_off = 64
    st_off = maps_off + 4 * len(maps)
    cnn_off = al4(st_off + 8 * len(stumps))
    total = cnn_off + len(cnn)
    buf = bytearray(total)
    for i, (t, c) in enumerate(maps):
        struct.pack_into("<BBH", buf, maps_off + 4 * i, t, 0, c)
    for k, (pos, m, thr, lv, rv) in enumerate(stumps):
        struct.pack_into("<HBbhh", buf, st_off + 8 * k, pos, m, thr, lv, rv)
    buf[cnn_off:] = cnn
    struct.pack_into("<4sHHIIBBHIIIIi16s", buf, 0, b"VDMF", 4, 64, total, 0, 3, len(maps), len(stumps), cnn_off,
                     len(cnn), maps_off, st_off, threshold, name.ljust(16, b"\0"))
    struct.pack_into("<I", buf, 12, zlib.crc32(bytes(buf[16:])) & 0xFFFFFFFF)
    return bytes(buf)


def main():
    out = HERE / "corpus" / "boost"
    out.mkdir(parents=True, exist_ok=True)
    rng = random.Random(2026)
    seeds = {}
    shipped = (HERE.parent.parent / "models" / "vd_boost.vdm").read_bytes()
    seeds["shipped_fixcrc"] = b"\x03" + shipped
    seeds["shipped_pad_stride"] = b"\x0d" + shipped
    # 4x4 crop: conv5x5 1 -> 2, two max-pools, head (tensors 1: 4x4, 2: 2x2, 3: 1x1, 4: head 1x1).
    tiny_cnn = pack_cnn([weighted(rng, CONV5, 1, 0, 1, 2, zp=0), copy(POOL, 1, 2, 2, 0), copy(POOL, 2, 2, 2, 0),
                         weighted(rng, PW, 1, 3, 2, 3, zp=0, amin=-128)], 4, 4, 3, 4)
    tiny = pack(tiny_cnn, [(1, 0), (2, 1), (1, 1)],
                [(5, 0, 20, -100, 300), (3, 1, 126, -50, 250), (10, 2, 90, 70, -700), (0, 2, -1, 1000, -5),
                 (15, 0, -128, 32767, -32767), (0, 1, 127, 0, 0)], threshold=200)
    seeds["tiny4"] = tiny
    seeds["tiny4_fixcrc"] = b"\x03" + tiny
    seeds["tiny4_pad_stride"] = b"\x0f" + tiny
    # 8x8 crop with the stretch: conv5x5 stride 2, conv5x5, pool, head; maps of every tensor.
    cnn8 = pack_cnn([weighted(rng, CONV5, 2, 0, 1, 3), weighted(rng, CONV5, 1, 1, 3, 4), copy(POOL, 2, 4, 4, -128),
                     weighted(rng, PW, 1, 3, 4, 3, zp=0, amin=-128)], 8, 8, 3, 4, norm=(1, 10, 990, 16))
    maps8 = [(1, 2), (2, 3), (3, 0), (4, 1), (2, 0)]
    lens8 = [16, 16, 4, 4, 16]
    st8 = []
    for m, n in enumerate(lens8):
        st8 += [(0, m, rng.randint(-128, 127), rng.randint(-2000, 2000), rng.randint(-2000, 2000)),
                (n - 1, m, rng.randint(-128, 127), rng.randint(-2000, 2000), rng.randint(-2000, 2000))]
    seeds["stretch8"] = b"\x01" + pack(cnn8, maps8, st8, threshold=-37, name=b"stretch8")
    seeds["header_only"] = tiny[:64]
    for name, blob in seeds.items():
        assert len(blob) <= 12288, (name, len(blob))   # run.sh's -max_len for boost
        (out / name).write_bytes(blob)
        print(f"{name}: {len(blob)} bytes")


if __name__ == "__main__":
    main()
