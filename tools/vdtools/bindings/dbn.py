# SPDX-License-Identifier: MIT
"""ctypes binding of dbn.h (vd_dbn_*): the vd_dbn_model_t mirror, a blob loaded by the C library
(CModel) and the 8-byte aligned copy both .vdm kinds are loaded from."""
import ctypes as C

import numpy as np

from vdtools.bindings import clib

MAX_LAYERS = 8   # VD_DBN_MAX_LAYERS


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


def load_status(load, model, blob, offset=0, nbytes=None):
    """Status of a .vdm loader (vd_dbn_load, vd_cnn_load, ...) on an aligned copy of blob placed at
    `offset`, telling it `nbytes` (default len(blob)); the model struct is not kept (for tests)."""
    keep, addr = aligned_copy(blob, offset)
    st = load(C.byref(model), addr, len(blob) if nbytes is None else nbytes)
    del keep
    return st


def c_load(blob, offset=0, nbytes=None):
    """Status of vd_dbn_load on a copy of blob (for tests)."""
    return load_status(lib().vd_dbn_load, Model(), blob, offset, nbytes)


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
