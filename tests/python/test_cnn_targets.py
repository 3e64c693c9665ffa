# SPDX-License-Identifier: MIT
"""Training crops and targets of the CNN detector (tools/vdtools/training/cnn_targets.py), hand-worked:
the rule for vehicles a training crop cuts, and the heatmap / size / offset targets. numpy only (no
PyTorch), so CI runs them."""
import math

import numpy as np
import pytest

from vdtools.training import cnn_targets as G


def _boxes(*b):
    return np.array(b, np.float32).reshape(-1, 4)


CORNER_BOXES = ((10, 10, 300, 200), (400, 300, 120, 90), (600, 20, 40, 60), (200, 400, 60, 80))


def _random_frame(seed, shape=(480, 640), boxes=CORNER_BOXES):
    """A random frame (so that a crop is found back by its pixels) with vehicles and no ignore region, as
    sample() reads a cnn_data.Frame."""
    from types import SimpleNamespace
    img = np.random.default_rng(seed).integers(0, 255, shape, dtype=np.uint8)
    return SimpleNamespace(img=img, boxes=_boxes(*boxes), ignore=np.zeros((0, 4), np.float32),
                           others=np.zeros((0, 5), np.float32))


def test_split_cut_hand_worked():
    crop = 100
    pos, cut = G.split_cut(_boxes(
        (10, 10, 20, 20),      # inside: positive as it is
        (80, 10, 40, 20),      # centre (100, 20) outside, half inside: ignore over x 80..100
        (70, 50, 40, 20),      # centre (90, 60) inside, 30/40 = 75 % inside: positive clipped to 70..100
        (60, 70, 80, 20),      # centre (100, 80) on the edge = outside: ignore
        (45, 90, 20, 40),      # centre (55, 110) outside, 10/40 inside: ignore over y 90..100
        (30, 85, 20, 26),      # centre (40, 98) inside, 15/26 = 58 % < 60 %: ignore
        (150, 10, 20, 20),     # wholly outside: neither
        (99.5, 10, 20, 20),    # half a pixel inside: less than 1 px, neither
    ), crop)
    np.testing.assert_allclose(pos, _boxes((10, 10, 20, 20), (70, 50, 30, 20)))
    np.testing.assert_allclose(cut, _boxes((80, 10, 20, 20), (60, 70, 40, 20), (45, 90, 20, 10), (30, 85, 20, 15)))
    # the threshold is a parameter: at 50 % the 58 %-visible car stays a positive
    pos, cut = G.split_cut(_boxes((30, 85, 20, 26)), crop, min_visible=0.5)
    np.testing.assert_allclose(pos, _boxes((30, 85, 20, 15)))
    assert cut.shape == (0, 4)
    pos, cut = G.split_cut(np.zeros((0, 4), np.float32), crop)
    assert pos.shape == (0, 4) and cut.shape == (0, 4)


def test_targets_hand_worked():
    # a 16 x 8 box at (20, 24) on a 64 crop, stride 4: centre (28, 28) px = cell (7, 7), offsets 0
    hm, mask, reg, regm = G.targets(_boxes((20, 24, 16, 8)), _boxes((0, 0, 10, 6)), 64)
    assert hm.shape == (16, 16) and hm[7, 7] == 1.0 and (hm <= 1.0).all()
    assert hm.argmax() == 7 * 16 + 7 and np.count_nonzero(hm == 1.0) == 1
    # Gaussian sigmas max(0.5, 0.54 side / 4 / 6) cells: 0.5 across (the 16 px side gives 0.36), 0.5 down
    assert math.isclose(hm[7, 8], math.exp(-1 / (2 * 0.25)), rel_tol=1e-6)
    np.testing.assert_allclose(reg[:, 7, 7], [math.log(16), math.log(8), 0.0, 0.0], rtol=1e-6)
    assert regm[7, 7] == 1.0
    # neighbours inside the box learn the box too, weighted by the Gaussian; cells outside do not
    assert math.isclose(regm[7, 6], hm[7, 6], rel_tol=1e-6) and regm[7, 6] > 0
    np.testing.assert_allclose(reg[:, 7, 6], [math.log(16), math.log(8), 1.0, 0.0], rtol=1e-6)
    assert regm[5, 7] == 0.0               # cell centre y 22 px is above the box (24..32)
    # the ignore box 0..10 x 0..6 px covers cells x 0..2, y 0..1 (ceil): no loss there
    assert (mask[0:2, 0:3] == 0).all() and mask[2, 0] == 1 and mask[0, 3] == 1
    assert mask.sum() == 16 * 16 - 6


@pytest.mark.parametrize("cut_ignore", [False, True])
def test_sample_applies_split_cut_to_the_crop(cut_ignore):
    """sample() with augmentation off (scale 1, no flip, no photometric change) cuts a crop of the stretched
    half-resolution frame; its positives and ignore regions are exactly split_cut of the halved boxes shifted
    to the crop, wherever the crop falls (found back by its pixels: the frame is random, so unique). Without
    cut_ignore (the shipped recipe) a vehicle is a clipped positive when its centre is in the crop, else
    nothing: split_cut at min_visible 0 without its ignore regions."""
    from vdtools.data import cnn_data as CD
    rng = np.random.default_rng(3)
    fr = _random_frame(3)
    img, boxes = fr.img, fr.boxes
    full = G.stretch(CD.half(img))
    crop, n_pos, n_cut = 96, 0, 0
    for _ in range(40):
        crop_img, pos, ign = G.sample(fr, rng, crop=crop, augment=False, cut_ignore=cut_ignore)
        ys, xs = np.nonzero((full[:-crop + 1, :-crop + 1] == crop_img[0, 0]))
        at = [(y, x) for y, x in zip(ys, xs) if np.array_equal(full[y:y + crop, x:x + crop], crop_img)]
        assert len(at) == 1
        y0, x0 = at[0]
        want_pos, want_cut = G.split_cut(boxes * 0.5 - np.array([x0, y0, 0, 0], np.float32), crop,
                                         G.MIN_VISIBLE if cut_ignore else 0.0)
        if not cut_ignore:
            want_cut = want_cut[:0]
        np.testing.assert_allclose(pos, want_pos, atol=1e-4)
        np.testing.assert_allclose(ign, want_cut, atol=1e-4)
        n_pos, n_cut = n_pos + len(pos), n_cut + len(ign)
    assert n_pos > 0 and (n_cut > 0) == cut_ignore     # both cases were exercised


class _Script:
    """A scripted stand-in for numpy's Generator: integers() and uniform() return the queued values."""

    def __init__(self, ints, unif):
        self.ints, self.unif = list(ints), list(unif)

    def integers(self, lo, hi=None):
        v = self.ints.pop(0)
        assert (0 if hi is None else lo) <= v < (lo if hi is None else hi)
        return v

    def uniform(self, lo, hi):
        v = self.unif.pop(0)
        assert lo <= v <= hi
        return v


def _frame(img, boxes):
    from types import SimpleNamespace
    return SimpleNamespace(img=np.asarray(img, np.uint8), boxes=_boxes(*boxes))


def _donor():
    # full resolution 80 x 80, a car of 200 at (20, 20, 20, 20) = half resolution (10, 10, 10, 10) on 0
    d = np.zeros((80, 80), np.uint8)
    d[20:40, 20:40] = 200
    return _frame(d, [(20, 20, 20, 20)])


def test_paste_hand_worked():
    # margin 0.25 * 10 + 1 = 3.5 px: patch x, y 6..24 (int(6.5), ceil(23.5)), 18 x 18 at scale 1, the car at
    # (4, 4) inside it. Spots: (0, 0) touches the vehicle at (5, 5, 8, 8), (20, 2) is free: box (24, 6, 10, 10).
    img = np.full((40, 40), 30, np.uint8)
    rng = _Script(ints=[1, 0, 0, 0, 0, 20, 2], unif=[1.0])
    out, boxes, ign = G.paste(img, _boxes((5, 5, 8, 8)), _boxes(), [_donor()], rng)
    np.testing.assert_allclose(boxes, _boxes((5, 5, 8, 8), (24, 6, 10, 10)))
    assert ign.shape == (0, 4)
    # mean-matched: the patch's ring (0) is moved to the spot's mean (30), so the car is 230 and the
    # background 30; the feather (max(1, 0.5 * 3.5) = 1.75 px) blends only the outer two rings
    assert (out[6:16, 24:34] == 230).all()
    assert (out[2:20, 20:38] != 30).sum() == 100 and (out[:, :20] == 30).all() and (out[20:] == 30).all()


def test_paste_keep_row_and_no_free_spot():
    img = np.zeros((40, 40), np.uint8)
    # keep_row (road level): y of the spot is the patch's own, (6 + 24 - 18) / 2 = 6: the car stays at y 10
    rng = _Script(ints=[1, 0, 0, 15, 3], unif=[1.0])
    _, boxes, _ = G.paste(img, _boxes(), _boxes(), [_donor()], rng, keep_row=True)
    np.testing.assert_allclose(boxes, _boxes((19, 10, 10, 10)))
    # an ignore region over the whole frame: every try fails, nothing is pasted, the frame is unchanged
    rng = _Script(ints=[1, 0, 0] + [3, 4] * G.PASTE_TRIES, unif=[1.0])
    out, boxes, _ = G.paste(img, _boxes(), _boxes((0, 0, 40, 40)), [_donor()], rng)
    assert boxes.shape == (0, 4) and (out == 0).all()


def test_camera_angle_and_oblique_weights():
    from types import SimpleNamespace

    from vdtools.data import cnn_data as CD

    def fr(dataset, name):
        return SimpleNamespace(dataset=dataset, name=name)
    frames = [fr("hit", "0_100_30_0_00001.jpg"), fr("hit", "1_60_40_0_00002.jpg"),
              fr("hit", "1_60_90_0_00003.jpg"), fr("seq", "0_100_50_0_08067.jpg"), fr("msrs", "00012N.png")]
    assert [CD.hit_view(f) for f in frames] == [(False, 30), (True, 40), (True, 90), (False, 50), None]
    # two oblique frames (<= 40 degrees) at weight 3, three at 1: 3/9, 3/9, 1/9, 1/9, 1/9
    np.testing.assert_allclose(G.frame_weights(frames, 3.0), [3 / 9, 3 / 9, 1 / 9, 1 / 9, 1 / 9])
    np.testing.assert_allclose(G.frame_weights(frames), [0.2] * 5)


def test_scene_subset_keeps_whole_groups_of_one_family():
    from types import SimpleNamespace

    from vdtools.data import cnn_data as CD

    # four MSRS scene groups of 2 frames, one drone group of 3 frames
    frames = [SimpleNamespace(dataset="msrs", name=f"{i:05d}N.png", group=f"N{i // 2}") for i in range(8)] + \
             [SimpleNamespace(dataset="hit", name=f"1_60_40_0_{i:05d}.jpg", group="1_60_40") for i in range(3)]
    half = CD.scene_subset(frames, "msrs", 0.5)
    kept = {f.group for f in half if f.dataset == "msrs"}
    assert len(kept) == 2                                     # round(0.5 x 4) groups, each whole
    assert sum(f.dataset == "msrs" for f in half) == 4
    assert sum(f.dataset == "hit" for f in half) == 3         # the other family untouched
    assert {f.group for f in CD.scene_subset(frames, "msrs", 0.5)} == {f.group for f in half}   # seeded
    assert len({f.group for f in CD.scene_subset(frames, "msrs", 0.1) if f.dataset == "msrs"}) == 1   # >= 1
    assert CD.scene_subset(frames, "msrs", 1.0) == frames
    for bad in (0.0, 1.5):
        with pytest.raises(ValueError):
            CD.scene_subset(frames, "msrs", bad)


def test_aux_targets_hand_worked():
    """cnn_train --aux: one heatmap per class of other road users, the vehicles' Gaussian; the class picks
    the channel."""
    # a bicycle (class 1), 8 x 16 at (40, 8) on a 64 crop: centre (44, 16) px = cell (11, 4)
    hm = G.aux_targets(np.array([[40, 8, 8, 16, 1]], np.float32), 64)
    assert hm.shape == (2, 16, 16) and not hm[0].any()
    assert hm[1, 4, 11] == 1.0 and np.count_nonzero(hm[1] == 1.0) == 1
    # sigma down 0.54 * 16 / 4 / 6 = 0.36 -> 0.5 cells
    assert math.isclose(hm[1, 5, 11], math.exp(-1 / (2 * 0.25)), rel_tol=1e-6)
    # two people overlap: the maximum of their Gaussians
    hm = G.aux_targets(np.array([[0, 0, 8, 8, 0], [8, 0, 8, 8, 0]], np.float32), 64)
    assert hm[0, 1, 1] == 1.0 and hm[0, 1, 3] == 1.0 and math.isclose(hm[0, 1, 2], math.exp(-2.0), rel_tol=1e-6)
    assert G.aux_targets(np.zeros((0, 5), np.float32), 32).shape == (2, 8, 8)


def test_sample_moves_other_road_users_with_the_vehicles():
    """sample(others=True) applies the crop's scale, shift and flip to the persons / bicycles exactly as to
    the vehicles, keeps a class with its box, draws no extra random numbers (same crop as without them),
    and keeps one only when its centre is in the crop, clipped to it, as a positive."""
    fr = _random_frame(5)
    boxes = fr.boxes
    fr.others = np.concatenate([boxes, np.array([[0], [1], [1], [0]], np.float32)], 1)
    kept = 0
    for seed in range(30):
        c1, pos, ign = G.sample(fr, np.random.default_rng(seed))
        c2, pos2, ign2, oth = G.sample(fr, np.random.default_rng(seed), others=True)
        np.testing.assert_array_equal(c1, c2)
        np.testing.assert_array_equal(pos, pos2)
        np.testing.assert_allclose(oth[:, :4], pos, rtol=1e-6)
        assert set(oth[:, 4].tolist()) <= {0.0, 1.0}
        kept += len(oth)
    assert kept > 0
    # a frame without persons or bicycles: none
    fr.others = np.zeros((0, 5), np.float32)
    assert G.sample(fr, np.random.default_rng(0), others=True)[3].shape == (0, 5)


def test_sample_invert_flips_polarity_without_moving_the_crop(monkeypatch):
    """invert_p = 1 inverts the half-resolution frame (255 - v) before the stretch, drawing only from
    inv_rng: same crop place and boxes as without it, and (photometric changes and rescaling switched off)
    the crop is a window of the stretched inverted frame, possibly mirrored."""
    from vdtools.data import cnn_data as CD
    fr = _random_frame(7, (240, 320), ((40, 40, 60, 30),))
    img = fr.img
    c0, p0, _ = G.sample(fr, np.random.default_rng(1), crop=64, augment=False)
    c1, p1, _ = G.sample(fr, np.random.default_rng(1), crop=64, augment=False, invert_p=1.0,
                         inv_rng=np.random.default_rng(2))
    np.testing.assert_array_equal(p0, p1)
    np.testing.assert_array_equal(c0, c1)          # augment off: no inversion either
    for seed in range(5):
        a, pa, _ = G.sample(fr, np.random.default_rng(seed), crop=64)
        b, pb, _ = G.sample(fr, np.random.default_rng(seed), crop=64, invert_p=1.0, inv_rng=np.random.default_rng(0))
        np.testing.assert_array_equal(pa, pb)
        assert not np.array_equal(a, b)
    monkeypatch.setattr(G, "photometric", lambda x, r: x)
    monkeypatch.setattr(G, "SCALE", (1.0, 1.0))
    inv = G.stretch(255 - CD.half(img))
    for seed in range(5):
        c, _, _ = G.sample(fr, np.random.default_rng(seed), crop=64, invert_p=1.0, inv_rng=np.random.default_rng(0))
        found = any(np.array_equal(inv[y:y + 64, x:x + 64], w) for w in (c, c[:, ::-1])
                    for y in range(inv.shape[0] - 63) for x in range(inv.shape[1] - 63))
        assert found


def test_camera_shift_keeps_the_frame_and_its_draws():
    """camera_shift (cnn_train --camera) changes pixels only: same shape and dtype, deterministic for a seed,
    and sample() draws it (and --small's rescale) from cam_rng alone, so the crop's boxes are those of the
    run without it unless --small rescales."""
    fr = _random_frame(3, (240, 320), ((40, 40, 60, 30), (200, 100, 30, 20)))
    half = fr.img[::2, ::2].copy()
    for seed in range(8):       # every kind: the tone curves and the texture change
        a = G.camera_shift(half, np.random.default_rng(seed))
        b = G.camera_shift(half, np.random.default_rng(seed))
        assert a.shape == half.shape and a.dtype == np.uint8
        np.testing.assert_array_equal(a, b)
    for seed in range(5):
        a, pa, _ = G.sample(fr, np.random.default_rng(seed), crop=64)
        b, pb, _ = G.sample(fr, np.random.default_rng(seed), crop=64, camera_p=1.0, cam_rng=np.random.default_rng(9))
        np.testing.assert_array_equal(pa, pb)
        assert not np.array_equal(a, b)
        c, pc, _ = G.sample(fr, np.random.default_rng(seed), crop=64, camera_p=0.0, cam_rng=np.random.default_rng(9))
        np.testing.assert_array_equal(a, c)
        np.testing.assert_array_equal(pa, pc)


def test_camera_shift_s_curve_hand_worked(monkeypatch):
    """Kind 2, the S-curve: its table is the logistic normalised to map 0 to 0 and 255 to 255, so a frame
    of only those two levels keeps them (no texture step: the second draw is >= 0.5)."""
    class R:
        def integers(self, n):
            return 2
        def uniform(self, lo, hi):
            return (lo + hi) / 2
        def random(self):
            return 0.9
    img = np.array([[0, 255], [255, 0]], np.uint8)
    np.testing.assert_array_equal(G.camera_shift(img, R()), img)
    # mid level: k = 7, c = 0.5: f(0) = 0.0293, f(128) = 0.5034, f(255) = 0.9707, so 128 maps to
    # 255 * 0.4741 / 0.9414 = 128.4 -> 128; 200 to 255 * (0.8798 - 0.0293) / 0.9414 = 230.4 -> 230
    f = lambda v: 1 / (1 + math.exp(-7 * (v / 255 - 0.5)))
    for v, want in ((128, 128), (200, 230)):
        assert round(255 * (f(v) - f(0)) / (f(255) - f(0))) == want
        assert G.camera_shift(np.full((2, 2), v, np.uint8), R())[0, 0] == want
