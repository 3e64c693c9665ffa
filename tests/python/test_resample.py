# SPDX-License-Identifier: MIT
"""vd_resample_u8 (via vdtools.data.samples) against its integer numpy reference
(bit-exact) and against OpenCV (INTER_AREA when shrinking, INTER_LINEAR when
growing: within 1 grey level), on generated and real thermal frames."""
import cv2
import numpy as np
import pytest

from vdtools.data import samples
from vdtools.bindings import resample as vd_resample


def _real_frames(data_dir, n=4):
    files = sorted(p for p in data_dir.rglob("*") if p.suffix.lower() in (".png", ".jpg", ".jpeg"))
    if not files:
        pytest.skip(f"no PNG/JPEG frames under {data_dir}")
    pick = [files[i] for i in np.linspace(0, len(files) - 1, n).astype(int)]
    return [cv2.imread(str(p), cv2.IMREAD_GRAYSCALE) for p in pick]


def test_random_regions_match_reference(vdlib):
    rng = np.random.default_rng(0)
    for _ in range(300):
        h, w = rng.integers(1, 90, 2)
        img = rng.integers(0, 256, (h, w), dtype=np.uint8)
        x, y = int(rng.integers(0, w)), int(rng.integers(0, h))
        rw, rh = int(rng.integers(1, w - x + 1)), int(rng.integers(1, h - y + 1))
        dw, dh = (int(v) for v in rng.integers(1, 70, 2))
        np.testing.assert_array_equal(vd_resample.resample(img, (x, y, rw, rh), dw, dh),
                                      samples.resample_ref(img, (x, y, rw, rh), dw, dh))


def test_non_contiguous_view(vdlib):
    img = np.random.default_rng(1).integers(0, 256, (60, 80), dtype=np.uint8)
    sub = img[5:50, 7:70]                       # row stride 80 > width 63
    np.testing.assert_array_equal(vd_resample.resample(sub), samples.resample_ref(np.ascontiguousarray(sub)))


def _vs_opencv(img, rect):
    x, y, w, h = rect
    crop = img[y:y + h, x:x + w]
    got = vd_resample.resample(img, rect).astype(int)
    if w >= 32 and h >= 32:
        ref = cv2.resize(crop, (32, 32), interpolation=cv2.INTER_AREA)
    elif w < 32 and h < 32:
        ref = cv2.resize(crop, (32, 32), interpolation=cv2.INTER_LINEAR)
    else:
        return 0
    return int(np.abs(got - ref).max())


def test_close_to_opencv_generated(vdlib):
    rng = np.random.default_rng(2)
    img = cv2.GaussianBlur(rng.integers(0, 256, (240, 320), dtype=np.uint8), (0, 0), 2)
    for _ in range(200):
        s = int(rng.integers(2, 200))
        x, y = int(rng.integers(0, 320 - s)), int(rng.integers(0, 240 - min(s, 239)))
        rect = (x, y, s, min(s, 240 - y))
        assert _vs_opencv(img, rect) <= 1


def test_close_to_opencv_real_frames(vdlib, data_dir):
    rng = np.random.default_rng(3)
    for img in _real_frames(data_dir):
        hh, ww = img.shape
        for _ in range(50):
            w, h = int(rng.integers(8, min(160, ww))), int(rng.integers(8, min(120, hh)))
            x, y = int(rng.integers(0, ww - w)), int(rng.integers(0, hh - h))
            assert _vs_opencv(img, (x, y, w, h)) <= 1
            np.testing.assert_array_equal(vd_resample.resample(img, (x, y, w, h)),
                                          samples.resample_ref(img, (x, y, w, h)))


def test_sample32_modes(vdlib):
    img = (np.arange(64 * 48, dtype=np.uint32).reshape(48, 64) * 7 % 251).astype(np.uint8)
    s = samples.sample32(img, (3, 5, 40, 30), "grey")
    assert s.shape == (32, 32) and s.dtype == np.uint8
    # rects are clipped to the frame
    np.testing.assert_array_equal(samples.sample32(img, (-10, -10, 30, 30), "grey"),
                                  vd_resample.resample(img, (0, 0, 20, 20)))
    with pytest.raises(ValueError):
        samples.sample32(img, (100, 100, 5, 5), "grey")
    with pytest.raises(ValueError):
        samples.sample32(img, (0, 0, 5, 5), "colour")
    try:
        m = samples.sample32(img, (3, 5, 40, 30), "shape")
    except NotImplementedError as e:
        pytest.skip(str(e))
    assert m.shape == (32, 32) and m.dtype == np.uint8
