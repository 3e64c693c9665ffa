# SPDX-License-Identifier: MIT
"""components.h against OpenCV: cv2.connectedComponentsWithStats(connectivity=8)
on real MSRS / HIT-UAV frames thresholded three ways, and on random masks and ROIs;
the thresholding labellers (no mask, run budget) on real 8-bit and generated 16-bit frames.
Counts, boxes, areas and order must be equal; centroids within 1/256 px.
Also the rules and the expansion against a Python transcription of the header."""
import cv2
import numpy as np
import pytest

from vdtools.bindings import clib
from vdtools.bindings import components as cc

N_FRAMES = 15  # per data set; frames spread evenly over the sorted file list


def _frames(data_dir):
    out = []
    for sub, pat in (("msrs/images", "*.png"), ("hit-uav/frames/images", "*.jpg")):
        files = sorted((data_dir / sub).glob(pat))
        if not files:
            pytest.skip(f"no frames in {data_dir / sub}")
        for f in files[:: max(1, len(files) // N_FRAMES)][:N_FRAMES]:
            img = cv2.imread(str(f), cv2.IMREAD_GRAYSCALE)
            assert img is not None, f
            out.append((f.name, img))
    return out


def _masks(img):
    """The three thresholds of the task: 150 (paper), the frame's 99th percentile, Otsu."""
    p99 = int(np.percentile(img, 99))
    otsu, _ = cv2.threshold(img, 0, 255, cv2.THRESH_BINARY | cv2.THRESH_OTSU)
    return {"150": np.where(img >= 150, 255, 0).astype(np.uint8),
            "p99": np.where(img >= p99, 255, 0).astype(np.uint8),
            "otsu": np.where(img > otsu, 255, 0).astype(np.uint8)}


def _assert_matches_cv2(comps, mask, roi=None, what=""):
    x0, y0 = (0, 0) if roi is None else roi[:2]
    crop = mask if roi is None else mask[roi[1]:roi[1] + roi[3], roi[0]:roi[0] + roi[2]]
    n, _, stats, cents = cv2.connectedComponentsWithStats(crop, connectivity=8)
    stats = stats[1:].astype(np.int64)
    stats[:, 0] += x0
    stats[:, 1] += y0
    cents = cents[1:] + np.array([x0, y0])
    got, got_c = cc.as_cv2_stats(comps)
    assert len(comps) == n - 1, f"{what}: {len(comps)} components, OpenCV {n - 1}"
    np.testing.assert_array_equal(got, stats, err_msg=what)
    err = np.abs(got_c - cents).max(initial=0.0)
    assert err <= 1 / 256 + 1e-9, f"{what}: centroid off by {err * 256:.3f}/256 px"


def test_real_frames_match_opencv(vdlib, data_dir):
    frames = _frames(data_dir)
    lab = cc.Labeller(640, 512)
    total = 0
    for name, img in frames:
        for kind, mask in _masks(img).items():
            comps, st = lab(mask, return_status=True)
            assert st == clib.VD_OK
            _assert_matches_cv2(comps, mask, what=f"{name} thr {kind}")
            total += len(comps)
    assert total > 100  # the frames do produce plenty of components


def test_real_frame_rois(vdlib, data_dir):
    rng = np.random.default_rng(5)
    name, img = _frames(data_dir)[1]
    mask = _masks(img)["otsu"]
    h, w = mask.shape
    lab = cc.Labeller(w, h)
    for _ in range(20):
        x, y = int(rng.integers(0, w - 1)), int(rng.integers(0, h - 1))
        roi = (x, y, int(rng.integers(1, w - x + 1)), int(rng.integers(1, h - y + 1)))
        _assert_matches_cv2(lab(mask, roi), mask, roi, what=f"{name} roi {roi}")


@pytest.mark.parametrize("seed", range(6))
def test_random_masks_and_rois(vdlib, seed):
    rng = np.random.default_rng(seed)
    for _ in range(15):
        h, w = int(rng.integers(1, 130)), int(rng.integers(1, 130))
        kind = rng.integers(0, 3)
        if kind == 0:  # noise of random density, random nonzero values
            mask = np.where(rng.random((h, w)) < rng.random(), rng.integers(1, 256, (h, w)), 0).astype(np.uint8)
        elif kind == 1:  # blurred noise: blobs with holes and long merges
            noise = cv2.GaussianBlur(rng.random((h, w)).astype(np.float32), (0, 0), 2.0)
            mask = np.where(noise > np.median(noise), 255, 0).astype(np.uint8)
        else:  # rectangles
            mask = np.zeros((h, w), np.uint8)
            for _ in range(int(rng.integers(1, 30))):
                x, y = int(rng.integers(0, w)), int(rng.integers(0, h))
                mask[y:y + int(rng.integers(1, 12)), x:x + int(rng.integers(1, 12))] = 255
        _assert_matches_cv2(cc.label(mask), mask, what=f"seed {seed} {w}x{h}")
        x, y = int(rng.integers(0, w)), int(rng.integers(0, h))
        roi = (x, y, int(rng.integers(1, w - x + 1)), int(rng.integers(1, h - y + 1)))
        # a strided view: the C side must honour the stride
        big = np.full((h, w + 13), 77, np.uint8)
        big[:, :w] = mask
        _assert_matches_cv2(cc.label(big[:, :w], roi), mask, roi, what=f"seed {seed} roi {roi}")


def test_worst_cases_fill_the_workspace(vdlib):
    h, w = 512, 640
    yy, xx = np.mgrid[0:h, 0:w]
    checker = np.where((xx + yy) % 2 == 0, 255, 0).astype(np.uint8)  # max runs, 1 component
    _assert_matches_cv2(cc.label(checker), checker, what="checkerboard")
    dots = np.where((xx % 2 == 0) & (yy % 2 == 0), 255, 0).astype(np.uint8)  # max components
    comps = cc.label(dots)
    assert len(comps) == 320 * 256
    _assert_matches_cv2(comps, dots, what="dots")
    full = np.full((h, w), 255, np.uint8)
    _assert_matches_cv2(cc.label(full), full, what="full")


def test_capacity_returns_prefix(vdlib):
    rng = np.random.default_rng(9)
    mask = np.where(rng.random((60, 80)) < 0.2, 255, 0).astype(np.uint8)
    allc = cc.label(mask)
    assert len(allc) > 10
    part, st = cc.label(mask, cap=7, return_status=True)
    assert st == cc.VD_ERR_CAPACITY and len(part) == 7
    np.testing.assert_array_equal(part, allc[:7])
    none, st = cc.label(mask, cap=0, return_status=True)
    assert st == cc.VD_ERR_CAPACITY and len(none) == 0


def _runs(mask):
    """Horizontal runs of nonzero pixels (numpy oracle of vd_components_stats_t.runs)."""
    m = (mask != 0).astype(np.int8)
    return int((np.diff(np.pad(m, ((0, 0), (1, 0))), axis=1) == 1).sum())


def test_thr_u8_real_frames_match_opencv(vdlib, data_dir):
    total = 0
    for name, img in _frames(data_dir):
        for thr in (150, int(np.percentile(img, 99)), 0, 255):
            mask = np.where(img >= thr, 255, 0).astype(np.uint8)
            comps, st, stats = cc.label_thr(img, thr)
            assert st == clib.VD_OK
            _assert_matches_cv2(comps, mask, what=f"{name} thr_u8 {thr}")
            assert stats == {"runs": _runs(mask), "pixels": int((mask != 0).sum()), "rows": img.shape[0],
                             "labels": len(comps)}, name
            total += len(comps)
        roi = (37, 21, 301, 203)
        mask = np.where(img >= 150, 255, 0).astype(np.uint8)
        _assert_matches_cv2(cc.label_thr(img, 150, roi)[0], mask, roi, what=f"{name} thr_u8 roi")
    assert total > 100


@pytest.mark.parametrize("seed", range(4))
def test_thr_u16_generated_frames_match_opencv(vdlib, seed):
    rng = np.random.default_rng(100 + seed)
    h, w = int(rng.integers(1, 140)), int(rng.integers(1, 170))
    base = int(rng.choice([1000, 30315, 0x7FF0, 0x8000, 0xFFF0]))
    smooth = cv2.GaussianBlur(rng.random((h, w)).astype(np.float32), (0, 0), 3.0)
    plane = np.clip(base - 8 + (smooth - smooth.min()) / (np.ptp(smooth) + 1e-9) * 16
                    + rng.integers(-2, 3, (h, w)), 0, 65535).astype(np.uint16)
    for thr in (base - 9, base - 1, base, base + 1, base + 7, 0, 65535, 0x8000):
        thr = int(min(max(thr, 0), 65535))
        mask = np.where(plane >= thr, 255, 0).astype(np.uint8)
        comps, st, stats = cc.label_thr(plane, thr)
        assert st == clib.VD_OK
        _assert_matches_cv2(comps, mask, what=f"seed {seed} u16 thr {thr}")
        assert stats["runs"] == _runs(mask) and stats["pixels"] == int((mask != 0).sum())
        x, y = int(rng.integers(0, w)), int(rng.integers(0, h))
        roi = (x, y, int(rng.integers(1, w - x + 1)), int(rng.integers(1, h - y + 1)))
        big = np.full((h, w + 5), 65535, np.uint16)  # strided view, hot padding must be ignored
        big[:, :w] = plane
        _assert_matches_cv2(cc.label_thr(big[:, :w], thr, roi)[0], mask, roi, what=f"seed {seed} u16 roi {roi}")


def test_thr_run_budget_labels_top_rows(vdlib, data_dir):
    """Over the budget: VD_ERR_CAPACITY, and the components equal OpenCV's on the rows labelled."""
    name, img = max(_frames(data_dir), key=lambda t: _runs(t[1] >= 150))
    mask = np.where(img >= 150, 255, 0).astype(np.uint8)
    runs = _runs(mask)
    assert runs > 200, name
    for budget in (runs // 3, runs - 1, runs):
        comps, st, stats = cc.label_thr(img, 150, max_runs=budget)
        rows = stats["rows"]
        if budget >= runs:
            assert st == clib.VD_OK and rows == img.shape[0]
        else:
            assert st == cc.VD_ERR_CAPACITY and rows < img.shape[0] and rows % 2 == 0
            assert stats["runs"] <= budget and stats["runs"] == _runs(mask[:rows])
        _assert_matches_cv2(comps, mask[:rows], what=f"{name} budget {budget}")
    checker = np.where((np.add.outer(np.arange(64), np.arange(80)) % 2) == 0, 200, 10).astype(np.uint8)
    comps, st, stats = cc.label_thr(checker, 100)  # worst-case workspace: never runs out
    assert st == clib.VD_OK and len(comps) == 1 and stats["runs"] == 40 * 64


def _aspect_q8(w, h):
    return (512 * h + w) // (2 * w)


def test_filter_matches_python_rules(vdlib):
    rng = np.random.default_rng(3)
    comps = np.zeros(500, dtype=cc.COMPONENT_DTYPE)
    comps["x"] = np.arange(500)
    comps["w"] = rng.integers(1, 80, 500)
    comps["h"] = rng.integers(1, 80, 500)
    comps["area"] = rng.integers(1, 400, 500)
    r = cc.rules_default()
    assert (r.aspect_min_q8, r.aspect_max_q8, r.min_area, r.max_area) == (77, 384, 120, 0)
    asp = np.array([_aspect_q8(int(w), int(h)) for w, h in zip(comps["w"], comps["h"])])
    keep = (asp >= 77) & (asp <= 384) & (comps["area"] >= 120)
    np.testing.assert_array_equal(cc.filter(comps), comps[keep])
    r.max_area = 300
    keep &= comps["area"] <= 300
    np.testing.assert_array_equal(cc.filter(comps, r), comps[keep])
    assert len(cc.filter(comps[:0])) == 0


def _expand_ref(rect, fw, fh, sw=384, sh=512):
    """Python transcription of the rounding documented in components.h."""
    out = []
    for pos, ln, s, lim in ((rect[0], rect[2], sw, fw), (rect[1], rect[3], sh, fh)):
        nl = max(1, (ln * s * 2 + 256) // 512)
        lo = pos - (nl - ln) // 2  # Python // is floor
        hi = min(lo + nl, lim)
        lo = max(lo, 0)
        out.append((lo, hi - lo))
    return out[0][0], out[1][0], out[0][1], out[1][1]


def test_expand_matches_reference(vdlib):
    rng = np.random.default_rng(4)
    for _ in range(2000):
        fw, fh = int(rng.integers(1, 700)), int(rng.integers(1, 600))
        x, y = int(rng.integers(0, fw)), int(rng.integers(0, fh))
        rect = (x, y, int(rng.integers(1, fw - x + 1)), int(rng.integers(1, fh - y + 1)))
        sw, sh = int(rng.integers(1, 1024)), int(rng.integers(1, 1024))
        assert cc.rect_expand(rect, fw, fh, sw, sh) == _expand_ref(rect, fw, fh, sw, sh), (rect, fw, fh, sw, sh)
    assert cc.rect_expand((10, 10, 10, 10), 640, 480) == (8, 5, 15, 20)
    with pytest.raises(clib.VdError):
        cc.rect_expand((700, 10, 10, 10), 640, 480)
