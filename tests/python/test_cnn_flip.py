# SPDX-License-Identifier: MIT
"""Horizontal-flip test-time augmentation of the CNN (cfg.cnn_flip, the fused flip pass) in the Python
evaluation: the fusion rule by hand (vdtools.evaluation.cnn_eval.fuse_flip), vdtools.evaluation.cnn_eval.Int8(flip=True)
as the fusion of the pass on the half-resolution plane and the pass on its mirror (random network, no data),
and Int8(flip=True) through the C library (`--backend c`) equal to the numpy integer reference (`--backend ref`)
box for box and score for score on real test-split frames and odd-sized crops. The demo side
(`vd_fir_demo --cnn-flip on` against vdtools.evaluation.cnn_detector) is in test_cnn_detector.py."""
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


# Hand-worked fusion (lib/src/detector/detector_cnn.c fuse_boxes; the C side: tests/unit/test_detector_cnn.c).
A = [((10, 10, 20, 20), 30000),      # a0: b0 and b1 overlap it 16 x 20 each: IoU 320 / 480 = 21845, a tie -> b0
     ((100, 10, 21, 20), 20000),     # a1: b2, inter 20 x 19 = 380, union 460: 27069
     ((50, 50, 10, 10), 23999),      # a2: b3 (IoU 80 / 120 = 21845), taken before a3 (whose IoU with it is 1)
     ((52, 50, 10, 10), 23998),      # a3: nothing left -> alone
     ((0, 100, 21299, 1), 30000),    # a4: b4 overlaps 9829 of a 32768 union: IoU 9829 < 9830 -> alone
     ((0, 200, 13, 1), 15000)]       # a5: b5 overlaps 6 of 20: IoU 0.3 exactly, 9830 -> matched
B = [((14, 10, 20, 20), 25001),      # b0
     ((6, 10, 20, 20), 26000),       # b1: left over
     ((101, 11, 20, 21), 20001),     # b2
     ((52, 50, 10, 10), 1),          # b3
     ((11470, 100, 21298, 1), 20000),  # b4: left over
     ((7, 200, 13, 1), 9001)]        # b5
FUSED = [((12, 10, 20, 20), 27501),    # a0 + b0: x0 (10 + 14) >> 1, x1 (30 + 34 + 1) >> 1 = 32; (30000 + 25001 + 1) >> 1
         ((100, 10, 21, 21), 20001),   # a1 + b2: x1 (121 + 121 + 1) >> 1 = 121, y1 (30 + 32 + 1) >> 1 = 31 (rounded out)
         ((51, 50, 10, 10), 12000),    # a2 + b3: x0 (50 + 52) >> 1, x1 (60 + 62 + 1) >> 1 = 61; (23999 + 1 + 1) >> 1
         ((52, 50, 10, 10), 11999),    # a3 alone: (23998 + 1) >> 1
         ((0, 100, 21299, 1), 15000),  # a4 alone: (30000 + 1) >> 1
         ((3, 200, 14, 1), 12001),     # a5 + b5: x0 (0 + 7) >> 1 = 3, x1 (13 + 20 + 1) >> 1 = 17; (15000 + 9001 + 1) >> 1
         ((6, 10, 20, 20), 13000),     # b1 left over: (26000 + 1) >> 1
         ((11470, 100, 21298, 1), 10000)]  # b4 left over: (20000 + 1) >> 1


def test_fuse_flip_hand_worked():
    assert cnn_eval.iou_q15(A[4][0], B[4][0]) == 9829 and cnn_eval.iou_q15(A[5][0], B[5][0]) == 9830
    assert cnn_eval.FLIP_IOU_Q15 == 9830
    assert cnn_eval.fuse_flip(A, B, 0) == FUSED
    # T = 12000 drops a3 (its own score 23998 was above T) and b4; a2 + b3 stays at exactly 12000.
    assert cnn_eval.fuse_flip(A, B, 12000) == [f for f in FUSED if f[1] >= 12000]
    assert len(cnn_eval.fuse_flip(A, B, 12000)) == 6
    # One side empty: every box alone at half its score, in order.
    assert cnn_eval.fuse_flip(A[:2], [], 0) == [(A[0][0], 15000), (A[1][0], 10000)]
    assert cnn_eval.fuse_flip([], B[:2], 13000) == [(B[1][0], 13000)]
    # The decode threshold of both passes: max(1, 2 T - 32768).
    assert [cnn_eval.flip_decode_score(t) for t in (0, 1, 16384, 16385, 19200, 32768)] == [1, 1, 1, 2, 5632, 32768]


def _random_net(tmp_path):
    rng = np.random.default_rng(7)
    d = R.random_model(rng, out_channels=5, width=(6, 8, 8, 6), name="flip_random")
    path = tmp_path / "net.vdm"
    path.write_bytes(V.pack(d))
    return rng, d, path


def test_flip_pass_is_the_fusion_of_both_passes(tmp_path):
    """Int8(flip=True) = fuse_flip(pass on the plane, pass on the mirrored plane with its boxes mirrored back),
    both decoded at the logit of flip_decode_score(T): T = 0 (thr_q -128: every peak, nothing dropped), the
    score of a logit threshold, or a Q15 score threshold. The odd last column is not part of the plane
    (changing it changes nothing)."""
    rng, d, path = _random_net(tmp_path)
    one, two = cnn_eval.Int8(path, backend="ref"), cnn_eval.Int8(path, backend="ref", flip=True)
    table = [int(v) for v in d["table"][0]]
    n_fused = n_dropped = 0
    for w, h in ((64, 48), (61, 45), (50, 40)):
        img = rng.integers(0, 256, (h, w), dtype=np.uint8)
        hw = w // 2
        x = CD.pad_to(np.ascontiguousarray(CD.half(img)[:, ::-1]), V.alignment(d))
        for t, kw in ((0, {}), (table[20 + 128], dict(thr_q=20)), (20000, dict(score_thr_q15=20000))):
            dec_q = -128 if t == 0 else cnn_eval.thr_from_score(d, cnn_eval.flip_decode_score(t))
            a = [(b, int(round(s * 32768))) for b, s in one(img, w, h, thr_q=dec_q)]
            mir = R.decode(d, R.run(d, x), 2 * x.shape[1], 2 * x.shape[0], thr_q=dec_q, max_peaks=100)
            b = []
            for bx, by, bw, bh, s, _ in mir:
                x0, x1, y1 = max(2 * hw - bx - bw, 0), min(2 * hw - bx, w), min(by + bh, h)
                if x1 > x0 and y1 > by:
                    b.append(((x0, by, x1 - x0, y1 - by), s))
            want = [(box, s / 32768.0) for box, s in cnn_eval.fuse_flip(a, b, t)]
            got = two(img, w, h, **kw)
            assert got == want, (w, h, t)
            assert all(s >= t / 32768.0 for _, s in got)
            n_fused += len(a) + len(b) - len(cnn_eval.fuse_flip(a, b, 0))
            n_dropped += len(cnn_eval.fuse_flip(a, b, 0)) - len(got)
            if w % 2:
                img2 = img.copy()
                img2[:, -1] = 255 - img2[:, -1]
                assert two(img2, w, h, **kw) == got
    assert n_fused > 0 and n_dropped > 0, (n_fused, n_dropped)
    # Without flip a Q15 score threshold is the logit threshold vd_cnn_thr_from_score gives.
    img = rng.integers(0, 256, (48, 64), dtype=np.uint8)
    assert one(img, 64, 48, score_thr_q15=20000) == one(img, 64, 48, thr_q=cnn_eval.thr_from_score(d, 20000))


def test_int8_flip_c_equals_ref_on_real_frames(vdlib, data_dir):
    """The C library and the numpy reference agree with the fused flip pass on real frames (even 640-wide and
    odd 601-wide crops), at the evaluation's threshold (every peak, T = 0) and at the shipped threshold 0.4
    (T = 13107: both passes decode at every score >= 1)."""
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
    n = n_moved = 0
    for fam, fs in sorted(fams.items()):
        for f in fs[::max(1, len(fs) // 3)][:3]:
            img = cv2.imread(str(f.path), cv2.IMREAD_GRAYSCALE)
            assert img is not None, f.path
            for im in (img, np.ascontiguousarray(img[5:454, 9:610])):
                h, w = im.shape
                for kw in ({}, dict(score_thr_q15=13107)):
                    got, want = c(im, w, h, **kw), ref(im, w, h, **kw)
                    assert got == want, f"{f.name} {w}x{h} {kw}"
                    n += len(got)
                first = {b for b, _ in one(im, w, h)}
                n_moved += sum(b not in first for b, _ in got)   # averaged boxes and mirrored leftovers
    assert n > 0 and n_moved > 0


def test_extra_scale_experiment(vdlib, data_dir):
    """cnn_eval --extra-scale (multi-scale test-time augmentation, an experiment of docs/results/detector.md):
    an empty height range gives the base boxes unchanged; the quarter-resolution pass appends exactly the
    fused flip pass of the plane made by two 2x2 box averages, its boxes scaled by 4 into the frame (C and the
    numpy reference alike); factor 2 (the base's own scale) is refused."""
    if not MODEL.is_file():
        pytest.skip(f"no CNN model at {MODEL} (the trained network is committed there)")
    import cv2
    f = frames_in_test_split(data_dir)[0]
    img = cv2.imread(str(f.path), cv2.IMREAD_GRAYSCALE)
    h, w = img.shape
    for backend in ("c", "ref"):
        base = cnn_eval.Int8(MODEL, backend=backend, flip=True)
        assert cnn_eval.ExtraScale(base, 4, (0, 0))(img, w, h) == base(img, w, h)
        q = CD.half(CD.half(img))
        one = cnn_eval.Int8(MODEL, backend=backend)
        passes = []
        for mirror in (False, True):
            plane = np.ascontiguousarray(q[:, ::-1]) if mirror else q
            x = CD.pad_to(plane, one.align)
            if backend == "c":
                dec = one.c.decode(one.c.run(x), x.shape[1] * 4, x.shape[0] * 4, thr_q=-128, max_peaks=100)
            else:
                dec = R.decode(one.desc, R.run(one.desc, x), x.shape[1] * 4, x.shape[0] * 4, thr_q=-128, max_peaks=100)
            passes.append(cnn_eval.clip_boxes(dec, w, h, flip_hw=q.shape[1] * 2 if mirror else None))
        want = [(b, s / 32768.0) for b, s in cnn_eval.fuse_flip(passes[0], passes[1], 0)]
        got = cnn_eval.ExtraScale(base, 4)(img, w, h)
        assert got[:len(got) - len(want)] == base(img, w, h) and got[len(got) - len(want):] == want
        assert len(want) > 0
    with pytest.raises(ValueError):
        cnn_eval.ExtraScale(base, 2)


def test_tiles_experiment(vdlib, data_dir):
    """cnn_eval --tiles (tiled inference at full resolution, an experiment of docs/results/cameras.md): one tile
    the size of the frame is the pair at full resolution, box for box (the frame's normalisation table taken
    outside, the tile through a model without one); a 2x2 grid keeps every box inside the frame and finds a
    vehicle; the experiment refuses what it is not (no flip, half resolution)."""
    model2 = REPO / "models" / "vd_cnn2.vdm"
    if not (MODEL.is_file() and model2.is_file()):
        pytest.skip(f"no CNN pair at {MODEL}, {model2} (the trained networks are committed there)")
    import cv2
    f = next(f for f in frames_in_test_split(data_dir) if "hit-uav" in str(f.path))
    img = cv2.imread(str(f.path), cv2.IMREAD_GRAYSCALE)
    h, w = img.shape
    pair = cnn_eval.Pair(cnn_eval.Int8(MODEL, flip=True, full_res=True),
                         cnn_eval.Int8(model2, flip=True, full_res=True))
    assert w % pair.nets[0].align == 0 and h % pair.nets[0].align == 0   # no padding: the mirrored pass's table too
    whole = pair(img, w, h)
    assert len(whole) > 0
    assert cnn_eval.Tiles(pair, 1, 1, 1.0)(img, w, h) == whole
    tiled = cnn_eval.Tiles(pair, 2, 2)(img, w, h)
    assert len(tiled) > 0
    assert all(x >= 0 and y >= 0 and x + bw <= w and y + bh <= h for (x, y, bw, bh), _ in tiled)
    with pytest.raises(ValueError):
        cnn_eval.Tiles(cnn_eval.Pair(cnn_eval.Int8(MODEL, flip=True), cnn_eval.Int8(model2, flip=True)), 2, 2)
    with pytest.raises(ValueError):
        cnn_eval.Tiles(cnn_eval.Pair(cnn_eval.Int8(MODEL, full_res=True), cnn_eval.Int8(model2, full_res=True)), 2, 2)
