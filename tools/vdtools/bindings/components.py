# SPDX-License-Identifier: MIT
"""ctypes bindings of components.h: 8-connected labelling, the paper's rules,
candidate expansion.

    from vdtools.bindings import components as cc
    comps = cc.label(mask)                   # structured array, one row per component
    comps["x"], comps["area"], comps["cx_q8"] ...
    kept = cc.filter(comps)                  # paper rules (aspect 77..384 Q8, area >= 120)
    x, y, w, h = cc.rect_expand((x, y, w, h), 640, 512)   # 1.5x / 2x about the centre
    comps, st, stats = cc.label_thr(frame, 150, max_runs=24576)  # pixels >= 150, no mask, run budget

Order of `label` = OpenCV's label order 1..n of
cv2.connectedComponentsWithStats(crop, connectivity=8), so row i matches stats[i + 1].
"""
import ctypes as C

import numpy as np

from vdtools.bindings import clib

# Same layout as vd_component_t (7 x 4 bytes, no padding).
COMPONENT_DTYPE = np.dtype([("x", "<i4"), ("y", "<i4"), ("w", "<i4"), ("h", "<i4"),
                            ("area", "<u4"), ("cx_q8", "<u4"), ("cy_q8", "<u4")])
EXPAND_W_Q8, EXPAND_H_Q8 = 384, 512
VD_ERR_CAPACITY = -3


class CcStats(C.Structure):
    _fields_ = [("runs", C.c_uint32), ("pixels", C.c_uint32), ("rows", C.c_uint32), ("labels", C.c_uint32)]


class Rules(C.Structure):
    _fields_ = [("aspect_min_q8", C.c_uint16), ("aspect_max_q8", C.c_uint16),
                ("min_area", C.c_uint32), ("max_area", C.c_uint32)]


_bound = False


def _lib():
    global _bound
    lib = clib.load()
    if not _bound:
        sz = C.POINTER(C.c_size_t)
        lib.vd_components_workspace_size.argtypes = [C.c_uint32, C.c_uint32, sz]
        lib.vd_components_label.argtypes = [C.POINTER(clib.ViewU8), C.POINTER(clib.Rect), C.c_void_p,
                                            C.c_size_t, C.c_void_p, C.c_size_t, sz]
        lib.vd_components_rules_default.argtypes = [C.POINTER(Rules)]
        lib.vd_components_rules_default.restype = None
        lib.vd_components_filter.argtypes = [C.c_void_p, C.c_size_t, C.POINTER(Rules), sz]
        lib.vd_rect_expand.argtypes = [C.POINTER(clib.Rect), C.c_uint16, C.c_uint16, C.c_uint32,
                                       C.c_uint32, C.POINTER(clib.Rect)]
        lib.vd_components_workspace_size_runs.argtypes = [C.c_uint32, C.c_uint32, C.c_uint32, sz]
        lib.vd_components_label_thr_u8.argtypes = [C.POINTER(clib.ViewU8), C.POINTER(clib.Rect), C.c_uint8,
                                                   C.c_void_p, C.c_size_t, C.c_void_p, C.c_size_t, sz,
                                                   C.POINTER(CcStats)]
        lib.vd_components_label_thr_u16.argtypes = [C.POINTER(clib.ViewU16), C.POINTER(clib.Rect), C.c_uint16,
                                                    C.c_void_p, C.c_size_t, C.c_void_p, C.c_size_t, sz,
                                                    C.POINTER(CcStats)]
        for f in (lib.vd_components_workspace_size, lib.vd_components_label,
                  lib.vd_components_filter, lib.vd_rect_expand, lib.vd_components_workspace_size_runs,
                  lib.vd_components_label_thr_u8, lib.vd_components_label_thr_u16):
            f.restype = C.c_int
        _bound = True
    return lib


def workspace_size(width, height):
    """Bytes of workspace vd_components_label needs for a width x height ROI."""
    n = C.c_size_t()
    clib.check(_lib().vd_components_workspace_size(int(width), int(height), C.byref(n)),
               "vd_components_workspace_size")
    return n.value


def workspace_size_runs(width, height, max_runs):
    """Bytes of workspace for the thresholding labellers with a budget of max_runs runs."""
    n = C.c_size_t()
    clib.check(_lib().vd_components_workspace_size_runs(int(width), int(height), int(max_runs), C.byref(n)),
               "vd_components_workspace_size_runs")
    return n.value


def label_thr(plane, thr, roi=None, cap=None, max_runs=None):
    """vd_components_label_thr_u8/_u16: components of plane[roi] >= thr (uint8 or
    uint16 2-D array) without a mask. max_runs None = worst-case workspace (never
    runs out); else a workspace of workspace_size_runs(roi w, roi h, max_runs).
    Returns (components, status, stats dict runs/pixels/rows/labels); status is
    VD_OK or VD_ERR_CAPACITY (stats["rows"] < roi h: run budget; labels > cap:
    component capacity); other errors raise VdError."""
    a = np.asarray(plane)
    if a.ndim != 2 or a.dtype not in (np.uint8, np.uint16):
        raise ValueError("label_thr needs a 2-D uint8 or uint16 array")
    if a.strides[1] != a.itemsize or a.strides[0] < a.shape[1] * a.itemsize:
        a = np.ascontiguousarray(a)
    rw, rh = (a.shape[1], a.shape[0]) if roi is None else (int(roi[2]), int(roi[3]))
    if rw < 1 or rh < 1:
        raise clib.VdError(-1, "vd_components_label_thr")
    nbytes = workspace_size(rw, rh) if max_runs is None else workspace_size_runs(rw, rh, max_runs)
    ws, ws_ptr = clib.workspace(nbytes)
    if cap is None:
        cap = ((rw + 1) // 2) * ((rh + 1) // 2)
    out = np.zeros(max(int(cap), 1), dtype=COMPONENT_DTYPE)
    r = None if roi is None else C.byref(clib.Rect(*(int(t) for t in roi)))
    n = C.c_size_t()
    st_out = CcStats()
    if a.dtype == np.uint8:
        v = clib.view_u8(a)
        st = _lib().vd_components_label_thr_u8(C.byref(v), r, int(thr), ws_ptr, nbytes, out.ctypes.data,
                                               int(cap), C.byref(n), C.byref(st_out))
    else:
        v = clib.view_u16(a)
        st = _lib().vd_components_label_thr_u16(C.byref(v), r, int(thr), ws_ptr, nbytes, out.ctypes.data,
                                                int(cap), C.byref(n), C.byref(st_out))
    if st not in (clib.VD_OK, VD_ERR_CAPACITY):
        raise clib.VdError(st, "vd_components_label_thr")
    stats = {f: int(getattr(st_out, f)) for f, _ in CcStats._fields_}
    return out[:n.value].copy(), st, stats


class Labeller:
    """Keeps one workspace (sized for max_width x max_height) and an output
    array between calls, as firmware would; `label` allocates one per call."""

    def __init__(self, max_width, max_height, cap=None):
        self.bytes = workspace_size(max_width, max_height)
        self._ws, self._ws_ptr = clib.workspace(self.bytes)
        if cap is None:  # enough for any mask of this size
            cap = ((max_width + 1) // 2) * ((max_height + 1) // 2)
        self.out = np.zeros(int(cap), dtype=COMPONENT_DTYPE)

    def __call__(self, mask, roi=None, return_status=False):
        """Components of mask[roi] (nonzero = foreground) in image coordinates.
        Returns a structured array (COMPONENT_DTYPE); with return_status=True,
        (array, status) so VD_ERR_CAPACITY can be seen; other errors raise VdError."""
        mask = np.asarray(mask)
        if mask.dtype != np.uint8 or mask.ndim != 2:
            raise ValueError("label needs a 2-D uint8 mask")
        if mask.strides[1] != 1 or mask.strides[0] < mask.shape[1]:
            mask = np.ascontiguousarray(mask)
        v = clib.view_u8(mask)
        r = None if roi is None else C.byref(clib.Rect(*(int(t) for t in roi)))
        n = C.c_size_t()
        st = _lib().vd_components_label(C.byref(v), r, self._ws_ptr, self.bytes,
                                        self.out.ctypes.data, len(self.out), C.byref(n))
        if st not in (clib.VD_OK, VD_ERR_CAPACITY):
            raise clib.VdError(st, "vd_components_label")
        res = self.out[:n.value].copy()
        return (res, st) if return_status else res


def label(mask, roi=None, cap=None, return_status=False):
    """vd_components_label on a 2-D uint8 mask; roi = (x, y, w, h) or None.
    cap None = room for every possible component. See Labeller.__call__."""
    mask = np.asarray(mask)
    rw, rh = (mask.shape[1], mask.shape[0]) if roi is None else (int(roi[2]), int(roi[3]))
    if rw < 1 or rh < 1:
        raise clib.VdError(-1, "vd_components_label")
    return Labeller(rw, rh, cap)(mask, roi, return_status)


def rules_default():
    r = Rules()
    _lib().vd_components_rules_default(C.byref(r))
    return r


def filter(comps, rules=None):
    """vd_components_filter on a copy of comps (COMPONENT_DTYPE array); returns
    the kept rows in their original order. rules: Rules or None (paper's)."""
    arr = np.ascontiguousarray(np.array(comps, dtype=COMPONENT_DTYPE, copy=True))
    r = rules_default() if rules is None else rules
    kept = C.c_size_t()
    clib.check(_lib().vd_components_filter(arr.ctypes.data if len(arr) else None, len(arr),
                                           C.byref(r), C.byref(kept)), "vd_components_filter")
    return arr[:kept.value].copy()


def rect_expand(rect, frame_w, frame_h, wscale_q8=EXPAND_W_Q8, hscale_q8=EXPAND_H_Q8):
    """vd_rect_expand: (x, y, w, h) scaled about its centre and clipped to the frame."""
    out = clib.Rect()
    clib.check(_lib().vd_rect_expand(C.byref(clib.Rect(*(int(t) for t in rect))), int(wscale_q8),
                                     int(hscale_q8), int(frame_w), int(frame_h), C.byref(out)),
               "vd_rect_expand")
    return out.x, out.y, out.w, out.h


def as_cv2_stats(comps):
    """(n, 5) int array [x, y, w, h, area] like cv2's stats[1:], and (n, 2)
    float centroids in pixels (cx_q8 / 256), for comparisons."""
    stats = np.stack([comps["x"], comps["y"], comps["w"], comps["h"],
                      comps["area"].astype(np.int64)], axis=1) if len(comps) else np.zeros((0, 5), int)
    cents = np.stack([comps["cx_q8"], comps["cy_q8"]], axis=1) / 256.0 if len(comps) else np.zeros((0, 2))
    return stats, cents
