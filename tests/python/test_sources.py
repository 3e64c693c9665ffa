# SPDX-License-Identifier: MIT
"""Oracle tests of contrast.h and windows.h (vdtools.bindings.sources) against OpenCV/numpy on real and
generated frames, and of the candidate-recall helpers (vdtools.evaluation.recall)."""
import cv2
import numpy as np
import pytest

from vdtools.data import dataset as D
from vdtools.evaluation import recall as R
from vdtools.bindings import sources as S


def oracle_map(img, r, polarity=S.BOTH):
    """Clipped box mean with cv2 (zero border, divided by the in-frame count), round half up."""
    k = np.ones(2 * r + 1, np.float64)
    s = cv2.sepFilter2D(img.astype(np.float64), -1, k, k, borderType=cv2.BORDER_CONSTANT)
    n = cv2.sepFilter2D(np.ones(img.shape, np.float64), -1, k, k, borderType=cv2.BORDER_CONSTANT)
    s, n = np.rint(s).astype(np.int64), np.rint(n).astype(np.int64)
    d = img.astype(np.int64) - (s + n // 2) // n
    if polarity == S.COLD:
        d = -d
    elif polarity == S.BOTH:
        d = np.abs(d)
    return np.clip(d, 0, 255).astype(np.uint8)


def oracle_candidates(img, r=16, thr=24):
    m = (oracle_map(img, r) >= thr).astype(np.uint8)
    n, _, st, _ = cv2.connectedComponentsWithStats(m, connectivity=8)
    out = []
    for x, y, w, h, a in st[1:]:
        q = (256 * h + w // 2) // w   # aspect h/w in Q8, round half up
        if 77 <= q <= 384 and a >= 120:
            out.append((int(x), int(y), int(w), int(h), int(a)))
    return out


@pytest.fixture(scope="module")
def real_frames(data_dir):
    msrs = sorted((data_dir / "msrs" / "images").glob("*N.png"))[:3] + sorted((data_dir / "msrs" / "images").glob("*D.png"))[:2]
    hit = sorted((data_dir / "hit-uav" / "frames" / "images").glob("*.jpg"))[:3]
    return [D.read_frame(p) for p in msrs + hit]


def test_contrast_map_real(vdlib, real_frames):
    for img in real_frames:
        for r, pol in ((16, S.BOTH), (5, S.WARM), (40, S.COLD)):
            assert np.array_equal(S.contrast_map(img, r, pol), oracle_map(img, r, pol))


def test_contrast_map_generated(vdlib):
    rng = np.random.default_rng(3)
    for _ in range(20):
        h, w = rng.integers(1, 70, 2)
        img = rng.integers(0, 256, (h, w), dtype=np.uint8)
        r = int(rng.integers(1, 30))
        pol = int(rng.integers(0, 3))
        assert np.array_equal(S.contrast_map(img, r, pol), oracle_map(img, r, pol))
    # a non-contiguous view (odd stride)
    big = rng.integers(0, 256, (40, 57), dtype=np.uint8)
    assert np.array_equal(S.contrast_map(big[:, 3:50], 7), oracle_map(np.ascontiguousarray(big[:, 3:50]), 7))


def test_contrast_candidates_real(vdlib, real_frames):
    for img in real_frames:
        got = S.contrast_candidates(img)
        exp = oracle_candidates(img)
        assert [(int(c["x"]), int(c["y"]), int(c["w"]), int(c["h"]), int(c["area"])) for c in got] == exp


def test_contrast_finds_cold_car():
    img = np.full((120, 160), 120, np.uint8)
    img[60:80, 40:75] = 70   # a parked car colder than the road
    img[20:32, 100:120] = 200   # a warm one
    boxes = sorted((int(c["x"]), int(c["y"]), int(c["w"]), int(c["h"])) for c in S.contrast_candidates(img))
    # a one-row halo around the large cold region is allowed (the road beside it has a lowered mean)
    assert len(boxes) == 2
    assert D.iou(boxes[0], (40, 60, 35, 20)) >= 0.85 and boxes[1] == (100, 20, 20, 12)


def python_windows(fw, fh, bands, aspects, step, stride, hy=0, k=0, tol=512):
    """Straight transcription of the rule in windows.h."""
    lo, hi = min(b[2] for b in bands), max(b[3] for b in bands)
    out, h = [], lo
    while h <= hi:
        for a in aspects:
            w = max(1, (h * 256 + a // 2) // a)
            if h > fh or w > fw:
                continue
            sx, sy = max(1, w * stride >> 8), max(1, h * stride >> 8)
            ox, oy = ((fw - w) % sx) // 2, ((fh - h) % sy) // 2
            for y in range(oy, fh - h + 1, sy):
                yb = y + h - 1
                ok = any(b[0] <= yb <= b[1] and b[2] <= h <= b[3] for b in bands)
                if ok and k:
                    e = k * (yb - hy)
                    ok = yb > hy and h * 256 * tol >= e * 256 and h * 65536 <= e * tol
                if ok:
                    out += [(x, y, w, h) for x in range(ox, fw - w + 1, sx)]
        h = max(h + 1, (h * step + 128) >> 8)
    return out


def test_windows_vs_python(vdlib):
    bands = [(230, 270, 10, 30), (245, 310, 25, 70), (270, 479, 50, 300)]
    got = S.windows(640, 480, bands=bands, aspects=(1.0, 0.75), step=1.25, stride=0.25, horizon_y=230,
                    ground_k=1.6, ground_tol=2.0)
    exp = python_windows(640, 480, bands, [256, 192], 320, 64, 230, 410, 512)
    assert [tuple(b) for b in got.tolist()] == exp
    got = S.windows(640, 512, preset="hit")
    exp = python_windows(640, 512, [(0, 511, 12, 120)], [256], 361, 128)
    assert [tuple(b) for b in got.tolist()] == exp


def test_windows_capacity(vdlib):
    cfg = S.windows_cfg(640, 480, preset_name="table1", max_windows=100)
    b, st = S.windows_generate(cfg, cap=1000, return_status=True)
    assert st == S.VD_ERR_CAPACITY and len(b) == 100
    assert S.windows_count(cfg) > 100


def test_frame_candidates_for_mining(vdlib, real_frames):
    img = real_frames[0]
    got = list(S.frame_candidates(img, dataset="msrs"))
    srcs = {s for _, s in got}
    assert srcs <= {"window", "contrast"} and "window" in srcs
    for (x, y, w, h), _ in got:
        assert 0 <= x and 0 <= y and x + w <= img.shape[1] and y + h <= img.shape[0]


def test_iou_matrix_matches_dataset_iou():
    rng = np.random.default_rng(0)
    a = rng.integers(0, 50, (20, 4)) + [0, 0, 1, 1]
    b = rng.integers(0, 50, (15, 4)) + [0, 0, 1, 1]
    m = R.iou_matrix(a, b)
    for i in range(len(a)):
        for j in range(len(b)):
            assert m[i, j] == pytest.approx(D.iou(tuple(a[i]), tuple(b[j])))
