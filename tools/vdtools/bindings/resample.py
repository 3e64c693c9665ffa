# SPDX-License-Identifier: MIT
"""ctypes binding of resample.h: vd_resample_u8 on numpy images (the integer numpy reference is
vdtools.data.samples.resample_ref)."""
import ctypes as C

import numpy as np

from vdtools.bindings import clib

INPUT_SIZE = 32   # default output side: the DBN's input

_bound = False


def _lib():
    global _bound
    lib = clib.load()
    if not _bound:
        lib.vd_resample_u8.argtypes = [C.POINTER(clib.ViewU8), C.POINTER(clib.Rect),
                                       C.POINTER(C.c_uint8), C.c_uint32, C.c_uint32]
        lib.vd_resample_u8.restype = C.c_int
        _bound = True
    return lib


def resample(img, rect=None, w=INPUT_SIZE, h=INPUT_SIZE):
    """vd_resample_u8 on a 2-D uint8 image: the region rect=(x, y, w, h) (None =
    whole image; must lie inside) to an (h, w) uint8 array."""
    img = np.asarray(img)
    if img.dtype != np.uint8 or img.ndim != 2:
        raise ValueError("resample needs a 2-D uint8 image")
    if img.strides[1] != 1 or img.strides[0] < img.shape[1]:
        img = np.ascontiguousarray(img)
    lib = _lib()
    out = np.empty((h, w), dtype=np.uint8)
    v = clib.view_u8(img)
    r = None if rect is None else C.byref(clib.Rect(*(int(t) for t in rect)))
    st = lib.vd_resample_u8(C.byref(v), r, out.ctypes.data_as(C.POINTER(C.c_uint8)), w, h)
    clib.check(st, "vd_resample_u8")
    return out
