# SPDX-License-Identifier: MIT
"""32x32 network samples made by the C library itself (ctypes), so training sees
exactly the pixels the device sees.

    from vdtools.data.samples import sample32
    s = sample32(frame_u8, (x, y, w, h), "grey")    # (32, 32) uint8
    s = sample32(frame_u8, (x, y, w, h), "shape")   # refine mask (0/255) resampled

`vdtools.bindings.resample.resample(img, rect, w, h)` is the C resampler (vd_resample_u8), and
`resample_ref` the pure-numpy integer reference it is tested against.
"""
import numpy as np

from vdtools.bindings.resample import resample

INPUT_SIZE = 32
MODES = ("grey", "shape")

def clip_rect(rect, width, height):
    """(x, y, w, h) clipped to the image; ValueError if nothing is left."""
    x, y, w, h = (int(v) for v in rect)
    x0, y0 = max(x, 0), max(y, 0)
    x1, y1 = min(x + w, width), min(y + h, height)
    if x1 <= x0 or y1 <= y0:
        raise ValueError(f"rect {rect} does not overlap the {width}x{height} image")
    return x0, y0, x1 - x0, y1 - y0


def _axis_weights(s, d):
    """Dense (d, s) int64 weight matrix and its row total for one axis, as in
    lib/src/pixel/resample.c (area average if s >= d, else bilinear, exact)."""
    m = np.zeros((d, s), dtype=np.int64)
    if s >= d:
        for i in range(d):
            lo, hi = i * s, (i + 1) * s
            for k in range(lo // d, (hi - 1) // d + 1):
                m[i, k] = min((k + 1) * d, hi) - max(k * d, lo)
        return m, s
    for i in range(d):
        p = (2 * i + 1) * s - d
        if p <= 0:
            m[i, 0] = 2 * d
            continue
        k0, frac = divmod(p, 2 * d)
        if k0 >= s - 1:
            m[i, s - 1] = 2 * d
            continue
        m[i, k0] += 2 * d - frac
        m[i, k0 + 1] += frac
    return m, 2 * d


def resample_ref(img, rect=None, w=INPUT_SIZE, h=INPUT_SIZE):
    """Pure-numpy integer reference of vd_resample_u8 (same result, bit for bit)."""
    if rect is None:
        rect = (0, 0, img.shape[1], img.shape[0])
    x, y, rw, rh = rect
    roi = img[y:y + rh, x:x + rw].astype(np.int64)
    wx, tx = _axis_weights(rw, w)
    wy, ty = _axis_weights(rh, h)
    acc = wy @ roi @ wx.T
    t = tx * ty
    return ((acc + t // 2) // t).astype(np.uint8)


def _refine_mask(img, rect):
    """The refine stage's roi-sized 0/255 mask (vd_refine_region with the
    device's default config, vd_refine_cfg_default)."""
    try:
        from vdtools.bindings import refine  # bindings of refine.h (helper "contour")
    except ImportError as e:
        raise NotImplementedError(
            "shape mode needs tools/vdtools/bindings/refine.py (ctypes binding of vd_refine_region)") from e
    cfg = refine.default_cfg()
    mask, _stats = refine.refine_region(img, rect, median=cfg.median_ksize, edge_step=cfg.edge_step,
                                        window=cfg.window)
    return mask


def sample32(img_u8, rect, mode="grey", size=INPUT_SIZE):
    """The (size, size) uint8 network input (32x32 unless told: paper 003's verifier uses 64)
    for the candidate `rect` = (x, y, w, h) (clipped to the image) of a 2-D uint8 frame.
    mode 'grey': the grey crop resampled; 'shape': the refine stage's binary
    mask of the crop (vd_refine_region, default config) resampled."""
    img = np.asarray(img_u8)
    if img.dtype != np.uint8 or img.ndim != 2:
        raise ValueError("sample32 needs a 2-D uint8 frame")
    img = np.ascontiguousarray(img)
    r = clip_rect(rect, img.shape[1], img.shape[0])
    if mode == "grey":
        return resample(img, r, size, size)
    if mode == "shape":
        mask = np.ascontiguousarray(_refine_mask(img, r), dtype=np.uint8)
        return resample(mask, None, size, size)
    raise ValueError(f"mode must be one of {MODES}, not {mode!r}")
