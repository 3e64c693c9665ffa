# SPDX-License-Identifier: MIT
"""The .vdm model file (docs/model-format.md): pack an integer model from
vdtools.quantise into a blob, parse one back, and run it through the C library
(vd_dbn_load / vd_dbn_classify via ctypes).

    blob = vdm.pack(qm)                 # bytes
    qm2 = vdm.unpack(blob)              # dict as quantise.quantise() returns
    with vdm.CModel(blob) as m: m.classify(x_u8)  -> uint8 score(s)
"""
import ctypes as C
import struct
import zlib

import numpy as np

from vdtools import clib
from vdtools.quantise import MODE_IDS, NORM_IDS

MAGIC = b"VDMF"
VERSION = 2          # written; VERSIONS are read (a version-1 blob has no normalisation)
VERSIONS = (1, 2)
HEADER_SIZE = 64
LAYER_ENTRY_SIZE = 32
ACT_SIGMOID_Q8 = 1
MAX_LAYERS = 8
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


# ----------------------------------------------------------------- C binding
class _Layer(C.Structure):
    _fields_ = [("weights", C.c_void_p), ("bias_le", C.c_void_p), ("mult_le", C.c_void_p),
                ("shift", C.c_void_p), ("in_", C.c_uint32), ("out", C.c_uint32)]


class Model(C.Structure):
    """Mirror of vd_dbn_model_t (lib/include/vd/dbn.h)."""
    _fields_ = [("blob", C.c_void_p), ("size", C.c_uint32), ("crc32", C.c_uint32),
                ("format_version", C.c_uint16), ("input_w", C.c_uint16), ("input_h", C.c_uint16),
                ("norm_divisor", C.c_uint16), ("norm_offset", C.c_int16), ("input_mode", C.c_int),
                ("input_norm", C.c_int), ("norm_min_range", C.c_uint32), ("n_layers", C.c_uint32), ("max_units", C.c_uint32), ("name", C.c_char * 17),
                ("layers", _Layer * MAX_LAYERS)]


_bound = False


def lib():
    """The shared C library with the dbn prototypes declared."""
    global _bound
    lb = clib.load()
    if not _bound:
        lb.vd_dbn_load.argtypes = [C.POINTER(Model), C.c_void_p, C.c_size_t]
        lb.vd_dbn_workspace_size.argtypes = [C.POINTER(Model), C.POINTER(C.c_size_t)]
        lb.vd_dbn_classify.argtypes = [C.POINTER(Model), C.POINTER(C.c_uint8), C.c_void_p, C.c_size_t,
                                       C.POINTER(C.c_uint8)]
        lb.vd_dbn_requantize.argtypes = [C.c_int32, C.c_int32, C.c_int32]
        lb.vd_dbn_requantize.restype = C.c_int32
        lb.vd_dbn_sigmoid_q8.argtypes = [C.c_int32]
        lb.vd_dbn_sigmoid_q8.restype = C.c_uint8
        lb.vd_dbn_stretch_u8.argtypes = [C.POINTER(C.c_uint8), C.c_uint32, C.c_uint32, C.POINTER(C.c_uint8)]
        lb.vd_dbn_stretch_u8.restype = C.c_int
        for f in (lb.vd_dbn_load, lb.vd_dbn_workspace_size, lb.vd_dbn_classify):
            f.restype = C.c_int
        _bound = True
    return lb


def c_stretch(x_u8, min_range):
    """vd_dbn_stretch_u8 on one sample (uint8 array) -> (status, uint8 array)."""
    x = np.ascontiguousarray(x_u8, dtype=np.uint8).reshape(-1)
    out = np.zeros_like(x)
    st = lib().vd_dbn_stretch_u8(x.ctypes.data_as(C.POINTER(C.c_uint8)), len(x), int(min_range),
                                 out.ctypes.data_as(C.POINTER(C.c_uint8)))
    return st, out


def aligned_copy(blob, offset=0):
    """(keepalive, address) of a copy of blob at an 8-byte aligned address + offset."""
    keep = np.zeros((len(blob) + offset + 15) // 8, dtype=np.uint64)
    addr = keep.ctypes.data + offset
    C.memmove(addr, bytes(blob), len(blob))
    return keep, addr


def c_load(blob, offset=0, nbytes=None):
    """Status of vd_dbn_load on a copy of blob (for tests)."""
    keep, addr = aligned_copy(blob, offset)
    m = Model()
    st = lib().vd_dbn_load(C.byref(m), addr, len(blob) if nbytes is None else nbytes)
    del keep
    return st


class CModel:
    """A blob loaded by the C library, with a workspace; classify() calls vd_dbn_classify."""

    def __init__(self, blob):
        self._keep, addr = aligned_copy(blob)
        self.m = Model()
        clib.check(lib().vd_dbn_load(C.byref(self.m), addr, len(blob)), "vd_dbn_load")
        n = C.c_size_t()
        clib.check(lib().vd_dbn_workspace_size(C.byref(self.m), C.byref(n)), "vd_dbn_workspace_size")
        self._ws, self._ws_ptr = clib.workspace(n.value)
        self.ws_bytes = n.value
        self.n_in = self.m.input_w * self.m.input_h

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def classify_one(self, x_u8):
        """Q8 score (int 0..255) of one sample of input_w * input_h bytes."""
        return int(self.classify(np.asarray(x_u8).reshape(1, -1))[0])

    def classify(self, x_u8):
        """Q8 scores uint8 [N] for a batch [N, in] or [N, h, w] of uint8 samples."""
        x = np.ascontiguousarray(x_u8, dtype=np.uint8).reshape(-1, self.n_in)
        out = np.empty(len(x), dtype=np.uint8)
        score = C.c_uint8()
        fn, mp = lib().vd_dbn_classify, C.byref(self.m)
        for i in range(len(x)):
            st = fn(mp, x[i].ctypes.data_as(C.POINTER(C.c_uint8)), self._ws_ptr, self.ws_bytes, C.byref(score))
            clib.check(st, "vd_dbn_classify")
            out[i] = score.value
        return out
