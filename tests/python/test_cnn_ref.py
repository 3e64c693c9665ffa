# SPDX-License-Identifier: MIT
"""The numpy integer reference of the int8 CNN (vdtools.formats.cnn_ref) and the version-3 .vdm packer
(vdtools.formats.cnn_vdm), against the format and arithmetic of docs/model-format.md and docs/fixed-point.md: hand-worked
cases for every op, the percentile stretch, requantisation and decoding; the vectorised kernels
against naive loops written straight from the spec formulas; pack/unpack round trips and rejections."""
import shutil
import struct
import subprocess
import zlib

import numpy as np
import pytest

from vdtools.formats import cnn_ref as R
from vdtools.formats import cnn_vdm as V
from vdtools.formats import quantise

INT32_MIN, INT32_MAX = -(1 << 31), (1 << 31) - 1
IDENT = dict(mult=1 << 30, shift=1)      # exact identity requantisation for |acc| < 2^30


# ------------------------------------------------------------------ requantisation
def requant_scalar(acc, mult, shift):
    """The spec's requantisation, one value at a time with Python ints (written from the spec text)."""
    x = acc * (1 << shift) if shift > 0 else acc
    x = max(INT32_MIN, min(INT32_MAX, x))
    if x == INT32_MIN and mult == INT32_MIN:
        high = INT32_MAX
    else:
        ab = x * mult
        nudge = (1 << 30) if ab >= 0 else 1 - (1 << 30)
        t = ab + nudge
        high = t // (1 << 31) if t >= 0 else -((-t) // (1 << 31))     # truncate toward zero
    e = max(-shift, 0)
    mask = (1 << e) - 1
    rem = high & mask
    thr = (mask >> 1) + (1 if high < 0 else 0)
    return (high >> e) + (1 if rem > thr else 0)


@pytest.mark.parametrize("acc,mult,shift,want", [
    (100, 1 << 30, 0, 50),          # 100 * 0.5
    (5, 1 << 30, -1, 2),            # 1.25: double rounding (2.5 -> 3, then 1.5 -> 2)
    (-5, 1 << 30, -1, -1),          # -1.25: (-2.5 -> -2, then -1 -> -1)
    (3, 1 << 30, 1, 3),             # the identity used below
    (-3, 1 << 30, 1, -3),
    (1 << 30, INT32_MAX, 7, INT32_MAX - 1),    # acc << 7 saturates to INT32_MAX first
    (-(1 << 30), INT32_MAX, 7, -INT32_MAX),
    (INT32_MAX, INT32_MAX, -31, 1),
    (0, 1 << 30, -31, 0),
])
def test_requant_hand_worked(acc, mult, shift, want):
    assert requant_scalar(acc, mult, shift) == want
    assert int(quantise.requantise(acc, mult, shift)) == want


def test_requant_vectorised_equals_scalar():
    rng = np.random.default_rng(1)
    n = 20000
    acc = np.concatenate([rng.integers(INT32_MIN, INT32_MAX, n // 2, endpoint=True),
                          rng.integers(-100000, 100000, n // 2),
                          [INT32_MIN, INT32_MAX, 0, 1, -1]])
    mult = rng.integers(1 << 30, INT32_MAX, len(acc), endpoint=True)
    mult[:5] = [1 << 30, INT32_MAX, 1 << 30, INT32_MAX, (1 << 30) + 1]
    shift = rng.integers(-31, 8, len(acc))
    got = quantise.requantise(acc, mult, shift)
    want = [requant_scalar(int(a), int(m), int(s)) for a, m, s in zip(acc, mult, shift)]
    np.testing.assert_array_equal(got, want)


def test_requant_layer_clamps_and_adds_zero_point():
    L = dict(out_zp=-10, act_min=-10, act_max=20, mult=np.array([1 << 30] * 4), shift=np.array([1] * 4))
    np.testing.assert_array_equal(R.requant(np.array([[-100, 5, 25, 40]]), L), [[-10, -5, 15, 20]])
    with pytest.raises(OverflowError):
        R.requant(np.array([[1 << 31, 0, 0, 0]]), L)


# ------------------------------------------------------------------ input
def _norm_desc(lo, hi, min_range):
    return dict(input_norm=1, norm_lo_permille=lo, norm_hi_permille=hi, norm_min_range=min_range)


def test_preprocess_none_is_pixel_minus_128():
    img = np.array([[0, 1, 127], [128, 254, 255]], np.uint8)
    x = R.preprocess(img, dict(input_norm=0))
    assert x.shape == (2, 3, 1) and x.dtype == np.int8
    np.testing.assert_array_equal(x[:, :, 0], [[-128, -127, -1], [0, 126, 127]])


def test_equalise_hand_worked():
    img = np.array([[10, 10, 10, 10], [10, 10, 20, 20], [20, 20, 30, 200]], np.uint8)
    # n = 12; level 10: below 0, count 6 -> (6 * 255 + 12) // 24 = 64; level 20: below 6, count 4 ->
    # (16 * 255 + 12) // 24 = 170; level 30: below 10, count 1 -> (21 * 255 + 12) // 24 = 223;
    # level 200: below 11, count 1 -> (23 * 255 + 12) // 24 = 244; minus 128
    x = R.preprocess(img, dict(input_norm=2))[:, :, 0]
    np.testing.assert_array_equal(x, [[-64, -64, -64, -64], [-64, -64, 42, 42], [42, 42, 95, 116]])
    # a strictly increasing tone curve (a brighter camera) leaves the input unchanged
    curve = np.round(255 * (np.arange(256) / 255.0) ** 0.5).astype(np.uint8)
    assert np.all(np.diff(curve[[10, 20, 30, 200]].astype(int)) > 0)
    np.testing.assert_array_equal(R.preprocess(curve[img], dict(input_norm=2)), R.preprocess(img, dict(input_norm=2)))
    # one grey level: its mid-rank, 128 -> 0
    np.testing.assert_array_equal(R.preprocess(np.full((3, 5), 77, np.uint8), dict(input_norm=2)), 0)


def test_stretch_hand_worked():
    img = np.arange(16, dtype=np.uint8).reshape(4, 4)
    # n = 16: lo threshold 16*100//1000 = 1 -> lo = 1 (cum(0) = 1, cum(1) = 2); hi threshold 14 -> hi = 14
    assert R.stretch_bounds(img, 100, 900, 4) == (1, 14, 13)
    x = R.preprocess(img, _norm_desc(100, 900, 4))[:, :, 0]
    # p' = 0 for p <= 1; (p - 1) * 510 + 13) // 26: 7 -> 118, 14 -> 255 (255.5), 15 -> 275 -> 255
    assert x[0, 0] == -128 and x[0, 1] == -128
    assert x[1, 3] == 118 - 128
    assert x[3, 2] == 127 and x[3, 3] == 127
    want = [0 if p <= 1 else min(255, ((p - 1) * 510 + 13) // 26) for p in range(16)]
    np.testing.assert_array_equal(x.reshape(-1).astype(int) + 128, want)


def test_stretch_min_range_and_hi_1000():
    flat = np.full((4, 8), 100, np.uint8)
    assert R.stretch_bounds(flat, 10, 990, 16) == (100, 100, 16)
    assert (R.preprocess(flat, _norm_desc(10, 990, 16)) == -128).all()      # every pixel <= lo
    img = np.array([[100, 104, 108, 116]], np.uint8)
    # hi_permille 1000: no v has cum(v) > n, so hi = 255; lo_permille 0 -> lo = 100; r = 155
    assert R.stretch_bounds(img, 0, 1000, 16) == (100, 255, 155)
    np.testing.assert_array_equal(R.preprocess(img, _norm_desc(0, 1000, 16))[0, :, 0].astype(int) + 128,
                                  [0, (4 * 510 + 155) // 310, (8 * 510 + 155) // 310, (16 * 510 + 155) // 310])
    # narrow range: r = min_range 16 stretches 8 levels to about half the scale
    img = np.array([[100, 102, 104, 108]], np.uint8)
    assert R.stretch_bounds(img, 0, 999, 16) == (100, 108, 16)
    np.testing.assert_array_equal(R.preprocess(img, _norm_desc(0, 999, 16))[0, :, 0].astype(int) + 128,
                                  [0, (2 * 510 + 16) // 32, (4 * 510 + 16) // 32, (8 * 510 + 16) // 32])


def test_stretch_matches_naive_on_random_planes():
    rng = np.random.default_rng(2)
    for trial in range(200):
        h, w = rng.integers(1, 20, 2)
        img = R.random_image(rng, int(h), int(w))
        lo_pm = int(rng.integers(0, 1000))
        hi_pm = int(rng.integers(lo_pm + 1, 1001))
        mr = int(rng.integers(1, 256))
        n = img.size
        vals = img.reshape(-1).tolist()
        cum = [sum(1 for p in vals if p <= v) for v in range(256)]
        lo = next(v for v in range(256) if cum[v] > n * lo_pm // 1000)
        hi = next((v for v in range(256) if cum[v] > n * hi_pm // 1000), 255)
        r = max(hi - lo, mr)
        want = [(0 if p <= lo else min(255, ((p - lo) * 510 + r) // (2 * r))) - 128 for p in vals]
        got = R.preprocess(img, _norm_desc(lo_pm, hi_pm, mr)).reshape(-1)
        np.testing.assert_array_equal(got, want)


def test_preprocess_accepts_strided_views():
    rng = np.random.default_rng(3)
    big = R.random_image(rng, 40, 50, "blobs")
    view = big[3:35, 5:45]
    d = _norm_desc(20, 980, 8)
    np.testing.assert_array_equal(R.preprocess(view, d), R.preprocess(view.copy(), d))


# ------------------------------------------------------------------ ops, hand-worked
def _ts(*arrays):
    return [np.asarray(a, np.int8) for a in arrays]


def test_conv3x3_hand_worked_layout_and_padding():
    # tensor 0: 2x2x2, zp 1; channel 0 - zp = [[0, 1], [2, 3]], channel 1 - zp = 1 everywhere
    x = np.stack([np.array([[1, 2], [3, 4]]), np.full((2, 2), 2)], axis=2)
    w = np.zeros((2, 3, 3, 2), np.int8)                       # OHWI
    w[0, :, :, 0] = np.arange(1, 10).reshape(3, 3)            # w[0][ky][kx][0] = 3 ky + kx + 1
    w[0, 1, 1, 1] = -1                                        # minus the centre of channel 1
    w[1, 0, 0, 1] = 7                                         # output 1: 7 * x1(oy - 1, ox - 1)
    L = dict(op=V.CONV3X3, stride=1, cin=2, cout=2, **{"in": 0}, w=w, bias=np.array([10, 0]), out_zp=-5,
             act_min=-128, act_max=127, **{k: np.full(2, v) for k, v in IDENT.items()})
    out = R.layer_forward(L, _ts(x), [1])
    # channel 0: 10 + {49, 43; 31, 25} - 1 - 5 (worked out tap by tap in the comment of the spec formula)
    np.testing.assert_array_equal(out[:, :, 0], [[53, 47], [35, 29]])
    np.testing.assert_array_equal(out[:, :, 1], [[-5, -5], [-5, 2]])


def test_conv3x3_stride2_taps():
    # 4x4 input, x - zp = raster index; all-ones kernel: out(oy, ox) sums rows 2oy-1..2oy+1, cols 2ox-1..2ox+1
    x = np.arange(16).reshape(4, 4, 1)
    L = dict(op=V.CONV3X3, stride=2, cin=1, cout=1, **{"in": 0}, w=np.ones((1, 3, 3, 1), np.int8),
             bias=np.array([0]), out_zp=0, act_min=-128, act_max=127, mult=np.array([1 << 30]), shift=np.array([1]))
    out = R.layer_forward(L, _ts(x), [0])[:, :, 0]
    g = np.pad(np.arange(16).reshape(4, 4), 1)
    want = [[g[2 * oy:2 * oy + 3, 2 * ox:2 * ox + 3].sum() for ox in range(2)] for oy in range(2)]
    assert want == [[0 + 1 + 4 + 5, 1 + 2 + 3 + 5 + 6 + 7], [4 + 5 + 8 + 9 + 12 + 13, 5 + 6 + 7 + 9 + 10 + 11 + 13 + 14 + 15]]
    np.testing.assert_array_equal(out, np.minimum(want, 127))


def test_dw3x3_hand_worked():
    x = np.stack([np.array([[1, 2], [3, 4]]), np.array([[-1, -2], [-3, -4]])], axis=2)   # zp 0
    w = np.zeros((3, 3, 2), np.int8)                          # HWC
    w[1, 1, 0] = 2                                            # channel 0: 2 x (centre)
    w[2, 2, 1] = 3                                            # channel 1: 3 x(y + 1, x + 1)
    L = dict(op=V.DW3X3, stride=1, cin=2, cout=2, **{"in": 0}, w=w, bias=np.array([1, -1]), out_zp=0,
             act_min=-128, act_max=127, **{k: np.full(2, v) for k, v in IDENT.items()})
    out = R.layer_forward(L, _ts(x), [0])
    np.testing.assert_array_equal(out[:, :, 0], [[3, 5], [7, 9]])
    np.testing.assert_array_equal(out[:, :, 1], [[-13, -1], [-1, -1]])


def test_pw1x1_hand_worked_and_relu():
    x = np.array([[[1, 2, 3]]])                               # 1x1x3, zp -1 -> (2, 3, 4)
    w = np.array([[1, 0, 0], [0, 1, -1], [1, 1, 1]], np.int8)  # [cout][cin]
    L = dict(op=V.PW1X1, stride=1, cin=3, cout=3, **{"in": 0}, w=w, bias=np.array([0, 0, 100]), out_zp=-3,
             act_min=-3, act_max=100, **{k: np.full(3, v) for k, v in IDENT.items()})
    out = R.layer_forward(L, _ts(x), [-1])
    np.testing.assert_array_equal(out[0, 0], [2 - 3, -3, 100])   # -1 - 3 clamps to act_min; 109 - 3 to act_max


def test_maxpool_upsample_concat_hand_worked():
    x = np.array([[-5, 1, 7, 0], [3, -128, -1, -2], [9, 9, 127, -128], [-9, 2, 3, 4]]).reshape(4, 4, 1)
    mp = dict(op=V.MAXPOOL2, **{"in": 0})
    np.testing.assert_array_equal(R.layer_forward(mp, _ts(x), [0])[:, :, 0], [[3, 7], [9, 127]])
    y = np.array([[[1, -1], [2, -2]]])                        # 1x2x2
    up = R.layer_forward(dict(op=V.UPSAMPLE2, **{"in": 0}), _ts(y), [0])
    np.testing.assert_array_equal(up[:, :, 0], [[1, 1, 2, 2], [1, 1, 2, 2]])
    np.testing.assert_array_equal(up[:, :, 1], [[-1, -1, -2, -2]] * 2)
    a = np.array([[[1, 2]]])
    b = np.array([[[3, 4, 5]]])
    cat = R.layer_forward(dict(op=V.CONCAT, **{"in": 1}, in2=0), _ts(b, a), [0, 0])
    np.testing.assert_array_equal(cat[0, 0], [1, 2, 3, 4, 5])  # tensor `in` first, then `in2`


# ------------------------------------------------------------------ ops against naive loops
def naive_layer(L, ts, zps):
    """The spec's formulas with Python loops (slow; small tensors only)."""
    op, x, zp = L["op"], ts[L["in"]].astype(int), zps[L["in"]]
    h, w, c = x.shape
    if op == V.MAXPOOL2:
        return np.array([[[max(x[2 * y + dy, 2 * xx + dx, k] for dy in (0, 1) for dx in (0, 1)) for k in range(c)]
                          for xx in range(w // 2)] for y in range(h // 2)])
    if op == V.UPSAMPLE2:
        return np.array([[[x[y // 2, xx // 2, k] for k in range(c)] for xx in range(2 * w)] for y in range(2 * h)])
    if op == V.CONCAT:
        return np.concatenate([x, ts[L["in2"]].astype(int)], axis=2)
    s = int(L.get("stride", 1))
    cout = L["cout"]
    out = np.zeros((h // s, w // s, cout), int)
    for oy in range(h // s):
        for ox in range(w // s):
            for o in range(cout):
                acc = int(L["bias"][o])
                if op == V.PW1X1:
                    acc += sum(int(L["w"][o][k]) * (x[oy, ox, k] - zp) for k in range(c))
                else:
                    for ky in range(3):
                        for kx in range(3):
                            iy, ix = oy * s - 1 + ky, ox * s - 1 + kx
                            if 0 <= iy < h and 0 <= ix < w:
                                if op == V.CONV3X3:
                                    acc += sum(int(L["w"][o][ky][kx][k]) * (x[iy, ix, k] - zp) for k in range(c))
                                else:
                                    acc += int(L["w"][ky][kx][o]) * (x[iy, ix, o] - zp)
                z = requant_scalar(acc, int(L["mult"][o]), int(L["shift"][o]))
                out[oy, ox, o] = min(max(int(L["out_zp"]) + z, int(L["act_min"])), int(L["act_max"]))
    return out


@pytest.mark.parametrize("op,stride", [(V.CONV3X3, 1), (V.CONV3X3, 2), (V.DW3X3, 1), (V.DW3X3, 2), (V.PW1X1, 1),
                                       (V.MAXPOOL2, 1), (V.UPSAMPLE2, 1), (V.CONCAT, 1)])
def test_ops_equal_naive_loops(op, stride):
    rng = np.random.default_rng(op * 10 + stride)
    for trial in range(6):
        h, w = 2 * rng.integers(1, 5, 2)
        cin = int(rng.integers(1, 5))
        cout = cin if op in (V.DW3X3, V.MAXPOOL2, V.UPSAMPLE2) else int(rng.integers(1, 6))
        x = rng.integers(-128, 128, (h, w, cin))
        x2 = rng.integers(-128, 128, (h, w, 3))
        zps = [int(rng.integers(-128, 128)), 0]
        L = dict(op=op, stride=stride, cin=cin, cout=cout, **{"in": 0}, in2=1)
        if op in V.WEIGHTED:
            L["w"] = rng.integers(-127, 128, V.weight_shape(op, cin, cout)).astype(np.int8)
            bb = V.bias_bound(op, cin)
            L["bias"] = rng.integers(-bb, bb + 1, cout) if trial == 0 else rng.integers(-5000, 5000, cout)
            L["mult"] = rng.integers(1 << 30, INT32_MAX, cout, endpoint=True)
            L["shift"] = rng.integers(-31, 8, cout) if trial < 2 else rng.integers(-12, -4, cout)
            L["out_zp"] = int(rng.integers(-128, 128))
            L["act_min"] = int(rng.integers(-128, 0))
            L["act_max"] = int(rng.integers(L["act_min"], 128))
        ts = _ts(x, x2)
        np.testing.assert_array_equal(R.layer_forward(L, ts, zps), naive_layer(L, ts, zps))


def test_conv_banding_is_exact():
    """The im2col bands (CHUNK) do not change the result."""
    rng = np.random.default_rng(5)
    x = rng.integers(-128, 128, (16, 24, 6)).astype(np.int8)
    w = rng.integers(-127, 128, (7, 3, 3, 6)).astype(np.int8)
    full = R.conv3x3_acc(x, 3, w, np.zeros(7), 1)
    old = R.CHUNK
    try:
        R.CHUNK = 1
        banded = R.conv3x3_acc(x, 3, w, np.zeros(7), 1), R.conv3x3_acc(x, 3, w, np.zeros(7), 2)
    finally:
        R.CHUNK = old
    np.testing.assert_array_equal(banded[0], full)
    np.testing.assert_array_equal(banded[1], R.conv3x3_acc(x, 3, w, np.zeros(7), 2))
    # extremes: every product 127 * 255 or -127 * 255, K = 9 * 6
    xe = np.full((4, 4, 6), 127, np.int8)
    we = np.full((2, 3, 3, 6), 127, np.int8)
    we[1] = -127
    acc = R.conv3x3_acc(xe, -128, we, np.zeros(2), 1)
    assert acc[1, 1, 0] == 9 * 6 * 127 * 255 and acc[1, 1, 1] == -9 * 6 * 127 * 255


# ------------------------------------------------------------------ whole network
def test_forward_random_model_shapes_and_determinism():
    rng = np.random.default_rng(6)
    d = R.random_model(rng)
    ops = {V.op_id(L["op"]) for L in d["layers"]}
    assert ops == set(V.OP_NAMES) - {V.CONV5X5}   # conv5=True swaps two convs for CONV5X5 (op 7):
    d5 = R.random_model(np.random.default_rng(6), conv5=True)
    assert {V.op_id(L["op"]) for L in d5["layers"]} == set(V.OP_NAMES)
    assert any(L["stride"] == 2 and L["op"] == V.CONV3X3 for L in d["layers"])
    assert any(L["stride"] == 2 and L["op"] == V.DW3X3 for L in d["layers"])
    assert V.alignment(d) == 8 and V.tensor_factors(d)[-1] == 4
    shifts = np.concatenate([L["shift"] for L in d["layers"] if L["shift"] is not None])
    assert (shifts < 0).mean() > 0.8
    x = R.preprocess(R.random_image(rng, 48, 64, "blobs"), d)
    ts = R.forward(d, x)
    assert [t.shape for t in ts] == R.shapes(d, 64, 48)
    assert ts[-1].shape == (12, 16, 5)
    np.testing.assert_array_equal(R.forward(d, x)[-1], ts[-1])
    # tensors are the layers applied in order (forward = layer_forward chained)
    zps = V.tensor_zps(d)
    for i, L in enumerate(d["layers"]):
        np.testing.assert_array_equal(R.layer_forward(L, ts, zps), ts[i + 1])
    with pytest.raises(ValueError):
        R.forward(d, x[:44])                              # 44 is not a multiple of 8
    with pytest.raises(ValueError):
        R.forward(d, x.astype(np.int16))


def test_random_models_are_valid_and_varied():
    for seed in range(12):
        rng = np.random.default_rng(100 + seed)
        d = R.random_model(rng, out_channels=5 if seed % 2 else 3, input_norm=seed % 2,
                           out_stride=8 if seed % 3 == 0 else 4, input_w=64, input_h=64)
        V.validate(d)
        for L in d["layers"]:
            if L["w"] is not None:
                assert L["mult"].min() >= 1 << 30 and L["shift"].min() >= -31 and L["shift"].max() <= 7
                assert np.abs(L["bias"].astype(np.int64)).max() <= V.bias_bound(L["op"], L["cin"])
                assert np.abs(L["w"].astype(int)).max() <= 127
        assert np.all(np.diff(d["table"][0].astype(np.int64)) >= 0)


def test_macs_hand_worked():
    rng = np.random.default_rng(7)
    d = R.random_model(rng, width=(8, 12, 16, 12))
    w, h = 64, 48
    want = (32 * 24 * 9 * 1 * 8 + 32 * 24 * 9 * 8 + 32 * 24 * 8 * 12 + 0 + 8 * 6 * 9 * 12 + 8 * 6 * 12 * 16
            + 8 * 6 * 9 * 16 * 16 + 0 + 0 + 16 * 12 * 9 * 28 * 12 + 16 * 12 * 12 * 5)
    assert R.macs(d, w, h) == want
    assert R.params(d) == sum(L["w"].size + L["bias"].size for L in d["layers"] if L["w"] is not None)


# ------------------------------------------------------------------ decoding
def _dec_desc(out_channels=5, thr=-128, max_peaks=100, out_stride=4, sizes=(8, 4), offs=(128, 64)):
    t = np.zeros((out_channels, 256), np.int32)
    t[0] = np.arange(256) * 128                               # score_q15 = (v + 128) * 128
    t[1], t[2] = sizes[0] * 256, sizes[1] * 256
    if out_channels == 5:
        t[3], t[4] = offs
    return dict(out_channels=out_channels, out_stride=out_stride, score_threshold_q=thr, max_peaks=max_peaks,
                table=t)


def _head(hm, out_channels=5, fill=0):
    hm = np.asarray(hm)
    h = np.full(hm.shape + (out_channels,), fill, np.int8)
    h[:, :, 0] = hm
    return h


def test_decode_box_hand_worked():
    hm = np.full((4, 4), -100)
    hm[1, 2] = 50
    d = _dec_desc()
    # network input 16x16, frame 32x32: cx = (2*256 + 128) * 4 = 2560 (10 px), cy = (256 + 64) * 4 = 1280 (5 px)
    # x0n = 2560 - 1024, x1n = 3584 -> X = floor((a * 32 + 2048) / 4096) = 12, 28; y: 768, 1792 -> 6, 14
    boxes = R.decode(d, _head(hm), 32, 32, thr_q=0)
    assert boxes == [(12, 6, 16, 8, (50 + 128) * 128, 50)]


def test_decode_round_half_up():
    hm = np.full((4, 4), -100)
    hm[1, 2] = 50
    d = _dec_desc()
    # frame 24x24 = 1.5 x the 16x16 network input
    X = lambda a: (a * 24 + 2048) // 4096
    assert (X(1536), X(3584), X(768), X(1792)) == (9, 21, 5, 11)
    assert R.decode(d, _head(hm), 24, 24, thr_q=0)[0][:4] == (9, 5, 12, 6)
    # a half exactly: 1 px of network input = 1.5 frame px -> rounds up to 2
    d2 = _dec_desc(sizes=(2, 2), offs=(0, 0))
    hm2 = np.full((4, 4), -100)
    hm2[0, 1] = 0
    # cx = (256 + 0) * 4 = 1024 (4 px), x0n = 1024 - 256 = 768 (3 px -> 4.5 -> 5), x1n = 1280 (5 px -> 7.5 -> 8)
    assert R.decode(d2, _head(hm2), 24, 24, thr_q=0)[0][:4] == (5, 0, 3, 2)


def test_decode_plateaus_and_ties():
    hm = np.full((5, 6), -50)
    hm[1, 1:3] = 40                   # horizontal plateau: only the first in raster order is a peak
    hm[3, 3:5] = 40                   # 2x2 plateau: only its top-left cell
    hm[4, 3:5] = 40
    hm[0, 5] = 40                     # a separate peak of the same value
    hm[4, 0] = 60
    boxes = R.decode(_dec_desc(), _head(hm), 24, 20, thr_q=0)
    # order: value descending, then raster index ascending: (4,0)=60, then (0,5), (1,1), (3,3) all 40
    assert [b[5] for b in boxes] == [60, 40, 40, 40]
    ys, xs = R.peaks(hm, 0)
    assert sorted(zip(ys.tolist(), xs.tolist())) == [(0, 5), (1, 1), (3, 3), (4, 0)]
    # a diagonal neighbour before it with an equal value suppresses; one after it does not
    hm2 = np.full((3, 3), 0)
    hm2[0, 0] = hm2[1, 1] = 9
    assert list(zip(*R.peaks(hm2, 1))) == [(0, 0)]
    hm2 = np.full((3, 3), 0)
    hm2[0, 2] = hm2[1, 1] = 9         # (0,2) is before (1,1) in raster order: (1,1) is suppressed
    assert list(zip(*R.peaks(hm2, 1))) == [(0, 2)]


def test_decode_threshold_topk_capacity_and_defaults():
    rng = np.random.default_rng(9)
    hm = rng.integers(-128, 128, (12, 16))
    d = _dec_desc(thr=10, max_peaks=5)
    ys, xs = R.peaks(hm, -128)
    v = hm[ys, xs]
    allp = sorted(zip((-v).tolist(), (ys * 16 + xs).tolist()))
    full = R.decode(d, _head(hm), 64, 48, thr_q=-128, max_peaks=1000)
    assert [(-b[5]) for b in full] == [a for a, _ in allp]
    assert R.decode(d, _head(hm), 64, 48)[:] == [b for b in full if b[5] >= 10][:5]     # header thr and K
    assert R.decode(d, _head(hm), 64, 48, max_peaks=0) == R.decode(d, _head(hm), 64, 48)
    assert R.decode(d, _head(hm), 64, 48, thr_q=-128, max_peaks=1000, capacity=3) == full[:3]
    assert R.decode(d, _head(hm), 64, 48, thr_q=-128, max_peaks=2, capacity=3) == full[:2]
    assert R.decode(d, _head(hm), 64, 48, capacity=0) == []
    # the threshold is inclusive
    hm3 = np.full((4, 4), -128)
    hm3[2, 2] = 10
    assert len(R.decode(d, _head(hm3), 16, 16, thr_q=10)) == 1 and R.decode(d, _head(hm3), 16, 16, thr_q=11) == []
    with pytest.raises(ValueError):
        R.decode(d, _head(hm3), 16, 16, thr_q=128)


def test_decode_clamping_and_three_channels():
    d = _dec_desc(out_channels=3, sizes=(40, 0))
    hm = np.full((4, 4), -128)
    hm[0, 0] = 5                      # box of 40 x 0 network px at cell (0,0), offset half a cell
    hm[3, 3] = 4
    b = R.decode(d, _head(hm, 3), 16, 16, thr_q=0)
    # (0,0): cx = 128 * 4 = 512 (2 px): x0n = 2 - 20 < 0 -> 0; x1n = 22 px -> clamped to 16; h 0 -> 1
    assert b[0][:4] == (0, 2, 16, 1)
    # (3,3): cx = 14 px: x0 = -6 -> 0, x1 = 34 -> 16; cy = 14, y0 = 14, y1 = 14 -> 15
    assert b[1][:4] == (0, 14, 16, 1)
    # x0 is clamped to fw - 1 and x1 to at least x0 + 1
    d5 = _dec_desc(sizes=(0, 0), offs=(512, 512))
    hm = np.full((4, 4), -128)
    hm[3, 3] = 0
    assert R.decode(d5, _head(hm), 16, 16, thr_q=0)[0][:4] == (15, 15, 1, 1)
    # odd Q8 widths: bw // 2 floors
    t = _dec_desc(sizes=(0, 0), offs=(0, 0))
    t["table"][1] = 3
    hm = np.full((4, 4), -128)
    hm[1, 1] = 0
    # cx = 1024; x0n = 1024 - 1 = 1023, x1n = 1026; frame 4096 px wide over 16 px: X(a) = (a * 4096 + 2048) // 4096
    assert R.decode(t, _head(hm), 4096, 16, thr_q=0)[0][0] == (1023 * 4096 + 2048) // 4096
    assert R.decode(t, _head(hm), 4096, 16, thr_q=0)[0][2] == (1026 * 4096 + 2048) // 4096 - 1023


def test_decode_uses_each_channel_at_the_peak():
    d = _dec_desc()
    t = d["table"]
    t[1] = np.arange(256) * 10 + 256        # width Q8 of value v: (v + 128) * 10 + 256
    t[2] = 512
    t[3] = np.clip(np.arange(256) - 128, -256, 512)
    t[4] = 0
    head = np.full((2, 2, 5), -128, np.int8)
    head[1, 0] = [20, 72, 0, 100, 0]
    (x, y, w, h, s, logit), = R.decode(d, head, 8, 8, thr_q=0)
    bw = (72 + 128) * 10 + 256
    cx = (0 * 256 + 100) * 4
    x0n = cx - bw // 2
    assert (x, w) == (max(0, (x0n * 8 + 1024) // 2048), min(8, ((x0n + bw) * 8 + 1024) // 2048) - max(0, (x0n * 8 + 1024) // 2048))
    assert s == (20 + 128) * 128 and logit == 20


# ------------------------------------------------------------------ .vdm pack / unpack
def _model(seed=10, **kw):
    return R.random_model(np.random.default_rng(seed), **kw)


def _assert_desc_equal(a, b):
    for k in V.HEADER_KEYS:
        assert a[k] == b[k], k
    np.testing.assert_array_equal(a["table"], b["table"])
    assert len(a["layers"]) == len(b["layers"])
    for la, lb in zip(a["layers"], b["layers"]):
        for k in ("op", "stride", "in", "in2", "cin", "cout", "out_zp", "act_min", "act_max"):
            assert int(la[k]) == int(lb[k]), k
        for k in ("w", "bias", "mult", "shift"):
            if la[k] is None:
                assert lb[k] is None
            else:
                np.testing.assert_array_equal(np.asarray(la[k]).reshape(-1), np.asarray(lb[k]).reshape(-1))


@pytest.mark.parametrize("kw", [{}, dict(input_norm=1), dict(out_channels=3), dict(out_stride=8)])
def test_pack_unpack_round_trip(kw):
    d = _model(**kw)
    blob = V.pack(d)
    u = V.unpack(blob)
    _assert_desc_equal(d, u)
    assert V.pack(u) == blob
    # ops given by name pack identically
    named = dict(d, layers=[dict(L, op=V.OP_NAMES[L["op"]]) for L in d["layers"]])
    assert V.pack(named) == blob


def test_blob_layout():
    d = _model(name="cnn-test")
    blob = V.pack(d)
    (magic, ver, hs, total, crc, kind, norm, n, cout, iw, ih, lo, hi, mr, zp, os_, lt, dt, thr, r0, mp, flags, name,
     r1) = struct.unpack_from(V.HEADER_FMT, blob)
    assert (magic, ver, hs, kind, n, cout, iw, ih, zp, os_) == (b"VDMF", 3, 128, 2, len(d["layers"]), 5, 64, 48, -128, 4)
    assert total == len(blob) and total % 4 == 0 and crc == zlib.crc32(blob[16:]) & 0xFFFFFFFF
    assert lt == 128 and dt % 4 == 0 and dt + 5 * 256 * 4 == total
    assert (thr, mp) == (d["score_threshold_q"], d["max_peaks"]) and name.rstrip(b"\0") == b"cnn-test"
    assert r0 == 0 and flags == 0 and r1 == bytes(64)
    end = lt + 32 * n
    prev = end
    for i, L in enumerate(d["layers"]):
        e = struct.unpack_from(V.LAYER_FMT, blob, lt + 32 * i)
        assert e[:9] == (L["op"], L["stride"], L["in"], L["in2"], L["cin"], L["cout"], L["out_zp"], L["act_min"],
                         L["act_max"]) and e[9] == 0 and e[14] == 0
        if L["w"] is None:
            assert e[10:14] == (0, 0, 0, 0)
            continue
        ow, ob, om, osh = e[10:14]
        assert all(o % 4 == 0 for o in e[10:14]) and prev <= ow < ob < om < osh < dt
        assert blob[ow:ow + L["w"].size] == L["w"].tobytes()          # C layout, row-major
        assert np.frombuffer(blob, "<i4", L["cout"], ob).tolist() == L["bias"].tolist()
        assert np.frombuffer(blob, "<i4", L["cout"], om).tolist() == L["mult"].tolist()
        assert np.frombuffer(blob, "i1", L["cout"], osh).tolist() == L["shift"].tolist()
        prev = osh + L["cout"]
    assert np.frombuffer(blob, "<i4", 5 * 256, dt).tolist() == d["table"].reshape(-1).tolist()


def _mutants():
    """(description, mutate(desc) in place, expected message fragment)."""
    def layer(i, **kv):
        def f(d):
            d["layers"][i].update(kv)
        return f

    def hdr(**kv):
        def f(d):
            d.update(kv)
        return f

    def arr(i, key, fn):
        def f(d):
            d["layers"][i][key] = fn(np.array(d["layers"][i][key]))
        return f

    def tab(fn):
        def f(d):
            d["table"] = fn(np.array(d["table"]))
        return f

    def set_item(a, idx, v):
        a = a.astype(np.int64)
        a.reshape(-1)[idx] = v
        return a

    return [
        ("unknown op", layer(1, op=8), "unknown op"),   # 7 is CONV5X5 (issue 12)
        ("op name", layer(1, op="conv7x7"), "unknown op"),
        ("pw stride 2", layer(2, stride=2), "stride"),
        ("conv stride 3", layer(0, stride=3), "stride"),
        ("in after the layer", layer(1, **{"in": 2}), "in"),
        ("in2 on a conv", layer(1, in2=1), "in2"),
        ("concat in2 after the layer", layer(8, in2=9), "in2"),
        ("cin mismatch", layer(2, cin=9), "cin"),
        ("cout 0", layer(0, cout=0), "cout"),
        ("cout 1025", layer(0, cout=1025), "cout"),
        ("dw cout != cin", layer(1, cout=9), "cout"),
        ("maxpool zp", layer(3, out_zp=5), "zero point"),
        ("maxpool act", layer(3, act_min=0), "act_min"),
        ("upsample act", layer(7, act_max=100), "act_max"),
        ("concat cout", layer(8, cout=99), "CONCAT cout"),
        ("concat f", layer(8, in2=3), "sizes differ"),
        ("act_min > act_max", layer(0, act_min=10, act_max=5), "act_max"),
        ("out_zp range", layer(0, out_zp=200), "out_zp"),
        ("mult < 2^30", arr(0, "mult", lambda a: set_item(a, 0, (1 << 30) - 1)), "mult"),
        ("mult > int32", arr(0, "mult", lambda a: set_item(a, 0, 1 << 31)), "mult"),
        ("shift 8", arr(1, "shift", lambda a: set_item(a, 0, 8)), "shift"),
        ("shift -32", arr(1, "shift", lambda a: set_item(a, 0, -32)), "shift"),
        ("bias over the bound", arr(9, "bias", lambda a: set_item(a, 0, V.bias_bound(1, 28) + 1)), "bias"),
        ("bias under the bound", arr(2, "bias", lambda a: set_item(a, 0, -V.bias_bound(3, 8) - 1)), "bias"),
        ("weights too few", arr(0, "w", lambda a: a.reshape(-1)[:-1]), "w"),
        ("weight 200", arr(0, "w", lambda a: set_item(a, 0, 200)), "w"),
        ("float weights", arr(0, "w", lambda a: a.astype(np.float32)), "integer"),
        ("maxpool with weights", layer(3, w=np.zeros(4, np.int8)), "no w"),
        ("missing mult", layer(0, mult=None), "mult"),
        ("no layers", hdr(layers=[]), "layers"),
        ("33 layers", lambda d: d.update(layers=d["layers"] + [d["layers"][3]] * 22), "layers"),
        ("out_channels 4", hdr(out_channels=4), "out_channels"),
        ("out_channels vs head", hdr(out_channels=3), "out_channels"),
        ("out_stride 8 vs head f 4", hdr(out_stride=8), "out_stride"),
        ("out_stride 2", hdr(out_stride=2), "out_stride"),
        ("input_w not a multiple of A", hdr(input_w=60), "alignment"),
        ("input_h 0", hdr(input_h=0), "input_h"),
        ("input_w 4097", hdr(input_w=4097), "input_w"),
        ("input_zp", hdr(input_zp=0), "input_zp"),
        ("norm fields with norm 0", hdr(norm_min_range=5), "norm_min_range"),
        ("input_norm 3", hdr(input_norm=3), "input_norm"),
        ("norm fields with norm 2", hdr(input_norm=2, norm_min_range=5), "norm_min_range"),
        ("lo >= hi", hdr(input_norm=1, norm_lo_permille=500, norm_hi_permille=500, norm_min_range=4), "norm_hi"),
        ("hi > 1000", hdr(input_norm=1, norm_lo_permille=5, norm_hi_permille=1001, norm_min_range=4), "norm_hi"),
        ("min_range 0", hdr(input_norm=1, norm_lo_permille=5, norm_hi_permille=995, norm_min_range=0), "norm_min"),
        ("threshold 128", hdr(score_threshold_q=128), "score_threshold_q"),
        ("max_peaks 0", hdr(max_peaks=0), "max_peaks"),
        ("max_peaks 1025", hdr(max_peaks=1025), "max_peaks"),
        ("name too long", hdr(name="x" * 17), "name"),
        ("name not ASCII", hdr(name="caf\u00e9"), "name"),
        ("name control char", hdr(name="a\nb"), "name"),
        ("table shape", tab(lambda t: t[:4]), "table"),
        ("score not monotonic", tab(lambda t: set_item(t, 100, int(t[0, 101]) + 1)), "table[0]"),
        ("score > 1.0", tab(lambda t: set_item(t, 255, 32769)), "table[0]"),
        ("negative size", tab(lambda t: set_item(t, 256 + 3, -1)), "table[1..2]"),
        ("size too large", tab(lambda t: set_item(t, 512 + 3, 4096 * 256 + 1)), "table[1..2]"),
        ("offset < -1 cell", tab(lambda t: set_item(t, 768 + 3, -257)), "table[3..4]"),
        ("offset > 2 cells", tab(lambda t: set_item(t, 1024 + 3, 513)), "table[3..4]"),
    ]


@pytest.mark.parametrize("what,mutate,msg", _mutants(), ids=[m[0] for m in _mutants()])
def test_pack_rejects(what, mutate, msg):
    d = _model(seed=11)
    assert [V.op_id(L["op"]) for L in d["layers"]] == [1, 2, 3, 4, 2, 3, 1, 5, 6, 1, 3]
    mutate(d)
    with pytest.raises(ValueError, match=msg.replace("[", r"\[").replace("]", r"\]")):
        V.pack(d)


def test_pack_rejects_upsample_at_full_resolution_and_f_over_1024():
    table = R._decode_table(np.random.default_rng(0), 3, 0)
    base = dict(input_w=8, input_h=8, input_norm=0, input_zp=-128, out_stride=4, out_channels=3,
                score_threshold_q=0, max_peaks=10, name="t", table=table)
    up = dict(op=V.UPSAMPLE2, stride=1, **{"in": 0}, cin=1, cout=1, out_zp=-128, act_min=-128, act_max=127)
    with pytest.raises(ValueError, match="UPSAMPLE2"):
        V.pack(dict(base, layers=[up]))
    mp = lambda i: dict(op=V.MAXPOOL2, stride=1, **{"in": i}, cin=1, cout=1, out_zp=-128, act_min=-128, act_max=127)
    with pytest.raises(ValueError, match="downsample factor 2048"):
        V.pack(dict(base, input_w=2048, input_h=2048, layers=[mp(i) for i in range(11)]))


def test_unpack_rejects_bad_containers():
    d = _model(seed=12)
    blob = V.pack(d)
    with pytest.raises(ValueError, match="magic"):
        V.unpack(b"XDMF" + blob[4:])
    with pytest.raises(ValueError, match="CRC"):
        V.unpack(blob[:200] + bytes([blob[200] ^ 1]) + blob[201:])
    with pytest.raises(ValueError, match="version"):
        V.unpack(V.fix_crc(blob[:4] + struct.pack("<H", 2) + blob[6:]))
    with pytest.raises(ValueError, match="total_size"):
        V.unpack(blob[:-4])
    with pytest.raises(ValueError, match="shorter"):
        V.unpack(blob[:100])
    bad = bytearray(blob)
    bad[16] = 1                                               # kind
    with pytest.raises(ValueError, match="kind"):
        V.unpack(V.fix_crc(bytes(bad)))
    bad = bytearray(blob)
    bad[100] = 1                                              # reserved
    with pytest.raises(ValueError, match="reserved"):
        V.unpack(V.fix_crc(bytes(bad)))
    bad = bytearray(blob)
    bad[48:64] = b"ab\0c" + bytes(12)                         # byte after the first NUL
    with pytest.raises(ValueError, match="NUL"):
        V.unpack(V.fix_crc(bytes(bad)))
    # overlapping arrays: layer 1's bias offset pointed at its weights
    bad = bytearray(blob)
    e = 128 + 32
    struct.pack_into("<I", bad, e + 16, struct.unpack_from("<I", bad, e + 12)[0])
    with pytest.raises(ValueError, match="overlap"):
        V.unpack(V.fix_crc(bytes(bad)))
    # array outside the blob
    bad = bytearray(blob)
    struct.pack_into("<I", bad, e + 12, len(blob) - 4)
    with pytest.raises(ValueError, match="outside"):
        V.unpack(V.fix_crc(bytes(bad)))
    # a model invalid as a whole is caught after parsing (pack(check=False) writes it anyway)
    d["layers"][2]["cin"] = 9
    d["layers"][2]["w"] = np.zeros((d["layers"][2]["cout"], 9), np.int8)
    raw = V.pack(d, check=False)
    with pytest.raises(ValueError, match="cin"):
        V.unpack(raw)
    assert V.unpack(raw, check=False)["layers"][2]["cin"] == 9


def test_write_c_array(tmp_path):
    d = _model(seed=13)
    blob = V.pack(d)
    paths = V.write_c_array(blob, "vd_cnn_t", tmp_path)
    assert [p.name for p in paths] == ["vd_cnn_t.vdm", "vd_cnn_t_vdm.c", "vd_cnn_t_vdm.h"]
    assert (tmp_path / "vd_cnn_t.vdm").read_bytes() == blob
    c = (tmp_path / "vd_cnn_t_vdm.c").read_text()
    h = (tmp_path / "vd_cnn_t_vdm.h").read_text()
    assert "const void *vd_model_vd_cnn_t(size_t *bytes);" in h and "vd_cnn_load()" in h
    assert f"VD_MODEL_VD_CNN_T_BYTES {len(blob)}u" in h and "uint64_t align;" in c and "aligned(8)" in c
    body = c[c.index(".bytes = {") + 10:c.index("    }\n};")]
    assert bytes(int(t, 16) for t in body.replace(",", " ").split()) == blob
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc:
        main = tmp_path / "main.c"
        main.write_text('#include "vd_cnn_t_vdm.h"\n#include <stdint.h>\nint main(void){size_t n=0;'
                        'const void *p=vd_model_vd_cnn_t(&n);'
                        f'return (n=={len(blob)}u && ((uintptr_t)p % 8u)==0u) ? 0 : 1;}}\n')
        exe = tmp_path / "a.out"
        subprocess.run([cc, "-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror", "-o", str(exe), str(main),
                        str(tmp_path / "vd_cnn_t_vdm.c"), "-I", str(tmp_path)], check=True)
        assert subprocess.run([str(exe)]).returncode == 0
