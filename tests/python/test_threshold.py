# SPDX-License-Identifier: MIT
"""Oracle tests of threshold.h: cv2.threshold on every real frame, numpy on 16-bit frames."""
import cv2
import numpy as np
import pytest

from vdtools.bindings import clib, pixel
from realdata import frame_paths


def _frames(data_dir):
    msrs, uav = frame_paths(data_dir)
    return msrs + uav


def test_u8_equals_cv2_on_every_real_frame(vdlib, data_dir):
    rng = np.random.default_rng(3)
    n = 0
    for p in _frames(data_dir):
        a = cv2.imread(str(p), cv2.IMREAD_GRAYSCALE)
        thr = int(rng.integers(0, 256)) if n % 2 else 150
        _, ref = cv2.threshold(a, thr - 1, 255, cv2.THRESH_BINARY)
        assert np.array_equal(pixel.threshold_u8(a, thr), ref), p.name
        h, w = a.shape
        x, y = int(rng.integers(0, w - 1)), int(rng.integers(0, h - 1))
        rw, rh = int(rng.integers(1, w - x + 1)), int(rng.integers(1, h - y + 1))
        assert np.array_equal(pixel.threshold_u8(a, thr, (x, y, rw, rh)), ref[y:y + rh, x:x + rw]), p.name
        n += 1
    assert n >= 1000


@pytest.mark.parametrize("thr", [0, 1, 128, 254, 255])
def test_u8_generated_and_strided(vdlib, thr):
    rng = np.random.default_rng(thr)
    big = rng.integers(0, 256, (37, 91), dtype=np.uint8)
    a = big[3:30, 5:66]  # non-contiguous view: stride 91
    ref = np.where(a >= thr, 255, 0).astype(np.uint8)
    assert np.array_equal(pixel.threshold_u8(a, thr), ref)
    for const in (0, thr, 255):
        c = np.full((5, 9), const, np.uint8)
        assert np.array_equal(pixel.threshold_u8(c, thr), np.where(c >= thr, 255, 0).astype(np.uint8))


def _temp(raw, gain_q16, offset_ck):
    return offset_ck + ((raw.astype(np.int64) * gain_q16 + 32768) >> 16)


@pytest.mark.parametrize("gain_q16,offset_ck", [(65536, 0), (4 * 65536, 20000), (32768, 25000), (98304, -500)])
def test_u16_ck_equals_numpy(vdlib, gain_q16, offset_ck):
    rng = np.random.default_rng(gain_q16)
    a = rng.integers(0, 65536, (48, 64), dtype=np.uint16)
    a[0, 0], a[0, 1] = 0, 65535
    temps = _temp(a, gain_q16, offset_ck)
    for thr in list(rng.integers(int(temps.min()) - 10, int(temps.max()) + 10, 20)) + [int(temps.max()), int(temps.max()) + 1]:
        got = pixel.threshold_u16_ck(a, gain_q16, offset_ck, int(thr))
        assert np.array_equal(got, np.where(temps >= thr, 255, 0).astype(np.uint8)), thr
    got = pixel.threshold_u16_ck(a, gain_q16, offset_ck, int(temps.max()), (1, 0, 10, 3))
    assert np.array_equal(got, np.where(temps[0:3, 1:11] >= temps.max(), 255, 0).astype(np.uint8))


def test_calibration_30c(vdlib):
    # TLinear (0.01 K, gain 1.0, offset 0): 30.00 degC -> raw 30315.
    assert pixel.raw_from_centi_celsius(65536, 0, 3000) == (clib.VD_OK, 30315)
    # Made-up linear camera: 0.04 K/count, raw 0 = 200.00 K -> raw 2579 (hand-worked in test_threshold.c).
    assert pixel.raw_from_centi_celsius(4 * 65536, 20000, 3000) == (clib.VD_OK, 2579)
    assert pixel.raw_from_ck(65536, 0, 65536)[0] == -8  # VD_ERR_RANGE: hotter than raw 65535
    assert pixel.raw_from_ck(-1, 0, 0)[0] == -1         # VD_ERR_ARG: negative gain


def test_u16_raw_threshold(vdlib):
    rng = np.random.default_rng(1)
    a = rng.integers(0, 65536, (20, 33), dtype=np.uint16)
    for thr in (0, 1, 30315, 65535):
        assert np.array_equal(pixel.threshold_u16(a, thr), np.where(a >= thr, 255, 0).astype(np.uint8))
