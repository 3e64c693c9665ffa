# SPDX-License-Identifier: MIT
"""ctypes binding of boost.h (vd_boost_*): a boosted .vdm blob loaded by the C library (CBoost)."""
import ctypes as C

import numpy as np

from vdtools.bindings import clib


_bound = False


class BoostModel(C.Structure):
    pass


def lib():
    global _bound
    L = clib.load()
    if not _bound:
        L.vd_boost_model_bytes.argtypes = []
        L.vd_boost_model_bytes.restype = C.c_size_t
        L.vd_boost_load.argtypes = [C.c_void_p, C.c_void_p, C.c_size_t]
        L.vd_boost_load.restype = C.c_int
        L.vd_boost_workspace_size.argtypes = [C.c_void_p, C.POINTER(C.c_size_t)]
        L.vd_boost_workspace_size.restype = C.c_int
        L.vd_boost_score.argtypes = [C.c_void_p, C.POINTER(C.c_uint8), C.c_uint32, C.c_void_p, C.c_size_t,
                                     C.POINTER(C.c_int32)]
        L.vd_boost_score.restype = C.c_int
        L.vd_boost_features.argtypes = [C.c_void_p, C.POINTER(C.c_uint8), C.c_uint32, C.c_void_p, C.c_size_t,
                                        C.POINTER(C.c_int8), C.c_size_t]
        L.vd_boost_features.restype = C.c_int
        L.vd_boost_threshold.argtypes = [C.c_void_p, C.POINTER(C.c_int32), C.POINTER(C.c_uint32)]
        L.vd_boost_threshold.restype = C.c_int
        _bound = True
    return L


class CBoost:
    """A blob loaded by vd_boost_load with its own workspace."""

    def __init__(self, blob):
        L = lib()
        self.buf = (C.c_uint32 * ((len(blob) + 3) // 4))()
        C.memmove(self.buf, blob, len(blob))
        self.m = (C.c_uint8 * L.vd_boost_model_bytes())()
        clib.check(L.vd_boost_load(C.addressof(self.m), C.addressof(self.buf), len(blob)), "vd_boost_load")
        n = C.c_size_t()
        clib.check(L.vd_boost_workspace_size(C.addressof(self.m), C.byref(n)), "vd_boost_workspace_size")
        self.ws_bytes = n.value
        self.ws = (C.c_uint64 * ((n.value + 7) // 8 + 8))()
        thr, nf = C.c_int32(), C.c_uint32()
        clib.check(L.vd_boost_threshold(C.addressof(self.m), C.byref(thr), C.byref(nf)), "vd_boost_threshold")
        self.threshold, self.n_features = thr.value, nf.value

    def _ws(self):
        a = C.addressof(self.ws)
        return a + (-a) % 64

    def score(self, crop_u8):
        x = np.ascontiguousarray(crop_u8, np.uint8)
        s = C.c_int32()
        clib.check(lib().vd_boost_score(C.addressof(self.m), x.ctypes.data_as(C.POINTER(C.c_uint8)), x.shape[1],
                                        self._ws(), self.ws_bytes, C.byref(s)), "vd_boost_score")
        return s.value

    def features(self, crop_u8):
        x = np.ascontiguousarray(crop_u8, np.uint8)
        out = np.empty(self.n_features, np.int8)
        clib.check(lib().vd_boost_features(C.addressof(self.m), x.ctypes.data_as(C.POINTER(C.c_uint8)), x.shape[1],
                                           self._ws(), self.ws_bytes, out.ctypes.data_as(C.POINTER(C.c_int8)),
                                           out.size), "vd_boost_features")
        return out
