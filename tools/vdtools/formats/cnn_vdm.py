# SPDX-License-Identifier: MIT
"""The CNN kind of the .vdm model file (format version 3, docs/model-format.md):
pack an integer CNN description into a blob, parse one back, validate it the way vd_cnn_load does,
write it as a const C array for flash, and run it through the C library (vd_cnn_*, vdtools.bindings.cnn).

A description ("desc") is a plain dict:
    input_w, input_h            nominal network input size (multiples of the model's alignment A)
    input_norm                  0 none (q = pixel - 128), 1 per-frame percentile stretch,
                                2 per-frame histogram equalisation
    norm_lo_permille, norm_hi_permille, norm_min_range   (all 0 unless input_norm is 1)
    input_zp                    -128
    out_stride                  4 or 8 (the downsample factor of the head tensor)
    out_channels                3 or 5 (channels of the head tensor)
    score_threshold_q           default int8 heatmap threshold of decoding
    max_peaks                   default top-K of decoding, 1..1024
    name                        <= 16 printable ASCII characters
    layers                      list of dicts, layer i produces tensor i+1 (tensor 0 is the input):
        op (CONV3X3..CONCAT or its name), stride, in, in2, cin, cout, out_zp, act_min, act_max,
        w      int8   CONV3X3 [cout][3][3][cin], DW3X3 [3][3][cout], PW1X1 [cout][cin],
                      CONV5X5 [cout][5][5][cin] (op 7, padding 2: paper 003's network), else None
        bias   int32 [cout], mult int32 [cout] in [2^30, 2^31-1], shift int8 [cout] in [-31, 7]
               (None for MAXPOOL2 / UPSAMPLE2 / CONCAT)
    table                       int32 [out_channels][256] decode table, indexed by int8 value + 128

    blob = pack(desc)            # bytes; ValueError when vd_cnn_load would reject the description
    desc = unpack(blob)          # ValueError when the blob is malformed
    write_c_array(blob, "vd_cnn_x", "models")   # models/vd_cnn_x.vdm, vd_cnn_x_vdm.c, vd_cnn_x_vdm.h
    m = vdtools.bindings.cnn.CModel(blob); head = m.run(img_u8); boxes = m.decode(head, fw, fh)   # the C library (ctypes)
"""
import struct
import zlib
from pathlib import Path

import numpy as np

from vdtools.bindings.cnn import MAX_LAYERS, MAX_PEAKS   # VD_CNN_MAX_LAYERS, VD_CNN_MAX_PEAKS
from vdtools.formats.vdm import fix_crc  # noqa: F401  (one container, one CRC rule; V.fix_crc for the tests)

MAGIC = b"VDMF"
VERSION = 3
HEADER_SIZE = 128
LAYER_ENTRY_SIZE = 32
KIND_CNN = 2
MAX_CHANNELS = 1024
MAX_F = 1024             # largest downsample factor of any tensor
MAX_SIDE = 4096
NAME_LEN = 16
CRC_FROM = 16            # the CRC covers bytes [16, total_size)
INT32_MAX = (1 << 31) - 1
MULT_MIN, MULT_MAX = 1 << 30, INT32_MAX
SHIFT_MIN, SHIFT_MAX = -31, 7
SCORE_MAX = 32768        # Q15 1.0
SIZE_MAX_Q8 = 4096 * 256
OFF_MIN_Q8, OFF_MAX_Q8 = -256, 512

CONV3X3, DW3X3, PW1X1, MAXPOOL2, UPSAMPLE2, CONCAT, CONV5X5 = 1, 2, 3, 4, 5, 6, 7
OP_NAMES = {CONV3X3: "conv3x3", DW3X3: "dw3x3", PW1X1: "pw1x1", MAXPOOL2: "maxpool2",
            UPSAMPLE2: "upsample2", CONCAT: "concat", CONV5X5: "conv5x5"}
OP_IDS = {v: k for k, v in OP_NAMES.items()}
WEIGHTED = (CONV3X3, DW3X3, PW1X1, CONV5X5)
STRIDED = (CONV3X3, DW3X3, CONV5X5)   # ops with stride 1 or 2

# magic, version, header_size, total_size, crc, kind, input_norm, n_layers, out_channels, input_w,
# input_h, norm_lo_permille, norm_hi_permille, norm_min_range, input_zp, out_stride, layer_table,
# decode_table, score_threshold_q, reserved0, max_peaks, flags, name, reserved1
HEADER_FMT = "<4sHHIIBBBBHHHHHbBIIbBHI16s64s"
# op, stride, in, in2, cin, cout, out_zp, act_min, act_max, reserved0, weights, bias, mult, shift, reserved1
LAYER_FMT = "<BBBBHHbbbBIIIII"
assert struct.calcsize(HEADER_FMT) == HEADER_SIZE and struct.calcsize(LAYER_FMT) == LAYER_ENTRY_SIZE

HEADER_KEYS = ("input_w", "input_h", "input_norm", "norm_lo_permille", "norm_hi_permille", "norm_min_range",
               "input_zp", "out_stride", "out_channels", "score_threshold_q", "max_peaks", "name")


def op_id(op):
    """The op number (1..7) of an op given by number or name ("conv3x3", ...)."""
    if isinstance(op, str):
        if op.lower() not in OP_IDS:
            raise ValueError(f"unknown op {op!r} (one of {sorted(OP_IDS)})")
        return OP_IDS[op.lower()]
    return int(op)


def k_of(op, cin):
    """Number of multiply-adds per output value (the K of the accumulator bound); 0 for ops 4-6."""
    return {CONV3X3: 9 * cin, DW3X3: 9, PW1X1: cin, CONV5X5: 25 * cin}.get(op, 0)


def bias_bound(op, cin):
    """Largest |bias| vd_cnn_load accepts: INT32_MAX - K * 128 * 255 (weights may be -128)."""
    return INT32_MAX - k_of(op, cin) * 128 * 255


def weight_shape(op, cin, cout):
    return {CONV3X3: (cout, 3, 3, cin), DW3X3: (3, 3, cout), PW1X1: (cout, cin),
            CONV5X5: (cout, 5, 5, cin)}.get(op)


def weights_from_oihw(w, op):
    """Weights in PyTorch's (cout, cin / groups, kh, kw) layout -> op's .vdm layout (weight_shape)."""
    if op in (CONV3X3, CONV5X5):
        return np.ascontiguousarray(w.transpose(0, 2, 3, 1))     # OHWI
    if op == DW3X3:
        return np.ascontiguousarray(w[:, 0].transpose(1, 2, 0))  # HWC
    return np.ascontiguousarray(w[:, :, 0, 0])                   # (cout, cin)


def _int_array(v, dtype, lo, hi, what, shape=None):
    """v as a numpy array of dtype after checking every value lies in [lo, hi] (no silent wrap)."""
    if v is None:
        raise ValueError(f"{what}: missing")
    a = np.asarray(v)
    if a.dtype.kind not in "iub":
        raise ValueError(f"{what}: integer array expected, got {a.dtype}")
    if shape is not None and a.size != int(np.prod(shape)):
        raise ValueError(f"{what}: {a.size} values, expected {int(np.prod(shape))} (shape {shape})")
    a64 = a.astype(np.int64)
    if a64.size and (a64.min() < lo or a64.max() > hi):
        raise ValueError(f"{what}: values must lie in [{lo}, {hi}] (found {a64.min()}..{a64.max()})")
    a = a64.astype(dtype)
    return a.reshape(shape) if shape is not None else a


def _int(d, key, lo, hi, where=""):
    if key not in d:
        raise ValueError(f"{where}{key}: missing")
    v = d[key]
    try:
        iv = int(v)
    except (TypeError, ValueError):
        raise ValueError(f"{where}{key}: integer expected, got {v!r}") from None
    if iv != v or not lo <= iv <= hi:
        raise ValueError(f"{where}{key} = {v!r} outside [{lo}, {hi}]")
    return iv


def validate(desc):
    """Checks desc like vd_cnn_load checks a blob; returns a normalised copy (ints, numpy arrays in the
    canonical shapes, op numbers) or raises ValueError naming the first offending field."""
    if not isinstance(desc, dict):
        raise ValueError("desc must be a dict")
    out = {}
    norm = out["input_norm"] = _int(desc, "input_norm", 0, 2)
    if norm == 1:
        lo = out["norm_lo_permille"] = _int(desc, "norm_lo_permille", 0, 999)
        out["norm_hi_permille"] = _int(desc, "norm_hi_permille", lo + 1, 1000)
        out["norm_min_range"] = _int(desc, "norm_min_range", 1, 255)
    else:
        for k in ("norm_lo_permille", "norm_hi_permille", "norm_min_range"):
            out[k] = _int(dict(desc, **{k: desc.get(k, 0)}), k, 0, 0)
    out["input_zp"] = _int(dict(desc, input_zp=desc.get("input_zp", -128)), "input_zp", -128, -128)
    out["out_stride"] = _int(desc, "out_stride", 4, 8)
    if out["out_stride"] not in (4, 8):
        raise ValueError(f"out_stride must be 4 or 8, not {out['out_stride']}")
    out["out_channels"] = _int(desc, "out_channels", 3, 5)
    if out["out_channels"] not in (3, 5):
        raise ValueError(f"out_channels must be 3 or 5, not {out['out_channels']}")
    out["input_w"] = _int(desc, "input_w", 1, MAX_SIDE)
    out["input_h"] = _int(desc, "input_h", 1, MAX_SIDE)
    out["score_threshold_q"] = _int(desc, "score_threshold_q", -128, 127)
    out["max_peaks"] = _int(desc, "max_peaks", 1, MAX_PEAKS)
    name = desc.get("name", "")
    name = name.decode("ascii") if isinstance(name, bytes) else str(name)
    if len(name) > NAME_LEN or any(not 0x20 <= ord(c) <= 0x7E for c in name):
        raise ValueError(f"name {name!r}: at most {NAME_LEN} printable ASCII characters")
    out["name"] = name

    layers = desc.get("layers")
    if not isinstance(layers, (list, tuple)) or not 1 <= len(layers) <= MAX_LAYERS:
        raise ValueError(f"layers: a list of 1..{MAX_LAYERS} layers expected")
    chans, fs, zps = [1], [1], [out["input_zp"]]
    nl = []
    for i, L in enumerate(layers):
        where = f"layer {i}: "
        op = op_id(L.get("op"))
        if op not in OP_NAMES:
            raise ValueError(f"{where}unknown op {op}")
        n = {"op": op}
        n["stride"] = _int(L, "stride", 1, 2 if op in STRIDED else 1, where)
        n["in"] = _int(L, "in", 0, i, where)
        n["in2"] = _int(dict(L, in2=L.get("in2", 0)), "in2", 0, i if op == CONCAT else 0, where)
        n["cin"] = _int(L, "cin", 1, MAX_CHANNELS, where)
        n["cout"] = _int(L, "cout", 1, MAX_CHANNELS, where)
        n["out_zp"] = _int(L, "out_zp", -128, 127, where)
        n["act_min"] = _int(L, "act_min", -128, 127, where)
        n["act_max"] = _int(L, "act_max", n["act_min"], 127, where)
        a, cin, cout = n["in"], n["cin"], n["cout"]
        if cin != chans[a]:
            raise ValueError(f"{where}cin {cin} != {chans[a]} channels of tensor {a}")
        f = fs[a]
        if op in STRIDED:
            f *= n["stride"]
        elif op == MAXPOOL2:
            f *= 2
        elif op == UPSAMPLE2:
            if f < 2:
                raise ValueError(f"{where}UPSAMPLE2 of tensor {a} at full input resolution (f = 1)")
            f //= 2
        if f > MAX_F:
            raise ValueError(f"{where}downsample factor {f} > {MAX_F}")
        if op in (DW3X3, MAXPOOL2, UPSAMPLE2) and cout != cin:
            raise ValueError(f"{where}cout {cout} must equal cin {cin} for {OP_NAMES[op]}")
        if op in (MAXPOOL2, UPSAMPLE2, CONCAT):
            if n["act_min"] != -128 or n["act_max"] != 127:
                raise ValueError(f"{where}{OP_NAMES[op]} needs act_min -128 and act_max 127")
            if n["out_zp"] != zps[a]:
                raise ValueError(f"{where}out_zp {n['out_zp']} must equal the zero point {zps[a]} of tensor {a}")
        if op == CONCAT:
            b = n["in2"]
            if cout != cin + chans[b]:
                raise ValueError(f"{where}CONCAT cout {cout} != cin {cin} + {chans[b]} channels of tensor {b}")
            if fs[b] != fs[a]:
                raise ValueError(f"{where}CONCAT of tensors {a} (f {fs[a]}) and {b} (f {fs[b]}): sizes differ")
            if zps[b] != zps[a]:
                raise ValueError(f"{where}CONCAT zero points differ ({zps[a]} vs {zps[b]})")
        if op in WEIGHTED:
            n["w"] = _int_array(L.get("w"), np.int8, -128, 127, where + "w", weight_shape(op, cin, cout))
            bb = bias_bound(op, cin)
            n["bias"] = _int_array(L.get("bias"), np.int32, -bb, bb, where + "bias", (cout,))
            n["mult"] = _int_array(L.get("mult"), np.int32, MULT_MIN, MULT_MAX, where + "mult", (cout,))
            n["shift"] = _int_array(L.get("shift"), np.int8, SHIFT_MIN, SHIFT_MAX, where + "shift", (cout,))
        else:
            for k in ("w", "bias", "mult", "shift"):
                if L.get(k) is not None and np.asarray(L[k]).size:
                    raise ValueError(f"{where}{OP_NAMES[op]} has no {k} array")
                n[k] = None
        chans.append(cout)
        fs.append(f)
        zps.append(n["out_zp"])
        nl.append(n)
    out["layers"] = nl
    if chans[-1] != out["out_channels"]:
        raise ValueError(f"the last layer has {chans[-1]} channels, out_channels is {out['out_channels']}")
    if fs[-1] != out["out_stride"]:
        raise ValueError(f"the last tensor's downsample factor {fs[-1]} != out_stride {out['out_stride']}")
    align = max(fs)
    for k in ("input_w", "input_h"):
        if out[k] % align:
            raise ValueError(f"{k} {out[k]} is not a multiple of the model's alignment {align}")

    t = _int_array(desc.get("table"), np.int32, -(1 << 31), INT32_MAX, "table", (out["out_channels"], 256))
    if t[0].min() < 0 or t[0].max() > SCORE_MAX or np.any(np.diff(t[0].astype(np.int64)) < 0):
        raise ValueError("table[0] (score): must be non-decreasing Q15 values in [0, 32768]")
    if t[1:3].min() < 0 or t[1:3].max() > SIZE_MAX_Q8:
        raise ValueError(f"table[1..2] (box size): Q8 values in [0, {SIZE_MAX_Q8}]")
    if out["out_channels"] == 5 and (t[3:5].min() < OFF_MIN_Q8 or t[3:5].max() > OFF_MAX_Q8):
        raise ValueError(f"table[3..4] (offset): Q8 values in [{OFF_MIN_Q8}, {OFF_MAX_Q8}]")
    out["table"] = t
    return out


def alignment(desc):
    """A: the largest downsample factor over all tensors (run sizes must be multiples of it)."""
    return max(tensor_factors(desc))


def tensor_factors(desc):
    """Downsample factor f of every tensor 0..L (desc assumed valid)."""
    fs = [1]
    for L in desc["layers"]:
        op, f = op_id(L["op"]), fs[L["in"]]
        if op in STRIDED:
            f *= int(L["stride"])
        elif op == MAXPOOL2:
            f *= 2
        elif op == UPSAMPLE2:
            f //= 2
        fs.append(f)
    return fs


def tensor_zps(desc):
    """Zero point of every tensor 0..L."""
    return [int(desc.get("input_zp", -128))] + [int(L["out_zp"]) for L in desc["layers"]]


def _align4(n):
    return (n + 3) & ~3


def pack(desc, check=True):
    """bytes of the version-3 .vdm blob of desc. With check (default) desc is validated first
    (ValueError as vd_cnn_load would reject it); check=False packs a possibly invalid desc as is
    (for loader tests), still requiring the arrays to fit their fields."""
    d = validate(desc) if check else desc
    layers = d["layers"]
    table_off = HEADER_SIZE
    pos = table_off + LAYER_ENTRY_SIZE * len(layers)
    entries, chunks = [], []
    for L in layers:
        op = op_id(L["op"])
        offs = [0, 0, 0, 0]
        if L.get("w") is not None:
            arrays = [np.asarray(L["w"]).astype(np.int8).tobytes(), np.asarray(L["bias"]).astype("<i4").tobytes(),
                      np.asarray(L["mult"]).astype("<i4").tobytes(), np.asarray(L["shift"]).astype(np.int8).tobytes()]
            for j, a in enumerate(arrays):
                pos = _align4(pos)
                offs[j] = pos
                chunks.append((pos, a))
                pos += len(a)
        entries.append(struct.pack(LAYER_FMT, op, int(L["stride"]), int(L["in"]), int(L.get("in2", 0)),
                                   int(L["cin"]), int(L["cout"]), int(L["out_zp"]), int(L["act_min"]),
                                   int(L["act_max"]), 0, *offs, 0))
    pos = _align4(pos)
    dec_off = pos
    table = np.asarray(d["table"]).astype("<i4").tobytes()
    chunks.append((dec_off, table))
    total = _align4(dec_off + len(table))
    buf = bytearray(total)
    buf[table_off:table_off + len(entries) * LAYER_ENTRY_SIZE] = b"".join(entries)
    for off, a in chunks:
        buf[off:off + len(a)] = a
    name = str(d.get("name", "")).encode("ascii")
    hdr = struct.pack(HEADER_FMT, MAGIC, VERSION, HEADER_SIZE, total, 0, KIND_CNN, int(d["input_norm"]),
                      len(layers), int(d["out_channels"]), int(d["input_w"]), int(d["input_h"]),
                      int(d.get("norm_lo_permille", 0)), int(d.get("norm_hi_permille", 0)),
                      int(d.get("norm_min_range", 0)), int(d.get("input_zp", -128)), int(d["out_stride"]),
                      table_off, dec_off, int(d["score_threshold_q"]), 0, int(d["max_peaks"]), 0,
                      name.ljust(NAME_LEN, b"\0"), bytes(64))
    buf[:HEADER_SIZE] = hdr
    struct.pack_into("<I", buf, 12, zlib.crc32(bytes(buf[CRC_FROM:])) & 0xFFFFFFFF)
    return bytes(buf)



def unpack(blob, check=True):
    """desc of a version-3 CNN blob; ValueError when the container is malformed (magic, version,
    sizes, CRC, kind, reserved fields, array offsets) or, with check, the model is invalid."""
    blob = bytes(blob)
    if len(blob) < HEADER_SIZE:
        raise ValueError(f"blob of {len(blob)} bytes is shorter than the {HEADER_SIZE}-byte header")
    (magic, version, hsize, total, crc, kind, norm, n, cout, in_w, in_h, lo, hi, min_range, zp, ostride, table_off,
     dec_off, thr, r0, max_peaks, flags, name, r1) = struct.unpack_from(HEADER_FMT, blob, 0)
    if magic != MAGIC:
        raise ValueError("not a .vdm blob (magic)")
    if version != VERSION:
        raise ValueError(f"format version {version}: the CNN kind is version {VERSION}")
    if hsize != HEADER_SIZE:
        raise ValueError(f"header_size {hsize} != {HEADER_SIZE}")
    if total % 4 or total < HEADER_SIZE or total > len(blob):
        raise ValueError(f"total_size {total} (blob has {len(blob)} bytes)")
    if zlib.crc32(blob[CRC_FROM:total]) & 0xFFFFFFFF != crc:
        raise ValueError(".vdm CRC mismatch")
    if kind != KIND_CNN:
        raise ValueError(f"kind {kind} is not the CNN kind ({KIND_CNN})")
    if r0 or flags or any(r1):
        raise ValueError("reserved header fields / flags must be 0")
    if not 1 <= n <= MAX_LAYERS:
        raise ValueError(f"n_layers {n} outside 1..{MAX_LAYERS}")
    nb = name.split(b"\0", 1)
    if len(nb) == 2 and any(nb[1]):
        raise ValueError("name: bytes after the first NUL must be 0")
    arrays_from = table_off + LAYER_ENTRY_SIZE * n
    if table_off < HEADER_SIZE or table_off % 4 or arrays_from > total:
        raise ValueError(f"layer_table offset {table_off}")

    spans = []

    def arr(off, count, dtype, what):
        size = count * np.dtype(dtype).itemsize
        if off % 4 or off < arrays_from or off + size > total:
            raise ValueError(f"{what}: offset {off} (+{size}) outside [{arrays_from}, {total}) or unaligned")
        spans.append((off, off + size, what))
        return np.frombuffer(blob, dtype, count, off).copy()

    layers = []
    for i in range(n):
        (op, stride, a, b, cin, co, ozp, amin, amax, lr0, ow, ob, om, osh, lr1) = struct.unpack_from(
            LAYER_FMT, blob, table_off + i * LAYER_ENTRY_SIZE)
        if lr0 or lr1:
            raise ValueError(f"layer {i}: reserved fields must be 0")
        L = {"op": op, "stride": stride, "in": a, "in2": b, "cin": cin, "cout": co, "out_zp": ozp,
             "act_min": amin, "act_max": amax, "w": None, "bias": None, "mult": None, "shift": None}
        shape = weight_shape(op, cin, co)
        if shape is not None:
            L["w"] = arr(ow, int(np.prod(shape)), np.int8, f"layer {i} weights").reshape(shape)
            L["bias"] = arr(ob, co, "<i4", f"layer {i} bias").astype(np.int32)
            L["mult"] = arr(om, co, "<i4", f"layer {i} mult").astype(np.int32)
            L["shift"] = arr(osh, co, np.int8, f"layer {i} shift")
        elif ow or ob or om or osh:
            raise ValueError(f"layer {i}: op {op} must have array offsets 0")
        layers.append(L)
    table = arr(dec_off, cout * 256, "<i4", "decode table").astype(np.int32).reshape(cout, 256)
    spans.sort()
    for (_, e0, w0), (s1, _, w1) in zip(spans, spans[1:]):
        if s1 < e0:
            raise ValueError(f"{w0} and {w1} overlap")
    desc = {"input_w": in_w, "input_h": in_h, "input_norm": norm, "norm_lo_permille": lo, "norm_hi_permille": hi,
            "norm_min_range": min_range, "input_zp": zp, "out_stride": ostride, "out_channels": cout,
            "score_threshold_q": thr, "max_peaks": max_peaks, "name": nb[0].decode("ascii", "replace"),
            "layers": layers, "table": table}
    return validate(desc) if check else desc


# ------------------------------------------------------------------ C array for flash
def write_c_array(blob, name, out_dir):
    """Writes <out_dir>/<name>.vdm and <name>_vdm.c / <name>_vdm.h (8-byte aligned const array and
    the accessor `const void *vd_model_<name>(size_t *bytes)`, as vdtools.formats.export does for the DBN);
    returns the three paths."""
    from vdtools.formats import export
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    h, c = export.c_sources(bytes(blob), name, source=f"{name}.vdm")
    h = h.replace("The quantised DBN model", "The int8 CNN model").replace("vd_dbn_load()", "vd_cnn_load()")
    c = c.replace("The quantised DBN model", "The int8 CNN model").replace("(vd_dbn_load needs 4)",
                                                                          "(vd_cnn_load needs 4)")
    paths = (out / f"{name}.vdm", out / f"{name}_vdm.c", out / f"{name}_vdm.h")
    paths[0].write_bytes(bytes(blob))
    paths[1].write_text(c)
    paths[2].write_text(h)
    return paths
