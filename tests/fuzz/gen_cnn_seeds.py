#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Writes the seed corpus of tests/fuzz/fuzz_cnn.c into tests/fuzz/corpus/cnn/ (standard library only).

Small valid version-3 .vdm blobs (docs/model-format.md, "CNN kind") covering every op, both output
strides, the stretch, ReLU clamps, positive shifts and -128 weights, each under 4 KB (run.sh's
-max_len), some prefixed with the harness's control byte (bit 0: fix the CRC, 1: padding, 2: double
width). Deterministic: `python3 tests/fuzz/gen_cnn_seeds.py` rewrites the same bytes.
"""
import random
import struct
import zlib
from pathlib import Path

CONV, DW, PW, POOL, UP, CAT, CONV5 = 1, 2, 3, 4, 5, 6, 7


def al4(n):
    return (n + 3) & ~3


def pack(layers, in_w, in_h, n_ch, out_stride, norm=(0, 0, 0, 0), thr=0, max_peaks=16, name=b"seed", rng=None):
    """layers: (op, stride, in, in2, cin, cout, zp, amin, amax, arrays) with arrays (w, bias, mult, shift)
    lists or None."""
    n = len(layers)
    pos = 128 + 32 * n
    entries, chunks = [], []
    for (op, stride, a, b, cin, cout, zp, amin, amax, arr) in layers:
        offs = [0, 0, 0, 0]
        if arr is not None:
            w, bias, mult, shift = arr
            data = [struct.pack(f"<{len(w)}b", *w), struct.pack(f"<{cout}i", *bias),
                    struct.pack(f"<{cout}i", *mult), struct.pack(f"<{cout}b", *shift)]
            for j, d in enumerate(data):
                pos = al4(pos)
                offs[j] = pos
                chunks.append((pos, d))
                pos += len(d)
        entries.append(struct.pack("<BBBBHHbbbBIIIII", op, stride, a, b, cin, cout, zp, amin, amax, 0, *offs, 0))
    dec = al4(pos)
    table = []
    for ch in range(n_ch):
        for i in range(256):
            table.append(i * 128 if ch == 0 else i * 64 if ch <= 2 else min(512, 4 * i - 256))
    chunks.append((dec, struct.pack(f"<{len(table)}i", *table)))
    total = al4(dec + 4 * len(table))
    buf = bytearray(total)
    buf[128:128 + 32 * n] = b"".join(entries)
    for off, d in chunks:
        buf[off:off + len(d)] = d
    mode, lo, hi, mr = norm
    struct.pack_into("<4sHHIIBBBBHHHHHbBIIbBHI16s", buf, 0, b"VDMF", 3, 128, total, 0, 2, mode, n, n_ch, in_w,
                     in_h, lo, hi, mr, -128, out_stride, 128, dec, thr, 0, max_peaks, 0, name.ljust(16, b"\0"))
    struct.pack_into("<I", buf, 12, zlib.crc32(bytes(buf[16:])) & 0xFFFFFFFF)
    return bytes(buf)


def arrays(rng, op, cin, cout, shift=(-9, -7), wmin=-127):
    k = {CONV: 9 * cin * cout, DW: 9 * cout, PW: cin * cout, CONV5: 25 * cin * cout}[op]
    w = [rng.randint(wmin, 127) for _ in range(k)]
    bias = [rng.randint(-500, 500) for _ in range(cout)]
    mult = [rng.randint(1 << 30, (1 << 31) - 1) for _ in range(cout)]
    sh = [rng.randint(*shift) for _ in range(cout)]
    return w, bias, mult, sh


def weighted(rng, op, stride, a, cin, cout, zp=-128, amin=None, **kw):
    return (op, stride, a, 0, cin, cout, zp, zp if amin is None else amin, 127, arrays(rng, op, cin, cout, **kw))


def copy(op, a, cin, cout, zp, b=0):
    return (op, 1, a, b, cin, cout, zp, -128, 127, None)


def main():
    out = Path(__file__).resolve().parent / "corpus" / "cnn"
    out.mkdir(parents=True, exist_ok=True)
    rng = random.Random(2024)
    seeds = {}
    # pw, max-pools, head: the smallest chain (8x8, A = 4).
    seeds["chain_n3"] = pack([weighted(rng, PW, 1, 0, 1, 2), copy(POOL, 1, 2, 2, -128), copy(POOL, 2, 2, 2, -128),
                              weighted(rng, PW, 1, 3, 2, 3, zp=0, amin=-128)], 8, 8, 3, 4)
    # Every op and a skip, with the percentile stretch.
    allops = pack([weighted(rng, CONV, 2, 0, 1, 4, zp=2), weighted(rng, DW, 1, 1, 4, 4, zp=-1, amin=-128),
                   weighted(rng, PW, 1, 2, 4, 6, zp=2), copy(POOL, 3, 6, 6, 2), copy(UP, 4, 6, 6, 2),
                   copy(CAT, 5, 6, 10, 2, b=1), weighted(rng, DW, 2, 6, 10, 10, zp=0),
                   weighted(rng, PW, 1, 7, 10, 3, zp=0, amin=-128)], 8, 8, 3, 4, norm=(1, 20, 980, 10), thr=-5)
    seeds["allops_n3"] = allops
    seeds["allops_n3_fixcrc"] = b"\x01" + allops
    seeds["allops_n3_pad_wide"] = b"\x07" + allops
    # Full 3x3 convolutions (stride 1 and 2), head at stride 8 (A = 8).
    seeds["stride8_n3"] = pack([weighted(rng, CONV, 1, 0, 1, 3), copy(POOL, 1, 3, 3, -128),
                                weighted(rng, CONV, 2, 2, 3, 4), weighted(rng, CONV, 1, 3, 4, 5),
                                copy(POOL, 4, 5, 5, -128), weighted(rng, PW, 1, 5, 5, 3, zp=0, amin=-128)],
                               16, 8, 3, 8, max_peaks=3)
    # Positive shifts (saturating left shift), -128 weights (no int16 pairs in the depthwise), 17 channels
    # (kernel tails), narrow clamps.
    seeds["shifts_tails"] = b"\x05" + pack(
        [weighted(rng, CONV, 2, 0, 1, 17, shift=(-2, 7), wmin=-128), weighted(rng, DW, 2, 1, 17, 17, wmin=-128),
         (PW, 1, 2, 0, 17, 3, 3, -20, 40, arrays(rng, PW, 17, 3, shift=(-31, 7), wmin=-128))], 4, 4, 3, 4)
    # 5x5 convolutions (op 7, padding 2; paper 003's network) at stride 2 and 1 (drawn last: the
    # seeds above keep their bytes).
    seeds["conv5x5_n3"] = pack([weighted(rng, CONV5, 2, 0, 1, 3), weighted(rng, CONV5, 1, 1, 3, 4),
                                copy(POOL, 2, 4, 4, -128), weighted(rng, PW, 1, 3, 4, 3, zp=0, amin=-128)],
                               8, 8, 3, 4)
    seeds["header_only"] = seeds["chain_n3"][:128]
    for name, blob in seeds.items():
        assert len(blob) < 4096, (name, len(blob))
        (out / name).write_bytes(blob)
        print(f"{name}: {len(blob)} bytes")


if __name__ == "__main__":
    main()
