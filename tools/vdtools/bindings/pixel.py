# SPDX-License-Identifier: MIT
"""ctypes bindings of the pixel modules (threshold.h, histogram.h, otsu.h, median.h): numpy in, numpy out.

The generator of the 5x5 median selection network of lib/src/pixel/median.c is
vdtools.generators.median_network."""
import ctypes as C

import numpy as np

from vdtools.bindings import clib

_P = C.POINTER
_configured = set()


Calib = clib.Calib   # the one mirror of vd_calib_t


def _lib():
    lib = clib.load()
    if id(lib) not in _configured:
        u8v, u16v, img, rect = _P(clib.ViewU8), _P(clib.ViewU16), _P(clib.ImageU8), _P(clib.Rect)
        sigs = {
            "vd_threshold_u8": [u8v, rect, C.c_uint8, img],
            "vd_threshold_u16": [u16v, rect, C.c_uint16, img],
            "vd_threshold_u16_ck": [u16v, rect, _P(Calib), C.c_int32, img],
            "vd_calib_ck_from_raw": [_P(Calib), C.c_uint16, _P(C.c_int32)],
            "vd_calib_raw_from_ck": [_P(Calib), C.c_int32, _P(C.c_uint16)],
            "vd_calib_raw_from_centi_celsius": [_P(Calib), C.c_int32, _P(C.c_uint16)],
            "vd_histogram_u8": [u8v, rect, _P(C.c_uint32)],
            "vd_histogram_percentiles_u16": [u16v, C.c_uint32, C.c_uint32, _P(C.c_uint32), _P(C.c_uint16),
                                             _P(C.c_uint16)],
            "vd_otsu_from_hist": [_P(C.c_uint32), _P(C.c_uint8)],
            "vd_otsu_u8": [u8v, rect, _P(C.c_uint8)],
            "vd_median3_u8": [u8v, rect, img],
            "vd_median5_u8": [u8v, rect, img],
        }
        for name, args in sigs.items():
            f = getattr(lib, name)
            f.argtypes = args
            f.restype = C.c_int
        _configured.add(id(lib))
    return lib


def _roi(roi):
    """(x, y, w, h) or None -> (Rect pointer or None, rect tuple or None)."""
    if roi is None:
        return None
    return C.byref(clib.Rect(*[int(v) for v in roi]))


def _out_shape(a, roi):
    return (a.shape[0], a.shape[1]) if roi is None else (int(roi[3]), int(roi[2]))


def _image(out):
    return clib.ImageU8(out.ctypes.data_as(_P(C.c_uint8)), out.shape[1], out.shape[0], out.strides[0])


def threshold_u8(a, thr, roi=None):
    """Mask (0/255) of a >= thr over roi (x, y, w, h) of the 2-D uint8 array a."""
    out = np.empty(_out_shape(a, roi), np.uint8)
    v = clib.view_u8(a)
    clib.check(_lib().vd_threshold_u8(C.byref(v), _roi(roi), int(thr), C.byref(_image(out))), "vd_threshold_u8")
    return out


def threshold_u16(a, thr_raw, roi=None):
    out = np.empty(_out_shape(a, roi), np.uint8)
    v = clib.view_u16(a)
    clib.check(_lib().vd_threshold_u16(C.byref(v), _roi(roi), int(thr_raw), C.byref(_image(out))), "vd_threshold_u16")
    return out


def threshold_u16_ck(a, gain_q16, offset_ck, thr_ck, roi=None):
    out = np.empty(_out_shape(a, roi), np.uint8)
    v = clib.view_u16(a)
    cal = Calib(gain_q16, offset_ck)
    clib.check(_lib().vd_threshold_u16_ck(C.byref(v), _roi(roi), C.byref(cal), int(thr_ck), C.byref(_image(out))),
               "vd_threshold_u16_ck")
    return out


def ck_from_raw(gain_q16, offset_ck, raw):
    """(status, centi-kelvin) of one raw value."""
    ck = C.c_int32(0)
    st = _lib().vd_calib_ck_from_raw(C.byref(Calib(gain_q16, offset_ck)), int(raw), C.byref(ck))
    return st, ck.value


def raw_from_ck(gain_q16, offset_ck, ck):
    """(status, smallest raw whose temperature >= ck)."""
    raw = C.c_uint16(0)
    st = _lib().vd_calib_raw_from_ck(C.byref(Calib(gain_q16, offset_ck)), int(ck), C.byref(raw))
    return st, raw.value


def raw_from_centi_celsius(gain_q16, offset_ck, centi_c):
    raw = C.c_uint16(0)
    st = _lib().vd_calib_raw_from_centi_celsius(C.byref(Calib(gain_q16, offset_ck)), int(centi_c), C.byref(raw))
    return st, raw.value


def histogram_u8(a, roi=None):
    h = np.zeros(256, np.uint32)
    v = clib.view_u8(a)
    clib.check(_lib().vd_histogram_u8(C.byref(v), _roi(roi), h.ctypes.data_as(_P(C.c_uint32))), "vd_histogram_u8")
    return h


def percentiles_u16(a, lo_permille, hi_permille):
    """(lo, hi): vd_histogram_percentiles_u16 of the 2-D uint16 array a."""
    h = np.zeros(256, np.uint32)
    lo, hi = C.c_uint16(0), C.c_uint16(0)
    v = clib.view_u16(a)
    clib.check(_lib().vd_histogram_percentiles_u16(C.byref(v), int(lo_permille), int(hi_permille),
                                                   h.ctypes.data_as(_P(C.c_uint32)), C.byref(lo), C.byref(hi)),
               "vd_histogram_percentiles_u16")
    return lo.value, hi.value


def otsu_from_hist(hist):
    h = np.ascontiguousarray(hist, dtype=np.uint32)
    assert h.shape == (256,)
    t = C.c_uint8(0)
    clib.check(_lib().vd_otsu_from_hist(h.ctypes.data_as(_P(C.c_uint32)), C.byref(t)), "vd_otsu_from_hist")
    return t.value


def otsu_u8(a, roi=None):
    t = C.c_uint8(0)
    v = clib.view_u8(a)
    clib.check(_lib().vd_otsu_u8(C.byref(v), _roi(roi), C.byref(t)), "vd_otsu_u8")
    return t.value


def median_u8(a, k, roi=None):
    """k x k median (k = 3 or 5) of roi of a; equals cv2.medianBlur(a, k)[roi]."""
    fn = {3: "vd_median3_u8", 5: "vd_median5_u8"}[k]
    out = np.empty(_out_shape(a, roi), np.uint8)
    v = clib.view_u8(a)
    clib.check(getattr(_lib(), fn)(C.byref(v), _roi(roi), C.byref(_image(out))), fn)
    return out
