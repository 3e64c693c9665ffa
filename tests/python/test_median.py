# SPDX-License-Identifier: MIT
"""Oracle tests of median.h against cv2.medianBlur (BORDER_REPLICATE) on real frames,
ROIs of them and generated frames; and the generated 5x5 network against its generator."""
import re

import cv2
import numpy as np
import pytest

from vdtools.bindings import clib, pixel
from vdtools.generators import median5_net, median_network


def _frames(data_dir, n):
    paths = sorted((data_dir / "msrs" / "images").glob("*.png"))[::14] + \
        sorted((data_dir / "hit-uav" / "frames" / "images").glob("*.jpg"))[::24]
    if not paths:
        pytest.skip(f"no frames under {data_dir}")
    return paths[:n]


@pytest.mark.parametrize("k", [3, 5])
def test_equals_cv2_on_real_frames_and_rois(vdlib, data_dir, k):
    rng = np.random.default_rng(k)
    paths = _frames(data_dir, 40)
    assert len(paths) >= 40
    for p in paths:
        a = cv2.imread(str(p), cv2.IMREAD_GRAYSCALE)
        ref = cv2.medianBlur(a, k)
        assert np.array_equal(pixel.median_u8(a, k), ref), p.name
        h, w = a.shape
        rois = [(0, 0, 7, 5), (w - 9, h - 4, 9, 4)]  # image corners
        for _ in range(3):
            rw, rh = int(rng.integers(1, 150)), int(rng.integers(1, 100))
            rois.append((int(rng.integers(0, w - rw)), int(rng.integers(0, h - rh)), rw, rh))
        for (x, y, rw, rh) in rois:
            assert np.array_equal(pixel.median_u8(a, k, (x, y, rw, rh)), ref[y:y + rh, x:x + rw]), (p.name, x, y)


@pytest.mark.parametrize("k", [3, 5])
def test_generated_frames(vdlib, k):
    rng = np.random.default_rng(10 + k)
    cases = [np.full((9, 70), 77, np.uint8),
             np.tile(np.repeat(np.array([0, 255], np.uint8), 35), (9, 1)),
             (rng.integers(0, 2, (40, 130)) * 255).astype(np.uint8)]
    for _ in range(40):
        h, w = int(rng.integers(1, 40)), int(rng.integers(1, 200))
        cases.append(rng.integers(0, 256, (h, w), dtype=np.uint8))
    for a in cases:
        assert np.array_equal(pixel.median_u8(a, k), cv2.medianBlur(a, k)), a.shape
    big = rng.integers(0, 256, (60, 100), dtype=np.uint8)
    view = big[2:50, 3:90]  # non-contiguous source
    assert np.array_equal(pixel.median_u8(view, k), cv2.medianBlur(np.ascontiguousarray(view), k))


def test_bad_arguments(vdlib):
    a = np.zeros((8, 8), np.uint8)
    with pytest.raises(clib.VdError):
        pixel.median_u8(a, 3, (4, 4, 5, 1))


def test_generated_network_matches_median_c(vdlib):
    """median.c's generated blocks are exactly what the (0-1-principle checked) generators emit."""
    pair, _ = median_network.median_network(check=True)
    src = (clib.REPO / "lib" / "src" / "pixel" / "median.c").read_text()
    blocks = dict(re.findall(r"// BEGIN GENERATED (\w+)[^\n]*\n(.*?)\n\s*// END GENERATED \1", src, re.S))
    # Compared without indentation: median.c places the blocks at its own nesting depth.
    def strip(lines):
        return [ln.strip() for ln in lines]
    assert strip(blocks["pair"].split("\n")) == strip(pair)
    # The 5x5 select works on output pairs (vdtools.generators.median5_net,
    # also checked on every 0/1 input); median_network's own select is not used.
    assert strip(blocks["select_pair"].split("\n")) == strip(median5_net.select_pair(check=True))
