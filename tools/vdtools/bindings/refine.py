# SPDX-License-Identifier: MIT
"""ctypes bindings of refine.h and contour.h: segment a candidate region
(paper 001 §3) and trace outer contours like cv2.findContours(RETR_EXTERNAL,
CHAIN_APPROX_NONE)."""
import ctypes as C

import numpy as np

from vdtools.bindings import clib

CHAIN_NONE = 8
VD_ERR_RANGE = -8


class RefineCfg(C.Structure):
    _fields_ = [("median_ksize", C.c_uint8), ("edge_step", C.c_uint8), ("window", C.c_uint8)]


class RefineStats(C.Structure):
    _fields_ = [("otsu_thr", C.c_uint8), ("edge_points", C.c_uint32),
                ("local_windows", C.c_uint32), ("fg_pixels", C.c_uint32)]


class Contour(C.Structure):
    _fields_ = [("first", C.c_uint32), ("length", C.c_uint32), ("box", clib.Rect)]


_bound = None


def _lib():
    global _bound
    if _bound is None:
        lib = clib.load()
        st = C.c_int
        sz = C.POINTER(C.c_size_t)
        lib.vd_refine_cfg_default.argtypes = [C.POINTER(RefineCfg)]
        lib.vd_refine_cfg_default.restype = None
        lib.vd_refine_workspace_size.argtypes = [C.c_uint32, C.c_uint32, sz]
        lib.vd_refine_workspace_size.restype = st
        lib.vd_refine_region.argtypes = [C.POINTER(clib.ViewU8), C.POINTER(clib.Rect), C.POINTER(RefineCfg),
                                         C.c_void_p, C.c_size_t, C.POINTER(clib.ImageU8),
                                         C.POINTER(RefineStats)]
        lib.vd_refine_region.restype = st
        lib.vd_refine_maxdist_from_hist.argtypes = [C.POINTER(C.c_uint32), C.POINTER(C.c_uint8)]
        lib.vd_refine_maxdist_from_hist.restype = st
        lib.vd_refine_fill_holes_workspace_size.argtypes = [C.c_uint32, C.c_uint32, sz]
        lib.vd_refine_fill_holes_workspace_size.restype = st
        lib.vd_refine_fill_holes_u8.argtypes = [C.POINTER(clib.ImageU8), C.c_void_p, C.c_size_t]
        lib.vd_refine_fill_holes_u8.restype = st
        lib.vd_refine_edges_u8.argtypes = [C.POINTER(clib.ViewU8), C.POINTER(clib.Rect), C.POINTER(clib.ImageU8)]
        lib.vd_refine_edges_u8.restype = st
        lib.vd_contour_workspace_size.argtypes = [C.c_uint32, C.c_uint32, sz]
        lib.vd_contour_workspace_size.restype = st
        lib.vd_contour_find_external.argtypes = [C.POINTER(clib.ViewU8), C.c_void_p, C.c_size_t,
                                                  C.POINTER(clib.Point), C.POINTER(C.c_uint8), C.c_size_t,
                                                  C.POINTER(Contour), C.c_size_t, sz, sz]
        lib.vd_contour_find_external.restype = st
        _bound = lib
    return _bound


def _size(fn, w, h):
    n = C.c_size_t()
    clib.check(fn(w, h, C.byref(n)), fn.__name__)
    return n.value


def workspace_size(w, h):
    """vd_refine_workspace_size for a w x h region."""
    return _size(_lib().vd_refine_workspace_size, w, h)


def contour_workspace_size(w, h):
    """vd_contour_workspace_size for a w x h mask."""
    return _size(_lib().vd_contour_workspace_size, w, h)


def default_cfg():
    cfg = RefineCfg()
    _lib().vd_refine_cfg_default(C.byref(cfg))
    return cfg


def refine_region(img, roi=None, median=3, edge_step=5, window=5):
    """Runs vd_refine_region on a 2-D uint8 array. roi = (x, y, w, h) or None.
    Returns (mask uint8 roi-sized 0/255, stats dict)."""
    lib = _lib()
    img = np.ascontiguousarray(img, dtype=np.uint8)
    x, y, w, h = roi if roi is not None else (0, 0, img.shape[1], img.shape[0])
    rect = clib.Rect(x, y, w, h)
    cfg = RefineCfg(median, edge_step, window)
    out = np.zeros((h, w), np.uint8)
    nbytes = _size(lib.vd_refine_workspace_size, w, h)
    buf, ws = clib.workspace(nbytes)
    stats = RefineStats()
    src = clib.view_u8(img)
    dst = clib.view_u8(out)
    clib.check(lib.vd_refine_region(C.byref(src), C.byref(rect), C.byref(cfg), ws, nbytes, C.byref(dst),
                                    C.byref(stats)), "vd_refine_region")
    del buf
    return out, {"otsu_thr": stats.otsu_thr, "edge_points": stats.edge_points,
                 "local_windows": stats.local_windows, "fg_pixels": stats.fg_pixels}


def maxdist_from_hist(hist):
    """eq. (1) threshold of a 256-bin histogram (total 1..255); None if no split exists."""
    h = np.ascontiguousarray(hist, dtype=np.uint32)
    assert h.shape == (256,)
    t = C.c_uint8()
    st = _lib().vd_refine_maxdist_from_hist(h.ctypes.data_as(C.POINTER(C.c_uint32)), C.byref(t))
    if st == VD_ERR_RANGE:
        return None
    clib.check(st, "vd_refine_maxdist_from_hist")
    return t.value


def fill_holes(mask):
    """vd_refine_fill_holes_u8 on a copy of mask; returns the 0/255 result."""
    lib = _lib()
    out = np.ascontiguousarray(mask, dtype=np.uint8).copy()
    nbytes = _size(lib.vd_refine_fill_holes_workspace_size, out.shape[1], out.shape[0])
    buf, ws = clib.workspace(nbytes)
    img = clib.view_u8(out)
    clib.check(lib.vd_refine_fill_holes_u8(C.byref(img), ws, nbytes), "vd_refine_fill_holes_u8")
    del buf
    return out


def edges(mask, roi=None):
    """vd_refine_edges_u8: foreground pixels with a background 4-neighbour (outside the ROI = background)."""
    lib = _lib()
    mask = np.ascontiguousarray(mask, dtype=np.uint8)
    x, y, w, h = roi if roi is not None else (0, 0, mask.shape[1], mask.shape[0])
    out = np.zeros((h, w), np.uint8)
    src, dst, rect = clib.view_u8(mask), clib.view_u8(out), clib.Rect(x, y, w, h)
    clib.check(lib.vd_refine_edges_u8(C.byref(src), C.byref(rect), C.byref(dst)), "vd_refine_edges_u8")
    return out


def find_contours(mask, points_cap=None, contours_cap=None, raw=False):
    """vd_contour_find_external on a 2-D uint8 mask.
    Returns (contours, chains, boxes): contours like cv2 (list of int32 arrays
    of shape (n, 1, 2)), chain codes (list of uint8 arrays), boxes (x, y, w, h).
    With raw=True returns (status, points, chain, contour records) without
    raising, for capacity tests."""
    lib = _lib()
    mask = np.ascontiguousarray(mask, dtype=np.uint8)
    h, w = mask.shape
    pcap = 4 * w * h if points_cap is None else points_cap
    ccap = (w * h + 1) // 2 + 1 if contours_cap is None else contours_cap
    pts = np.zeros((max(pcap, 1), 2), np.int16)        # vd_point_t is {int16 x, y}
    chain = np.zeros(max(pcap, 1), np.uint8)
    recs = (Contour * max(ccap, 1))()
    nbytes = _size(lib.vd_contour_workspace_size, w, h)
    buf, ws = clib.workspace(nbytes)
    nc, npts = C.c_size_t(), C.c_size_t()
    view = clib.view_u8(mask)
    st = lib.vd_contour_find_external(C.byref(view), ws, nbytes, pts.ctypes.data_as(C.POINTER(clib.Point)),
                                       chain.ctypes.data_as(C.POINTER(C.c_uint8)), pcap, recs, ccap,
                                       C.byref(nc), C.byref(npts))
    del buf
    xy = pts[:npts.value].astype(np.int32)
    records = [(r.first, r.length, (r.box.x, r.box.y, r.box.w, r.box.h)) for r in recs[:nc.value]]
    if raw:
        return st, xy, chain[:npts.value].copy(), records
    clib.check(st, "vd_contour_find_external")
    contours = [xy[f:f + n].reshape(-1, 1, 2) for f, n, _ in records]
    chains = [chain[f:f + n].copy() for f, n, _ in records]
    boxes = [b for _, _, b in records]
    return contours, chains, boxes
