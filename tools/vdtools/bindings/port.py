# SPDX-License-Identifier: MIT
"""ctypes access to the capture port (port/include/vd_port/capture.h) through its shared build,
build/libvd_port.so ($VD_PORT_LIB, else beside $VD_LIB / build/libvd.so).

Python tools that must see exactly the frames vd_fir_demo sees (same file list, same PGM/PNG/JPEG/raw
decoding, same frame names) read recordings through it:

    from vdtools.bindings import port
    with port.Capture("frames.lst", raw_size=(640, 512)) as cap:
        for frame, name in cap:          # frame: clib.Frame, valid until the next iteration
            ...                          # port.pixels(frame) -> a numpy view of its samples
"""
import ctypes as C
import os
from pathlib import Path

import numpy as np

from vdtools.bindings import clib

VD_ERR_RANGE = -8
RAW_FORMATS = {"u16": (clib.VD_PIX_U16, False), "u16be": (clib.VD_PIX_U16, True), "u8": (clib.VD_PIX_U8, False)}


class CaptureOpts(C.Structure):
    _fields_ = [("width", C.c_uint32), ("height", C.c_uint32), ("fps", C.c_uint32), ("format", C.c_int),
                ("n_buffers", C.c_uint32), ("raw_width", C.c_uint32), ("raw_height", C.c_uint32),
                ("raw_format", C.c_int), ("raw_big_endian", C.c_bool), ("same_size", C.c_bool)]


# vd_capture_t is used through its functions only: a generous aligned buffer (about 420 bytes in C).
_CAPTURE_BYTES = 2048

_lib = None


def lib_path():
    if os.environ.get("VD_PORT_LIB"):
        return Path(os.environ["VD_PORT_LIB"])
    return clib.lib_path().with_name("libvd_port.so")


def load():
    """The loaded port library (cached; libvd.so is loaded first, it resolves the port's vd_* symbols)."""
    global _lib
    if _lib is None:
        clib.load()
        lib = C.CDLL(str(lib_path()))
        lib.vd_capture_opts_default.argtypes = [C.POINTER(CaptureOpts)]
        lib.vd_capture_opts_default.restype = None
        lib.vd_capture_open.argtypes = [C.c_void_p, C.c_char_p, C.POINTER(CaptureOpts)]
        lib.vd_capture_open.restype = C.c_int
        lib.vd_capture_start.argtypes = [C.c_void_p]
        lib.vd_capture_start.restype = C.c_int
        lib.vd_capture_next.argtypes = [C.c_void_p, C.c_int32, C.POINTER(clib.Frame)]
        lib.vd_capture_next.restype = C.c_int
        lib.vd_capture_release.argtypes = [C.c_void_p, C.POINTER(clib.Frame)]
        lib.vd_capture_release.restype = C.c_int
        lib.vd_capture_close.argtypes = [C.c_void_p]
        lib.vd_capture_close.restype = None
        for fn in ("vd_capture_error", "vd_capture_frame_name"):
            getattr(lib, fn).argtypes = [C.c_void_p]
            getattr(lib, fn).restype = C.c_char_p
        lib.vd_capture_at_end.argtypes = [C.c_void_p]
        lib.vd_capture_at_end.restype = C.c_bool
        lib.vd_file_frame_total.argtypes = [C.c_void_p, C.POINTER(C.c_uint64)]
        lib.vd_file_frame_total.restype = C.c_int
        lib.vd_file_skip.argtypes = [C.c_void_p, C.c_uint64]
        lib.vd_file_skip.restype = C.c_int
        _lib = lib
    return _lib


class CaptureError(IOError):
    def __init__(self, status, message):
        super().__init__(f"{message} ({clib.STATUS.get(status, status)})")
        self.status = status


class Capture:
    """A recorded input as vd_fir_demo opens it (--input PATH [--raw-size WxH --raw-format F]),
    with same_size on as in the demo (a frame of another size ends the run)."""

    def __init__(self, path, raw_size=None, raw_format="u16"):
        lib = load()
        self._cap = (C.c_uint64 * (_CAPTURE_BYTES // 8))()
        self._open = False
        o = CaptureOpts()
        lib.vd_capture_opts_default(C.byref(o))
        if raw_size:
            o.raw_width, o.raw_height = (int(v) for v in raw_size)
        o.raw_format, o.raw_big_endian = RAW_FORMATS[raw_format]
        o.same_size = True
        st = lib.vd_capture_open(self._cap, os.fsencode(str(path)), C.byref(o))
        if st == clib.VD_OK:
            self._open = True
            st = lib.vd_capture_start(self._cap)
        if st != clib.VD_OK:
            msg = self.error() or str(path)
            self.close()
            raise CaptureError(st, msg)

    def error(self):
        return load().vd_capture_error(self._cap).decode("utf-8", "replace")

    def __iter__(self):
        """(frame, name) per frame; the frame is released when the next one is asked for. A capture error
        (missing, truncated or undecodable file) raises CaptureError, as the demo ends its run."""
        while True:
            got = self._next()
            if got is None:
                return
            yield from got

    def total(self):
        """The frames the recording will hand out (vd_file_frame_total: one per image, size / frame size per
        raw file)."""
        n = C.c_uint64()
        st = load().vd_file_frame_total(self._cap, C.byref(n))
        if st != clib.VD_OK:
            raise CaptureError(st, "not a recorded input")
        return int(n.value)

    def frames_at(self, indices):
        """As iterating, but only the frames of the ascending 0-based `indices` (counted from where the capture
        stands: its first frame when fresh), passing over the others without decoding them (vd_file_skip), as
        vd_fir_demo's --cnn-full-res auto does."""
        lib, pos = load(), 0
        for want in indices:
            if want > pos:
                st = lib.vd_file_skip(self._cap, want - pos)
                if st == VD_ERR_RANGE and lib.vd_capture_at_end(self._cap):
                    return
                if st != clib.VD_OK:
                    raise CaptureError(st, self.error())
            pos = want + 1
            got = self._next()
            if got is None:
                return
            yield from got

    def _next(self):
        """The next frame as a one-item generator that releases it when resumed, or None at the end."""
        lib = load()
        f = clib.Frame()
        st = lib.vd_capture_next(self._cap, 0, C.byref(f))
        if st == VD_ERR_RANGE and lib.vd_capture_at_end(self._cap):
            return None
        if st != clib.VD_OK:
            raise CaptureError(st, self.error())
        name = os.path.basename(os.fsdecode(lib.vd_capture_frame_name(self._cap) or b""))

        def held():
            try:
                yield f, name
            finally:
                lib.vd_capture_release(self._cap, C.byref(f))
        return held()

    def close(self):
        if self._open:
            load().vd_capture_close(self._cap)
            self._open = False

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        self.close()


def pixels(frame):
    """A 2-D numpy view (uint8 or uint16) of a captured frame's samples (valid while the frame is held)."""
    dt = np.uint16 if frame.format == clib.VD_PIX_U16 else np.uint8
    nbytes = frame.stride * (frame.height - 1) + frame.width * np.dtype(dt).itemsize
    buf = (C.c_uint8 * nbytes).from_address(frame.data)
    return np.ndarray((frame.height, frame.width), dtype=dt, buffer=buf, strides=(frame.stride, np.dtype(dt).itemsize))
