# SPDX-License-Identifier: MIT
"""Horizontal-flip test-time augmentation of the CNN (cfg.cnn_flip) in the Python evaluation:
vdtools.evaluation.cnn_eval.Int8(flip=True) through the C library (`--backend c`) equals the numpy integer
reference (`--backend ref`) box for box and score for score on real test-split frames and odd-sized crops,
and its flip pass is the first pass on the mirrored half-resolution plane with the boxes mirrored back
(checked on a random network without data). The demo side (`vd_fir_demo --cnn-flip on` against
vdtools.evaluation.cnn_detector) is in test_cnn_detector.py."""
import numpy as np
import pytest

from vdtools.bindings.clib import REPO
from vdtools.data import cnn_data as CD
from vdtools.evaluation import cnn_eval
from vdtools.formats import cnn_ref as R
from vdtools.formats import cnn_vdm as V

from realdata import frames_in_test_split

MODEL = REPO / "models" / "vd_cnn.vdm"


def test_clip_boxes_mirror_rule():
    """[x, x + w) -> [2 hw - x - w, 2 hw - x), then inside [0, W) x [0, H); empty boxes dropped."""
    hw, fw, fh = 25, 51, 40   # odd width: 2 hw = 50 < W
    boxes = [(20, 12, 16, 16, 100), (44, 30, 12, 16, 7), (50, 0, 6, 4, 9), (0, 0, 4, 50, 1)]
    assert cnn_eval.clip_boxes(boxes, fw, fh) == [((20, 12, 16, 16), 100), ((44, 30, 7, 10), 7),
                                                  ((50, 0, 1, 4), 9), ((0, 0, 4, 40), 1)]
    assert cnn_eval.clip_boxes(boxes, fw, fh, flip_hw=hw) == [((14, 12, 16, 16), 100), ((0, 30, 6, 10), 7),
                                                              ((46, 0, 4, 40), 1)]


def test_flip_pass_is_the_mirrored_plane(tmp_path):
    """Int8(flip=True) = Int8() followed by the boxes of the mirrored plane, mirrored back; the odd last
    column is not part of the plane (changing it changes nothing)."""
    rng = np.random.default_rng(7)
    d = R.random_model(rng, out_channels=5, width=(6, 8, 8, 6), name="flip_random")
    path = tmp_path / "net.vdm"
    path.write_bytes(V.pack(d))
    one, two = cnn_eval.Int8(path, backend="ref"), cnn_eval.Int8(path, backend="ref", flip=True)
    n_flip = 0
    for w, h in ((64, 48), (61, 45), (50, 40)):
        img = rng.integers(0, 256, (h, w), dtype=np.uint8)
        a, b = one(img, w, h), two(img, w, h)
        assert b[:len(a)] == a
        hw = w // 2
        x = CD.pad_to(np.ascontiguousarray(CD.half(img)[:, ::-1]), V.alignment(d))
        dec = R.decode(d, R.run(d, x), 2 * x.shape[1], 2 * x.shape[0], thr_q=-128, max_peaks=100)
        want = []
        for x, y, bw, bh, s, _ in dec:
            x0, x1, y1 = max(2 * hw - x - bw, 0), min(2 * hw - x, w), min(y + bh, h)
            if x1 > x0 and y1 > y:
                want.append(((x0, y, x1 - x0, y1 - y), s / 32768.0))
        assert b[len(a):] == want, (w, h)
        n_flip += len(want)
        if w % 2:
            img2 = img.copy()
            img2[:, -1] = 255 - img2[:, -1]
            assert two(img2, w, h) == b
    assert n_flip > 0


def test_int8_flip_c_equals_ref_on_real_frames(vdlib, data_dir):
    """The C library and the numpy reference agree with the flip pass on real frames (even 640-wide and
    odd 601-wide crops), at the evaluation's threshold (every peak, top 100)."""
    if not MODEL.is_file():
        pytest.skip(f"no CNN model at {MODEL} (the trained network is committed there)")
    import cv2
    frames = frames_in_test_split(data_dir)
    fams = {}
    for f in frames:
        fams.setdefault(f.dataset, []).append(f)
    c = cnn_eval.Int8(MODEL, backend="c", flip=True)
    ref = cnn_eval.Int8(MODEL, backend="ref", flip=True)
    one = cnn_eval.Int8(MODEL, backend="c")
    n = n_flip = 0
    for fam, fs in sorted(fams.items()):
        for f in fs[::max(1, len(fs) // 3)][:3]:
            img = cv2.imread(str(f.path), cv2.IMREAD_GRAYSCALE)
            assert img is not None, f.path
            for im in (img, np.ascontiguousarray(img[5:454, 9:610])):
                h, w = im.shape
                got, want = c(im, w, h), ref(im, w, h)
                assert got == want, f"{f.name} {w}x{h}"
                first = one(im, w, h)
                assert got[:len(first)] == first
                n += len(got)
                n_flip += len(got) - len(first)
    assert n > 0 and n_flip > 0
