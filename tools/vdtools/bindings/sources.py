# SPDX-License-Identifier: MIT
"""ctypes bindings of windows.h and contrast.h, and candidate boxes per source for a frame.

    from vdtools.bindings import sources as S
    S.windows(640, 480, preset="msrs")                 # (N, 4) int32 boxes x, y, w, h
    S.contrast_map(img, radius=16)                     # uint8 |I - box mean|
    S.contrast_candidates(img)                         # COMPONENT_DTYPE rows (components.py)
    for box, source in S.frame_candidates(img, ("window", "contrast")):   # hard-negative mining
        ...

`frame_candidates` is the entry point for training with hard negatives ("dbn-train"):
it yields the boxes the C generators produce for a frame, exactly as the detector's
window/contrast sources see them (before verification).

Window presets (per camera mounting, see lib/include/vd/windows.h):
  "msrs"  road-level 640x480 (MSRS): horizon row 230, ground slope k = 1.6 (fitted to the car
          boxes: median height vs bottom row), tolerance x2, paper 000 Table 1 bands
          far 10..30 / middle 25..70 / near 50..200 px, extended to 300 px for the closest rows.
  "hit"   drone view (HIT-UAV, 60-130 m): no horizon; one band over every row, heights 12..120,
          half-window stride and step 1.41 (a quarter stride gives 111 858 windows per frame).
  "table1" the three Table 1 size ranges over the whole frame (no ground model).
"""
import ctypes as C

import numpy as np

from vdtools.bindings import clib
from vdtools.bindings.components import COMPONENT_DTYPE, Rules

MAX_BANDS, MAX_ASPECTS = 4, 4
BOTH, WARM, COLD = 0, 1, 2
THR_FIXED, THR_PERCENTILE = 0, 1
VD_ERR_CAPACITY = -3


class WindowBand(C.Structure):
    _fields_ = [("y_min", C.c_int32), ("y_max", C.c_int32), ("min_h", C.c_uint16), ("max_h", C.c_uint16)]


class WindowsCfg(C.Structure):
    _fields_ = [("frame_w", C.c_uint32), ("frame_h", C.c_uint32), ("n_bands", C.c_uint8), ("n_aspects", C.c_uint8),
                ("scale_step_q8", C.c_uint16), ("stride_q8", C.c_uint16), ("aspect_q8", C.c_uint16 * MAX_ASPECTS),
                ("bands", WindowBand * MAX_BANDS), ("horizon_y", C.c_int32), ("ground_k_q8", C.c_uint16),
                ("ground_tol_q8", C.c_uint16), ("max_windows", C.c_uint32)]


class ContrastCfg(C.Structure):
    _fields_ = [("radius", C.c_uint16), ("polarity", C.c_uint8), ("thr_mode", C.c_uint8), ("thr_u8", C.c_uint8),
                ("reserved", C.c_uint8), ("permille", C.c_uint16), ("rules", Rules)]


_bound = False


def _lib():
    global _bound
    lib = clib.load()
    if not _bound:
        sz = C.POINTER(C.c_size_t)
        lib.vd_windows_resolve.argtypes = [C.POINTER(WindowsCfg)]
        lib.vd_windows_generate.argtypes = [C.POINTER(WindowsCfg), C.c_void_p, C.c_size_t, sz]
        lib.vd_windows_count.argtypes = [C.POINTER(WindowsCfg), C.POINTER(C.c_uint32)]
        lib.vd_contrast_map_workspace_size.argtypes = [C.c_uint32, sz]
        lib.vd_contrast_map_u8.argtypes = [C.POINTER(clib.ViewU8), C.c_uint32, C.c_uint8, C.c_void_p, C.c_size_t,
                                           C.POINTER(clib.ImageU8)]
        lib.vd_contrast_workspace_size.argtypes = [C.c_uint32, C.c_uint32, sz]
        lib.vd_contrast_candidates.argtypes = [C.POINTER(clib.ViewU8), C.POINTER(ContrastCfg), C.c_void_p,
                                               C.c_size_t, C.c_void_p, C.c_size_t, sz, C.POINTER(C.c_uint8)]
        for f in (lib.vd_windows_resolve, lib.vd_windows_generate, lib.vd_windows_count,
                  lib.vd_contrast_map_workspace_size, lib.vd_contrast_map_u8, lib.vd_contrast_workspace_size,
                  lib.vd_contrast_candidates):
            f.restype = C.c_int
        _bound = True
    return lib


# ---------------------------------------------------------------- windows

def preset(name, frame_w, frame_h):
    """Keyword settings of windows_cfg for a camera mounting (see the module doc)."""
    if name == "msrs":
        hy = 230 * frame_h // 480
        return dict(bands=[(hy, hy + 40, 10, 30), (hy + 15, hy + 80, 25, 70), (hy + 40, frame_h - 1, 50, 300)],
                    horizon_y=hy, ground_k=1.6, ground_tol=2.0, aspects=(1.0,), stride=0.25, step=1.25)
    if name == "hit":
        return dict(bands=[(0, frame_h - 1, 12, 120)], aspects=(1.0,), stride=0.5, step=1.41)
    if name == "table1":
        return dict(bands=[(0, frame_h - 1, 10, 30), (0, frame_h - 1, 25, 70), (0, frame_h - 1, 50, 200)],
                    aspects=(1.0,), stride=0.25, step=1.25)
    raise ValueError(f"unknown window preset {name!r}")


def windows_cfg(frame_w, frame_h, bands=None, aspects=None, step=None, stride=None, horizon_y=0, ground_k=None,
                ground_tol=None, max_windows=0, preset_name=None):
    """A WindowsCfg. bands: [(y_min, y_max, min_h, max_h)]; aspects: h/w floats; step, stride,
    ground_k, ground_tol: floats (converted to Q8); None = the C default."""
    if preset_name is not None:
        kw = preset(preset_name, frame_w, frame_h)
        kw.update({k: v for k, v in dict(bands=bands, aspects=aspects, step=step, stride=stride,
                                          ground_k=ground_k, ground_tol=ground_tol).items() if v is not None})
        return windows_cfg(frame_w, frame_h, max_windows=max_windows, horizon_y=kw.pop("horizon_y", horizon_y), **kw)
    c = WindowsCfg()
    c.frame_w, c.frame_h = int(frame_w), int(frame_h)
    q8 = lambda v: int(round(v * 256))
    if bands:
        c.n_bands = len(bands)
        for i, (y0, y1, h0, h1) in enumerate(bands):
            c.bands[i] = WindowBand(int(y0), int(y1), int(h0), int(h1))
    if aspects:
        c.n_aspects = len(aspects)
        for i, a in enumerate(aspects):
            c.aspect_q8[i] = q8(a)
    c.scale_step_q8 = q8(step) if step else 0
    c.stride_q8 = q8(stride) if stride else 0
    c.horizon_y = int(horizon_y)
    c.ground_k_q8 = q8(ground_k) if ground_k else 0
    c.ground_tol_q8 = q8(ground_tol) if ground_tol else 0
    c.max_windows = int(max_windows)
    return c


def windows_count(cfg):
    n = C.c_uint32()
    clib.check(_lib().vd_windows_count(C.byref(cfg), C.byref(n)), "vd_windows_count")
    return n.value


def windows_generate(cfg, cap=None, return_status=False):
    """vd_windows_generate -> (N, 4) int32 array (x, y, w, h). cap None = room for all
    (bounded by cfg.max_windows in C)."""
    if cap is None:
        cap = max(windows_count(cfg), 1)
    out = np.zeros((int(cap), 4), dtype=np.int32)
    n = C.c_size_t()
    st = _lib().vd_windows_generate(C.byref(cfg), out.ctypes.data if cap else None, int(cap), C.byref(n))
    if st not in (clib.VD_OK, VD_ERR_CAPACITY):
        raise clib.VdError(st, "vd_windows_generate")
    res = out[:n.value].copy()
    return (res, st) if return_status else res


def windows(frame_w, frame_h, preset=None, max_windows=1048576, **kw):
    """All windows of a configuration (preset name and/or windows_cfg keywords)."""
    cfg = windows_cfg(frame_w, frame_h, preset_name=preset, max_windows=max_windows, **kw)
    return windows_generate(cfg)


# ---------------------------------------------------------------- contrast

def contrast_map(img, radius=16, polarity=BOTH):
    """vd_contrast_map_u8 on a 2-D uint8 array -> uint8 array of the same shape."""
    a = np.ascontiguousarray(img, dtype=np.uint8)
    lib = _lib()
    n = C.c_size_t()
    clib.check(lib.vd_contrast_map_workspace_size(a.shape[1], C.byref(n)), "vd_contrast_map_workspace_size")
    ws, wp = clib.workspace(n.value)
    dst = np.zeros_like(a)
    v, d = clib.view_u8(a), clib.view_u8(dst)
    clib.check(lib.vd_contrast_map_u8(C.byref(v), int(radius), int(polarity), wp, n.value, C.byref(d)),
               "vd_contrast_map_u8")
    return dst


def contrast_cfg(radius=0, polarity=BOTH, thr_mode=THR_FIXED, thr=0, permille=0, rules=None):
    c = ContrastCfg()
    c.radius, c.polarity, c.thr_mode, c.thr_u8, c.permille = int(radius), int(polarity), int(thr_mode), int(thr), \
        int(permille)
    if rules is not None:
        c.rules = rules
    return c


class ContrastSource:
    """Keeps one workspace sized for max_width x max_height (as firmware would)."""

    def __init__(self, max_width, max_height, cap=1024, **cfg):
        n = C.c_size_t()
        clib.check(_lib().vd_contrast_workspace_size(int(max_width), int(max_height), C.byref(n)),
                   "vd_contrast_workspace_size")
        self.bytes = n.value
        self._ws, self._wp = clib.workspace(n.value)
        self.cfg = contrast_cfg(**cfg)
        self.out = np.zeros(int(cap), dtype=COMPONENT_DTYPE)
        self.thr_used = None
        self.status = clib.VD_OK

    def __call__(self, img):
        a = np.ascontiguousarray(img, dtype=np.uint8)
        v = clib.view_u8(a)
        n = C.c_size_t()
        thr = C.c_uint8()
        st = _lib().vd_contrast_candidates(C.byref(v), C.byref(self.cfg), self._wp, self.bytes,
                                           self.out.ctypes.data, len(self.out), C.byref(n), C.byref(thr))
        if st not in (clib.VD_OK, VD_ERR_CAPACITY):
            raise clib.VdError(st, "vd_contrast_candidates")
        self.thr_used, self.status = thr.value, st
        return self.out[:n.value].copy()


def contrast_candidates(img, cap=1024, **cfg):
    """Contrast candidates of one frame: COMPONENT_DTYPE rows (box, area, centroid)."""
    return ContrastSource(img.shape[1], img.shape[0], cap=cap, **cfg)(img)


# ---------------------------------------------------------------- per-frame candidates

def default_preset(dataset, frame_w, frame_h):
    """Window preset for a data set name ("msrs" | "hit" | "seq"), else Table 1 over the frame."""
    return {"msrs": "msrs", "hit": "hit", "seq": "hit"}.get(dataset, "table1")


def frame_candidates(img, sources=("window", "contrast"), dataset=None, window_preset=None, window_kw=None,
                     contrast_kw=None, max_windows=4096):
    """Yields (box (x, y, w, h) ints, source name) for one 8-bit frame from the C generators:
    "window" (vd_windows_generate with the mounting preset of `dataset`, or `window_preset`) and
    "contrast" (vd_contrast_candidates, component boxes). For hard-negative mining: filter the
    boxes by IoU with the ground truth yourself (e.g. < 0.2 with every vehicle)."""
    fh, fw = img.shape
    if "contrast" in sources:
        for c in contrast_candidates(img, **(contrast_kw or {})):
            yield (int(c["x"]), int(c["y"]), int(c["w"]), int(c["h"])), "contrast"
    if "window" in sources:
        name = window_preset or default_preset(dataset, fw, fh)
        for b in windows(fw, fh, preset=name, max_windows=max_windows, **(window_kw or {})):
            yield tuple(int(v) for v in b), "window"
