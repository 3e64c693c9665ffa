# SPDX-License-Identifier: MIT
"""ctypes access to the shared build of the C library (build/libvd.so).

The path comes from $VD_LIB, else <repo>/build/libvd.so. Each module's
bindings (argtypes/restype and numpy helpers) live next to the code that uses
them; this file only loads the library and defines the shared structs."""
import ctypes as C
import os
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[3]
DATA_DIR = Path(os.environ.get("VD_DATA_DIR", REPO.parent / "shared" / "data"))

VD_OK = 0
STATUS = {
    0: "VD_OK", -1: "VD_ERR_ARG", -2: "VD_ERR_WORKSPACE", -3: "VD_ERR_CAPACITY",
    -4: "VD_ERR_MODEL", -5: "VD_ERR_FORMAT", -6: "VD_ERR_IO", -7: "VD_ERR_TIMEOUT",
    -8: "VD_ERR_RANGE", -9: "VD_ERR_NODEV", -10: "VD_ERR_STATE", -11: "VD_ERR_AGAIN",
    -12: "VD_ERR_OVERFLOW",
}
VD_PIX_U8, VD_PIX_U16 = 1, 2


class Rect(C.Structure):
    _fields_ = [("x", C.c_int32), ("y", C.c_int32), ("w", C.c_int32), ("h", C.c_int32)]


class ViewU8(C.Structure):
    _fields_ = [("data", C.POINTER(C.c_uint8)), ("width", C.c_uint32),
                ("height", C.c_uint32), ("stride", C.c_size_t)]


class ViewU16(C.Structure):
    _fields_ = [("data", C.POINTER(C.c_uint16)), ("width", C.c_uint32),
                ("height", C.c_uint32), ("stride", C.c_size_t)]


ImageU8 = ViewU8  # same layout; writable in C


class Frame(C.Structure):
    _fields_ = [("data", C.c_void_p), ("width", C.c_uint32), ("height", C.c_uint32),
                ("stride", C.c_size_t), ("format", C.c_int), ("seq", C.c_uint32),
                ("timestamp_us", C.c_uint64)]


class Calib(C.Structure):
    """Mirror of vd_calib_t (calib.h): used by the detector configuration and the pixel tools."""
    _fields_ = [("gain_q16", C.c_int32), ("offset_ck", C.c_int32)]


class Point(C.Structure):
    _fields_ = [("x", C.c_int16), ("y", C.c_int16)]


class VdError(RuntimeError):
    def __init__(self, status, what=""):
        super().__init__(f"{what}: {STATUS.get(status, status)}")
        self.status = status


_lib = None


def lib_path():
    return Path(os.environ.get("VD_LIB", REPO / "build" / "libvd.so"))


def load():
    """Returns the loaded shared library (cached). Raises OSError if it is not built."""
    global _lib
    if _lib is None:
        _lib = C.CDLL(str(lib_path()))
    return _lib


def check(status, what=""):
    if status != VD_OK:
        raise VdError(status, what)


def view_u8(a):
    """A ViewU8 on a 2-D uint8 numpy array (kept alive by the caller)."""
    assert a.dtype == np.uint8 and a.ndim == 2
    return ViewU8(a.ctypes.data_as(C.POINTER(C.c_uint8)), a.shape[1], a.shape[0], a.strides[0])


def view_u16(a):
    assert a.dtype == np.uint16 and a.ndim == 2
    return ViewU16(a.ctypes.data_as(C.POINTER(C.c_uint16)), a.shape[1], a.shape[0], a.strides[0])


def frame(a, seq=0):
    fmt = VD_PIX_U8 if a.dtype == np.uint8 else VD_PIX_U16
    return Frame(a.ctypes.data, a.shape[1], a.shape[0], a.strides[0], fmt, seq, 0)


def workspace(nbytes):
    """An 8-byte aligned numpy buffer of nbytes (at least 1)."""
    buf = np.zeros((max(int(nbytes), 1) + 7) // 8, dtype=np.uint64)
    return buf, buf.ctypes.data_as(C.c_void_p)
