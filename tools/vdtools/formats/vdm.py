# SPDX-License-Identifier: MIT
"""The .vdm model file (docs/model-format.md): pack an integer model from
vdtools.formats.quantise into a blob and parse one back; the C library runs it through
vdtools.bindings.dbn (vd_dbn_load / vd_dbn_classify).

    blob = vdm.pack(qm)                 # bytes
    qm2 = vdm.unpack(blob)              # dict as quantise.quantise() returns
    with vdtools.bindings.dbn.CModel(blob) as m: m.classify(x_u8)  -> uint8 score(s)
"""
import struct
import zlib

import numpy as np

from vdtools.bindings.dbn import MAX_LAYERS   # VD_DBN_MAX_LAYERS
from vdtools.formats.quantise import MODE_IDS, NORM_IDS

MAGIC = b"VDMF"
VERSION = 2          # written; VERSIONS are read (a version-1 blob has no normalisation)
VERSIONS = (1, 2)
HEADER_SIZE = 64
LAYER_ENTRY_SIZE = 32
ACT_SIGMOID_Q8 = 1
NAME_LEN = 16
CRC_FROM = 16   # the CRC covers bytes [16, total_size): everything after the CRC field

# magic, version, header_size, total_size, crc, in_w, in_h, mode, activation,
# n_layers, norm_divisor, norm_offset, layer_table, flags, input_norm, norm_min_range, reserved0, name,
# reserved1
HEADER_FMT = "<4sHHIIHHBBHHhIIBBH16s8s"
LAYER_FMT = "<IIIIIIII"   # in, out, weights, bias, mult, shift, flags, reserved
assert struct.calcsize(HEADER_FMT) == HEADER_SIZE and struct.calcsize(LAYER_FMT) == LAYER_ENTRY_SIZE


def _align4(n):
    return (n + 3) & ~3


def pack(qm):
    """bytes of the .vdm blob for an integer model (quantise.quantise())."""
    layers = qm["layers"]
    if not 1 <= len(layers) <= MAX_LAYERS:
        raise ValueError(f"1..{MAX_LAYERS} layers supported, got {len(layers)}")
    name = qm.get("name", "").encode("ascii")
    if len(name) > NAME_LEN or any(c < 0x20 or c > 0x7E for c in name):
        raise ValueError("name: at most 16 printable ASCII characters")
    table = HEADER_SIZE
    pos = table + LAYER_ENTRY_SIZE * len(layers)
    entries, chunks = [], []
    for L in layers:
        w = np.ascontiguousarray(L["w"], dtype=np.int8)
        n_out, n_in = w.shape
        arrays = [w.tobytes(), np.asarray(L["bias"], dtype="<i4").tobytes(),
                  np.asarray(L["mult"], dtype="<i4").tobytes(), np.asarray(L["shift"], dtype=np.int8).tobytes()]
        offs = []
        for a in arrays:
            pos = _align4(pos)
            offs.append(pos)
            chunks.append((pos, a))
            pos += len(a)
        entries.append(struct.pack(LAYER_FMT, n_in, n_out, *offs, 0, 0))
    total = _align4(pos)
    buf = bytearray(total)
    buf[table:table + len(entries) * LAYER_ENTRY_SIZE] = b"".join(entries)
    for off, a in chunks:
        buf[off:off + len(a)] = a
    hdr = struct.pack(HEADER_FMT, MAGIC, VERSION, HEADER_SIZE, total, 0, qm["input_w"], qm["input_h"],
                      MODE_IDS[qm["mode"]], ACT_SIGMOID_Q8, len(layers), qm.get("norm_divisor", 255),
                      qm.get("norm_offset", 0), table, 0, NORM_IDS[qm.get("input_norm", "none")],
                      int(qm.get("norm_min_range", 0)), 0, name.ljust(NAME_LEN, b"\0"), bytes(8))
    buf[:HEADER_SIZE] = hdr
    struct.pack_into("<I", buf, 12, zlib.crc32(bytes(buf[CRC_FROM:])) & 0xFFFFFFFF)
    return bytes(buf)


def fix_crc(blob):
    """The blob with its CRC field recomputed (for tests that corrupt structure)."""
    buf = bytearray(blob)
    total = struct.unpack_from("<I", buf, 8)[0]
    struct.pack_into("<I", buf, 12, zlib.crc32(bytes(buf[CRC_FROM:total])) & 0xFFFFFFFF)
    return bytes(buf)


def unpack(blob):
    """Integer model dict from a blob (structure trusted only after the C loader
    or this function's few checks: magic, version, CRC)."""
    h = struct.unpack_from(HEADER_FMT, blob, 0)
    (magic, version, hsize, total, crc, in_w, in_h, mode, act, n, ndiv, noff, table, _f, norm, min_range, _r0,
     name, _r1) = h
    if magic != MAGIC or version not in VERSIONS or hsize != HEADER_SIZE:
        raise ValueError(f"not a .vdm blob of version {VERSIONS}")
    if zlib.crc32(bytes(blob[CRC_FROM:total])) & 0xFFFFFFFF != crc:
        raise ValueError(".vdm CRC mismatch")
    modes = {v: k for k, v in MODE_IDS.items()}
    layers = []
    for i in range(n):
        n_in, n_out, ow, ob, om, osh, _fl, _rs = struct.unpack_from(LAYER_FMT, blob, table + i * LAYER_ENTRY_SIZE)
        layers.append({
            "w": np.frombuffer(blob, np.int8, n_in * n_out, ow).reshape(n_out, n_in),
            "bias": np.frombuffer(blob, "<i4", n_out, ob).astype(np.int32),
            "mult": np.frombuffer(blob, "<i4", n_out, om).astype(np.int32),
            "shift": np.frombuffer(blob, np.int8, n_out, osh),
        })
    norms = {v: k for k, v in NORM_IDS.items()}
    return {"mode": modes[mode], "input_w": in_w, "input_h": in_h, "norm_divisor": ndiv,
            "norm_offset": noff, "name": name.rstrip(b"\0").decode("ascii"), "layers": layers,
            "input_norm": norms[norm], "norm_min_range": min_range, "version": version}
