# SPDX-License-Identifier: MIT
"""Oracle tests of refine.h: the whole paper-001 §3 pipeline against a numpy
reference written here (cv2.medianBlur, cv2 Otsu, scipy hole filling, numpy
edges, exact eq. (1) in Python integers), on candidate areas of real frames
and on generated images; the parts (eq. (1), hole filling, edges) alone."""
import cv2
import numpy as np
from scipy import ndimage

from vdtools.bindings import refine
from realdata import frame_paths

CROSS = np.array([[0, 1, 0], [1, 1, 1], [0, 1, 0]], bool)


def maxdist_ref(hist):
    """eq. (1) of paper 001, exact: argmax_T (s*n - S*c)^2 / (c*(n-c)), smallest T on ties."""
    hist = [int(v) for v in hist]
    n = sum(hist)
    total = sum(i * v for i, v in enumerate(hist))
    best, best_t, c, s = None, None, 0, 0
    for t in range(255):
        c += hist[t]
        s += t * hist[t]
        if c == 0 or c == n:
            continue
        num, den = (s * n - total * c) ** 2, c * (n - c)
        if best is None or num * best[1] > best[0] * den:
            best, best_t = (num, den), t
    return best_t


def edges_ref(b):
    """Foreground with a background 4-neighbour; outside counts as background."""
    return b & ~ndimage.binary_erosion(b, CROSS, border_value=0)


def refine_ref(img, roi, median=3, step=5, window=5):
    x, y, w, h = roi
    full = cv2.medianBlur(img, median) if median else img
    f = full[y:y + h, x:x + w]
    t, _ = cv2.threshold(np.ascontiguousarray(f), 0, 255, cv2.THRESH_BINARY | cv2.THRESH_OTSU)
    b = ndimage.binary_fill_holes(f > t)     # 4-connected background by default
    e = edges_ref(b)
    out = np.where(b, 255, 0).astype(np.uint8)
    half = window // 2
    windows = 0
    for k in np.flatnonzero(e)[::step]:
        cy, cx = divmod(int(k), w)
        y0, y1, x0, x1 = max(cy - half, 0), min(cy + half, h - 1), max(cx - half, 0), min(cx + half, w - 1)
        win = f[y0:y1 + 1, x0:x1 + 1]
        tl = maxdist_ref(np.bincount(win.ravel(), minlength=256))
        if tl is not None:
            out[y0:y1 + 1, x0:x1 + 1] = np.where(win > tl, 255, 0)
            windows += 1
    return out, {"otsu_thr": int(t), "edge_points": int(e.sum()), "local_windows": windows,
                 "fg_pixels": int((out > 0).sum())}


def expand(box, fw, fh):
    """Paper step (1): 1.5x horizontally, 2x vertically about the centre, clipped."""
    x, y, w, h = box
    cx, cy = x + w / 2, y + h / 2
    nw, nh = w * 1.5, h * 2.0
    x0, y0 = max(int(round(cx - nw / 2)), 0), max(int(round(cy - nh / 2)), 0)
    x1, y1 = min(int(round(cx + nw / 2)), fw), min(int(round(cy + nh / 2)), fh)
    return x0, y0, x1 - x0, y1 - y0


def candidate_rois(img, limit=12):
    """Hot spots (98th percentile), area >= 30, expanded like the paper."""
    thr = max(int(np.percentile(img, 98)), 1)
    n, _, stats, _ = cv2.connectedComponentsWithStats((img >= thr).astype(np.uint8), connectivity=8)
    boxes = [tuple(int(v) for v in s[:4]) for s in stats[1:] if s[4] >= 30]
    boxes.sort(key=lambda b: -b[2] * b[3])
    return [expand(b, img.shape[1], img.shape[0]) for b in boxes[:limit]]


def _frames(data_dir):
    msrs, uav = frame_paths(data_dir)
    return [p for p in msrs if p.name.endswith("N.png")][::40] + uav[::60]


def test_real_candidates_match_reference(vdlib, data_dir):
    n = 0
    for path in _frames(data_dir):
        img = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
        for roi in candidate_rois(img):
            got, st = refine.refine_region(img, roi)
            want, wst = refine_ref(img, roi)
            assert st == wst, f"{path.name} {roi}: {st} vs {wst}"
            assert np.array_equal(got, want), f"{path.name} {roi}: {np.count_nonzero(got != want)} pixels differ"
            n += 1
    assert n >= 40


def test_otsu_threshold_matches_cv2_on_median_region(vdlib, data_dir):
    for path in _frames(data_dir)[:8]:
        img = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
        for median in (0, 3, 5):
            blurred = cv2.medianBlur(img, median) if median else img
            for roi in candidate_rois(img, limit=4):
                x, y, w, h = roi
                t, _ = cv2.threshold(np.ascontiguousarray(blurred[y:y + h, x:x + w]), 0, 255,
                                     cv2.THRESH_BINARY | cv2.THRESH_OTSU)
                _, st = refine.refine_region(img, roi, median=median)
                assert st["otsu_thr"] == int(t), f"{path.name} {roi} median {median}"


def test_generated_images_all_settings(vdlib):
    rng = np.random.default_rng(3)
    for it in range(40):
        h, w = (int(v) for v in rng.integers(8, 70, size=2))
        img = (rng.random((h, w)) * 60 + 40).astype(np.uint8)
        for _ in range(int(rng.integers(1, 4))):     # warm blobs, brighter bottom ("wheels")
            cx, cy = int(rng.integers(0, w)), int(rng.integers(0, h))
            cv2.ellipse(img, (cx, cy), (int(rng.integers(2, 15)), int(rng.integers(2, 12))), 0, 0, 360,
                        int(rng.integers(120, 200)), -1)
            cv2.rectangle(img, (cx - 3, cy + 2), (cx + 3, cy + 4), int(rng.integers(200, 256)), -1)
        x0, y0 = int(rng.integers(0, w // 3)), int(rng.integers(0, h // 3))
        roi = (x0, y0, int(rng.integers(1, w - x0 + 1)), int(rng.integers(1, h - y0 + 1)))
        median = int(rng.choice([0, 3, 5]))
        step = int(rng.choice([1, 3, 5, 9]))
        window = int(rng.choice([3, 5, 7, 15]))
        got, st = refine.refine_region(img, roi, median, step, window)
        want, wst = refine_ref(img, roi, median, step, window)
        assert st == wst, f"it {it}"
        assert np.array_equal(got, want), f"it {it}: roi {roi} m{median} s{step} w{window}"


def test_maxdist_matches_exact_reference():
    rng = np.random.default_rng(4)
    for it in range(400):
        n = int(rng.integers(1, 256))
        levels = rng.integers(0, 256, size=int(rng.integers(1, 6)))
        vals = rng.choice(levels, size=n)
        hist = np.bincount(vals, minlength=256)
        assert refine.maxdist_from_hist(hist) == maxdist_ref(hist), f"it {it}"
    # Hand-worked 5x5: 15 pixels at 10 and 10 at 200 -> any split between; smallest is 10.
    hist = np.zeros(256, np.uint32)
    hist[10], hist[200] = 15, 10
    assert refine.maxdist_from_hist(hist) == 10
    hist[10] = 25
    hist[200] = 0
    assert refine.maxdist_from_hist(hist) is None


def test_fill_holes_matches_scipy():
    rng = np.random.default_rng(5)
    for it in range(60):
        h, w = (int(v) for v in rng.integers(1, 50, size=2))
        m = np.where(rng.random((h, w)) < rng.uniform(0.2, 0.8), 255, 0).astype(np.uint8)
        want = np.where(ndimage.binary_fill_holes(m > 0), 255, 0).astype(np.uint8)
        assert np.array_equal(refine.fill_holes(m), want), f"it {it}"


def test_edges_match_numpy():
    rng = np.random.default_rng(6)
    for it in range(60):
        h, w = (int(v) for v in rng.integers(1, 40, size=2))
        m = np.where(rng.random((h, w)) < 0.6, 255, 0).astype(np.uint8)
        x0, y0 = int(rng.integers(0, w)), int(rng.integers(0, h))
        roi = (x0, y0, int(rng.integers(1, w - x0 + 1)), int(rng.integers(1, h - y0 + 1)))
        x, y, rw, rh = roi
        want = np.where(edges_ref(m[y:y + rh, x:x + rw] > 0), 255, 0).astype(np.uint8)
        assert np.array_equal(refine.edges(m, roi), want), f"it {it}"
