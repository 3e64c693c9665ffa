# SPDX-License-Identifier: MIT
"""Oracle tests of contour.h: vd_contour_find_external must give the same
contours (points, start, direction and contour order) as
cv2.findContours(mask, RETR_EXTERNAL, CHAIN_APPROX_NONE), on real-frame masks
and on generated ones, and chain codes that lead from each point to the next."""
import cv2
import numpy as np

from vdtools.bindings import refine
from realdata import frame_paths

DX = np.array([1, 1, 0, -1, -1, -1, 0, 1])
DY = np.array([0, -1, -1, -1, 0, 1, 1, 1])


def assert_same_as_cv2(mask, what=""):
    ref, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    got, chains, boxes = refine.find_contours(mask)
    assert len(got) == len(ref), f"{what}: {len(got)} contours, cv2 {len(ref)}"
    for i, (g, r, ch, box) in enumerate(zip(got, ref, chains, boxes)):
        assert np.array_equal(g, r), f"{what}: contour {i} differs (len {len(g)} vs {len(r)})"
        assert tuple(box) == cv2.boundingRect(r), f"{what}: box {i}"
        pts = g.reshape(-1, 2)
        if len(pts) == 1:
            assert ch.tolist() == [refine.CHAIN_NONE]
        else:
            nxt = np.roll(pts, -1, axis=0)
            assert np.array_equal(pts[:, 0] + DX[ch], nxt[:, 0]) and np.array_equal(pts[:, 1] + DY[ch], nxt[:, 1])
    return len(ref)


def _frames(data_dir):
    msrs, uav = frame_paths(data_dir)
    picks = msrs[::70] + uav[::60]   # 8 + 8 frames, night and day, both views
    assert len(picks) >= 10
    return picks


def test_real_frames_threshold_masks(vdlib, data_dir):
    total = 0
    for path in _frames(data_dir):
        img = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
        assert img is not None, path
        p98 = int(np.percentile(img, 98))
        otsu, _ = cv2.threshold(img, 0, 255, cv2.THRESH_BINARY | cv2.THRESH_OTSU)
        for thr in (150, p98, int(otsu)):
            mask = np.where(img >= thr, 255, 0).astype(np.uint8)
            total += assert_same_as_cv2(mask, f"{path.name} thr {thr}")
    assert total > 100   # the masks are not trivial


def test_random_blobs():
    rng = np.random.default_rng(1)
    for it in range(60):
        h, w = rng.integers(1, 90, size=2)
        noise = rng.random((h, w)).astype(np.float32)
        k = int(rng.choice([1, 3, 5, 9]))
        smooth = cv2.GaussianBlur(noise, (k, k), 0) if k > 1 else noise
        mask = np.where(smooth > np.quantile(smooth, rng.uniform(0.3, 0.9)), 255, 0).astype(np.uint8)
        assert_same_as_cv2(mask, f"blobs {it}")


def test_sparse_wide_masks():
    """Wide, mostly-zero masks with rings, nested blobs and wide solid runs:
    the scan skips 32 zero / 8 equal pixels at a time; the skips must land on
    every border start and on the lnbd updates at hole borders."""
    rng = np.random.default_rng(3)
    for it in range(40):
        h, w = int(rng.integers(8, 60)), int(rng.integers(33, 300))
        mask = np.zeros((h, w), np.uint8)
        for _ in range(int(rng.integers(1, 8))):
            x, y = int(rng.integers(0, w)), int(rng.integers(0, h))
            bw, bh = int(rng.integers(1, 70)), int(rng.integers(1, 20))
            mask[y:y + bh, x:x + bw] = 255
            if bw > 4 and bh > 4 and rng.random() < 0.6:   # hole, sometimes with an island
                mask[y + 2:y + bh - 2, x + 2:x + bw - 2] = 0
                if bw > 8 and bh > 8 and rng.random() < 0.5:
                    mask[y + 4:y + bh - 4, x + 4:x + bw - 4] = 255
        if it % 3 == 0:
            mask[:, -1] = 255   # a run to the last column
        assert_same_as_cv2(mask, f"sparse {it}")


def test_salt_and_pepper():
    rng = np.random.default_rng(2)
    for it in range(40):
        h, w = rng.integers(1, 40, size=2)
        mask = np.where(rng.random((h, w)) < rng.uniform(0.05, 0.95), 255, 0).astype(np.uint8)
        assert_same_as_cv2(mask, f"noise {it}")


def test_lines_points_and_border():
    m = np.zeros((20, 30), np.uint8)
    cv2.line(m, (2, 3), (25, 17), 255, 1)        # 1-pixel diagonal-ish line
    cv2.line(m, (5, 15), (5, 19), 255, 1)        # vertical, touching the bottom
    cv2.line(m, (0, 0), (29, 0), 255, 1)         # along the top edge
    m[10, 28] = 255                              # single pixels
    m[19, 29] = 255
    m[8, 0] = 255
    assert assert_same_as_cv2(m, "lines") >= 5
    assert_same_as_cv2(np.full((7, 9), 255, np.uint8), "full")
    assert_same_as_cv2(np.full((1, 1), 255, np.uint8), "1x1")
    assert_same_as_cv2(np.zeros((4, 4), np.uint8), "empty")
    assert_same_as_cv2(np.full((1, 12), 7, np.uint8), "one row, value 7")
    assert_same_as_cv2(np.full((12, 1), 255, np.uint8), "one column")


def test_nested_rings_report_only_outermost():
    m = np.zeros((40, 40), np.uint8)
    cv2.rectangle(m, (2, 2), (37, 37), 255, 1)
    cv2.rectangle(m, (6, 6), (30, 30), 255, 2)   # inside the hole: ignored
    m[15:20, 15:20] = 255
    cv2.circle(m, (34, 8), 2, 255, -1)           # inside the outer ring's hole too
    assert assert_same_as_cv2(m, "nested") == 1
    m2 = np.zeros((30, 50), np.uint8)
    cv2.circle(m2, (12, 15), 9, 255, 1)
    cv2.circle(m2, (12, 15), 3, 255, -1)
    cv2.circle(m2, (37, 15), 9, 255, -1)
    assert assert_same_as_cv2(m2, "ring + disc") == 2


def test_capacity_keeps_raster_prefix():
    m = np.zeros((10, 10), np.uint8)
    m[1, 1] = m[4, 4] = m[7, 7] = 255
    st, xy, chain, recs = refine.find_contours(m, contours_cap=2, raw=True)
    assert st == -3 and len(recs) == 2
    # The two found first in raster order, listed in cv2's relative order.
    assert xy.tolist() == [[4, 4], [1, 1]]
    st, xy, chain, recs = refine.find_contours(m, points_cap=3, raw=True)
    assert st == 0 and len(recs) == 3
