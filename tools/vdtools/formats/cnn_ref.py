# SPDX-License-Identifier: MIT
"""The numpy integer reference of the int8 CNN (docs/model-format.md "CNN kind", docs/fixed-point.md "cnn"): input normalisation, the six
layer ops with TFLite requantisation, and the fixed-point decoding. vd_cnn_run / vd_cnn_decode
(lib/src/models/cnn/) must equal it bit for bit (tests/python/test_cnn_parity.py).

    x = preprocess(img_u8, desc)            # int8 [h, w, 1]
    ts = forward(desc, x)                   # [x, t1, ..., tL], int8 [H, W, C] each; ts[-1] is the head
    boxes = decode(desc, ts[-1], fw, fh)    # [(x, y, w, h, score_q15, logit)], best first
    macs(desc, w, h)                        # multiply-adds of one run at w x h

desc is the model description of vdtools.formats.cnn_vdm (a dict; unpack() of a blob gives one).
Accumulation: float64 BLAS for the convolutions is exact (every product and partial sum is an
integer of magnitude <= 9 * 1024 * 128 * 255 < 2^53); everything else is int64.
Requantisation is vdtools.formats.quantise.requantise (vectorised; the DBN's semantics).
random_model() makes valid random models for the tests.
"""
import math

import numpy as np

from vdtools.formats import quantise
from vdtools.formats.cnn_vdm import (CONCAT, CONV3X3, CONV5X5, DW3X3, MAXPOOL2, PW1X1, UPSAMPLE2, MAX_SIDE, OFF_MAX_Q8,
                             OFF_MIN_Q8, SCORE_MAX, SIZE_MAX_Q8, alignment, bias_bound, op_id, tensor_zps)

INT32_MIN, INT32_MAX = -(1 << 31), (1 << 31) - 1
MAX_FRAME = 8192         # VD_MAX_DIM: largest frame size decode scales boxes to
CHUNK = 1 << 22          # im2col elements per band (bounds the reference's memory, ~32 MB of float64)


# ------------------------------------------------------------------ input
def stretch_bounds(img_u8, lo_permille, hi_permille, min_range):
    """(lo, hi, r) of the percentile stretch of a uint8 plane."""
    a = np.asarray(img_u8, dtype=np.uint8)
    n = a.size
    cum = np.cumsum(np.bincount(a.ravel(), minlength=256).astype(np.int64))
    t_lo = (n * int(lo_permille)) // 1000
    t_hi = (n * int(hi_permille)) // 1000
    lo = int(np.argmax(cum > t_lo))             # cum[255] = n > t_lo always (lo_permille < 1000)
    above = cum > t_hi
    hi = int(np.argmax(above)) if above.any() else 255
    return lo, hi, max(hi - lo, int(min_range))


def equalise_lut(img_u8):
    """The input_norm 2 table of a uint8 plane of n pixels: grey level v -> the mid-rank of its pixels,
    (255 (2 below(v) + count(v)) + n) // (2 n) in 0..255 (below(v): pixels darker than v)."""
    a = np.asarray(img_u8)
    n = a.size
    h = np.bincount(a.ravel(), minlength=256).astype(np.int64)
    below = np.cumsum(h) - h
    return ((2 * below + h) * 255 + n) // (2 * n)


def preprocess(img_u8, desc):
    """int8 [h, w, 1] network input of a uint8 plane [h, w] (any strides) per desc's input_norm:
    0: q = pixel - 128; 1: percentile stretch p' = 0 if pixel <= lo else min(255, ((pixel - lo) * 510 + r)
    // (2 r)), q = p' - 128; 2: histogram equalisation p' = equalise_lut(plane)[pixel], q = p' - 128."""
    a = np.asarray(img_u8)
    if a.dtype != np.uint8 or a.ndim != 2:
        raise ValueError("preprocess: a 2-D uint8 plane expected")
    p = a.astype(np.int64)
    if int(desc["input_norm"]) == 1:
        lo, _hi, r = stretch_bounds(a, desc["norm_lo_permille"], desc["norm_hi_permille"], desc["norm_min_range"])
        p = np.where(p <= lo, 0, np.minimum(255, ((p - lo) * 510 + r) // (2 * r)))
    elif int(desc["input_norm"]) == 2:
        p = equalise_lut(a)[p]
    return (p - 128).astype(np.int8)[:, :, None]


# ------------------------------------------------------------------ layers
def requant(acc, L):
    """int8 output of int64 accumulators [..., cout] for layer L (per-channel mult/shift, out_zp, clamp)."""
    acc = np.asarray(acc, dtype=np.int64)
    if acc.size and (acc.min() < INT32_MIN or acc.max() > INT32_MAX):
        raise OverflowError("accumulator outside int32: the model violates the bias bound")
    z = quantise.requantise(acc, np.asarray(L["mult"], np.int64), np.asarray(L["shift"], np.int64))
    return np.clip(z + int(L["out_zp"]), int(L["act_min"]), int(L["act_max"])).astype(np.int8)


def _padded(x, zp, pad=1):
    """float64 [H+2pad, W+2pad, C] of x - zp with a zero border (padding with the zero point)."""
    h, w, c = x.shape
    p = np.zeros((h + 2 * pad, w + 2 * pad, c), np.float64)
    p[pad:pad + h, pad:pad + w] = x.astype(np.float64) - zp
    return p


def conv_acc(x, zp, w, bias, stride, ks=3):
    """int64 [Ho, Wo, cout] accumulators of a padded ks x ks convolution (padding ks // 2);
    w int8 [cout, ks, ks, cin]. Exact: |sum| < 2^31 is far inside float64's 2^53."""
    h, wd, c = x.shape
    cout = w.shape[0]
    ho, wo = h // stride, wd // stride
    p = _padded(x, zp, ks // 2)
    kk = ks * ks
    wm = np.asarray(w, np.float64).reshape(cout, kk * c).T            # [(ky, kx, c), cout]
    out = np.empty((ho, wo, cout), np.int64)
    band = max(1, CHUNK // max(1, wo * kk * c))
    for y0 in range(0, ho, band):
        y1 = min(ho, y0 + band)
        cols = np.empty((y1 - y0, wo, kk, c), np.float64)
        for ky in range(ks):
            for kx in range(ks):
                cols[:, :, ky * ks + kx] = p[y0 * stride + ky:(y1 - 1) * stride + ky + 1:stride,
                                             kx:(wo - 1) * stride + kx + 1:stride]
        acc = cols.reshape(-1, kk * c) @ wm
        out[y0:y1] = np.rint(acc).astype(np.int64).reshape(y1 - y0, wo, cout)
    return out + np.asarray(bias, np.int64)


def conv3x3_acc(x, zp, w, bias, stride):
    """int64 [Ho, Wo, cout] accumulators of a padded 3x3 convolution; w int8 [cout, 3, 3, cin]."""
    return conv_acc(x, zp, w, bias, stride, 3)


def conv5x5_acc(x, zp, w, bias, stride):
    """int64 [Ho, Wo, cout] accumulators of a 5x5 convolution, padding 2; w int8 [cout, 5, 5, cin]."""
    return conv_acc(x, zp, w, bias, stride, 5)


def dw3x3_acc(x, zp, w, bias, stride):
    """int64 [Ho, Wo, c] accumulators of a padded depthwise 3x3 convolution; w int8 [3, 3, c]."""
    h, wd, c = x.shape
    ho, wo = h // stride, wd // stride
    # int32 is exact: |x - zp| <= 255, |w| <= 128, so |sum of 9| < 2^19 (half the bytes of int64)
    p = np.zeros((h + 2, wd + 2, c), np.int32)
    p[1:-1, 1:-1] = x.astype(np.int32) - np.int32(zp)
    acc = np.zeros((ho, wo, c), np.int32)
    w = np.asarray(w, np.int32)
    for ky in range(3):
        for kx in range(3):
            acc += w[ky, kx] * p[ky:(ho - 1) * stride + ky + 1:stride, kx:(wo - 1) * stride + kx + 1:stride]
    return acc.astype(np.int64) + np.asarray(bias, np.int64)


def pw1x1_acc(x, zp, w, bias):
    """int64 [H, W, cout] accumulators of a pointwise convolution; w int8 [cout, cin]."""
    h, wd, c = x.shape
    a = (x.reshape(-1, c).astype(np.float64) - zp) @ np.asarray(w, np.float64).T
    return np.rint(a).astype(np.int64).reshape(h, wd, -1) + np.asarray(bias, np.int64)


def layer_acc(L, ts, zps):
    """Accumulators of weighted layer L given the tensors so far (ts) and their zero points."""
    op, x, zp = op_id(L["op"]), ts[L["in"]], zps[L["in"]]
    if op == CONV3X3:
        return conv3x3_acc(x, zp, np.asarray(L["w"]).reshape(L["cout"], 3, 3, L["cin"]), L["bias"], int(L["stride"]))
    if op == CONV5X5:
        return conv5x5_acc(x, zp, np.asarray(L["w"]).reshape(L["cout"], 5, 5, L["cin"]), L["bias"], int(L["stride"]))
    if op == DW3X3:
        return dw3x3_acc(x, zp, np.asarray(L["w"]).reshape(3, 3, L["cout"]), L["bias"], int(L["stride"]))
    if op == PW1X1:
        return pw1x1_acc(x, zp, np.asarray(L["w"]).reshape(L["cout"], L["cin"]), L["bias"])
    raise ValueError(f"op {op} has no accumulator")


def layer_forward(L, ts, zps):
    """Output tensor (int8 [H, W, cout]) of layer L."""
    op, x = op_id(L["op"]), ts[L["in"]]
    if op in (CONV3X3, DW3X3, PW1X1, CONV5X5):
        return requant(layer_acc(L, ts, zps), L)
    if op == MAXPOOL2:
        h, w, c = x.shape
        return x.reshape(h // 2, 2, w // 2, 2, c).max(axis=(1, 3))
    if op == UPSAMPLE2:
        return x.repeat(2, axis=0).repeat(2, axis=1)
    if op == CONCAT:
        return np.concatenate([x, ts[L["in2"]]], axis=2)
    raise ValueError(f"unknown op {op}")


def check_size(desc, w, h):
    """ValueError unless w, h are in 1..4096 and multiples of the model's alignment (vd_cnn_run's VD_ERR_ARG)."""
    a = alignment(desc)
    for what, v in (("width", w), ("height", h)):
        if not 1 <= v <= MAX_SIDE or v % a:
            raise ValueError(f"{what} {v}: must be 1..{MAX_SIDE} and a multiple of {a}")


def forward(desc, x_int8):
    """All tensors [t0 = input, t1, ..., tL] (int8 HWC) of the network on the int8 input [h, w, 1]."""
    x = np.asarray(x_int8)
    if x.ndim == 2:
        x = x[:, :, None]
    if x.dtype != np.int8 or x.shape[2] != 1:
        raise ValueError("forward: int8 input [h, w, 1] expected")
    check_size(desc, x.shape[1], x.shape[0])
    zps = tensor_zps(desc)
    ts = [x]
    for L in desc["layers"]:
        ts.append(layer_forward(L, ts, zps))
    return ts


def run(desc, img_u8):
    """The head tensor of one uint8 plane (preprocess + forward): what vd_cnn_run returns."""
    return forward(desc, preprocess(img_u8, desc))[-1]


def shapes(desc, w, h):
    """(H, W, C) of every tensor 0..L at input size w x h."""
    out = [(h, w, 1)]
    for L in desc["layers"]:
        op = op_id(L["op"])
        hh, ww, _ = out[L["in"]]
        if op in (CONV3X3, DW3X3, CONV5X5):
            hh, ww = hh // int(L["stride"]), ww // int(L["stride"])
        elif op == MAXPOOL2:
            hh, ww = hh // 2, ww // 2
        elif op == UPSAMPLE2:
            hh, ww = hh * 2, ww * 2
        out.append((hh, ww, int(L["cout"])))
    return out


def macs(desc, w, h):
    """Multiply-adds of one run at w x h: H_out * W_out * (9 cin cout | 9 c | cin cout | 25 cin cout) over
    the CONV3X3 / DW3X3 / PW1X1 / CONV5X5 layers (pooling, upsampling and concatenation count 0)."""
    sh = shapes(desc, w, h)
    total = 0
    for i, L in enumerate(desc["layers"]):
        op = op_id(L["op"])
        ho, wo, _ = sh[i + 1]
        k = {CONV3X3: 9 * int(L["cin"]) * int(L["cout"]), DW3X3: 9 * int(L["cout"]),
             PW1X1: int(L["cin"]) * int(L["cout"]), CONV5X5: 25 * int(L["cin"]) * int(L["cout"])}.get(op, 0)
        total += ho * wo * k
    return total


def params(desc):
    """Number of stored parameters (weights + biases)."""
    return sum(np.asarray(L["w"]).size + np.asarray(L["bias"]).size for L in desc["layers"] if L.get("w") is not None)


# ------------------------------------------------------------------ decoding
def peaks(hm, thr_q):
    """(y, x) int arrays of the 3x3 peaks of an int8 heatmap [Ho, Wo] with v >= thr_q: v > the
    neighbours before it in raster order and v >= those after it (outside neighbours ignored)."""
    h = np.asarray(hm, np.int64)
    ho, wo = h.shape
    p = np.full((ho + 2, wo + 2), -1000, np.int64)
    p[1:-1, 1:-1] = h
    ok = h >= thr_q
    for dy, dx, strict in ((-1, -1, True), (-1, 0, True), (-1, 1, True), (0, -1, True),
                           (0, 1, False), (1, -1, False), (1, 0, False), (1, 1, False)):
        nb = p[1 + dy:1 + dy + ho, 1 + dx:1 + dx + wo]
        ok &= (h > nb) if strict else (h >= nb)
    return np.nonzero(ok)


def _floor_div(a, b):
    return a // b    # Python ints: floor division, also for negative a


def decode(desc, head, frame_w, frame_h, thr_q=None, max_peaks=None, capacity=None):
    """Boxes [(x, y, w, h, score_q15, logit)] of a head tensor int8 [Ho, Wo, C_out], best first, per the
    spec: peaks >= thr_q (None: header's), top K = min(max_peaks (None or 0: header's), capacity (None:
    no limit)) by value then raster index, boxes scaled from the network input (Wo * out_stride x
    Ho * out_stride) to frame_w x frame_h."""
    head = np.asarray(head)
    ho, wo, cc = head.shape
    if head.dtype != np.int8 or cc != int(desc["out_channels"]):
        raise ValueError("decode: int8 head [Ho, Wo, out_channels] expected")
    fw, fh = int(frame_w), int(frame_h)
    if not (1 <= fw <= MAX_FRAME and 1 <= fh <= MAX_FRAME):
        raise ValueError(f"decode: frame size must be 1..{MAX_FRAME}")
    thr = int(desc["score_threshold_q"]) if thr_q is None else int(thr_q)
    if not -128 <= thr <= 127:
        raise ValueError(f"thr_q {thr} outside int8")
    k = int(desc["max_peaks"]) if not max_peaks else int(max_peaks)
    if capacity is not None:
        k = min(k, int(capacity))
    s = int(desc["out_stride"])
    w, h = wo * s, ho * s
    t = np.asarray(desc["table"], np.int64)
    ys, xs = peaks(head[:, :, 0], thr)
    v = head[ys, xs, 0].astype(np.int64)
    order = np.lexsort((ys * wo + xs, -v))[:max(k, 0)]
    out = []
    for i in order:
        y, x = int(ys[i]), int(xs[i])
        c = [int(head[y, x, j]) + 128 for j in range(cc)]
        off_x, off_y = (int(t[3][c[3]]), int(t[4][c[4]])) if cc == 5 else (128, 128)
        cx = (x * 256 + off_x) * s
        cy = (y * 256 + off_y) * s
        bw, bh = int(t[1][c[1]]), int(t[2][c[2]])
        x0n = cx - bw // 2
        y0n = cy - bh // 2
        x1n, y1n = x0n + bw, y0n + bh
        X = lambda a: _floor_div(a * fw + (w * 256) // 2, w * 256)
        Y = lambda a: _floor_div(a * fh + (h * 256) // 2, h * 256)
        x0 = min(max(X(x0n), 0), fw - 1)
        x1 = min(max(X(x1n), x0 + 1), fw)
        y0 = min(max(Y(y0n), 0), fh - 1)
        y1 = min(max(Y(y1n), y0 + 1), fh)
        out.append((x0, y0, x1 - x0, y1 - y0, int(t[0][c[0]]), c[0] - 128))
    return out


# ------------------------------------------------------------------ random models (tests)
def _blob_image(rng, h, w):
    """A smooth random uint8 image with a few warm blobs and noise (calibration / test input)."""
    yy, xx = np.mgrid[0:h, 0:w]
    img = rng.uniform(20, 120) + rng.normal(0, 6, (h, w))
    for _ in range(int(rng.integers(2, 8))):
        cx, cy = rng.uniform(0, w), rng.uniform(0, h)
        r = rng.uniform(1.5, max(2.0, min(h, w) / 4))
        img += rng.uniform(-60, 150) * np.exp(-((xx - cx) ** 2 + (yy - cy) ** 2) / (2 * r * r))
    return np.clip(img, 0, 255).astype(np.uint8)


def random_image(rng, h, w, kind=None):
    """A random uint8 test frame: 'blobs' (smooth, warm spots), 'noise' (uniform), 'flat' or 'dark'
    (narrow ranges); kind None picks one."""
    kind = kind or rng.choice(["blobs", "blobs", "noise", "flat", "dark"])
    if kind == "blobs":
        return _blob_image(rng, h, w)
    if kind == "noise":
        return rng.integers(0, 256, (h, w), dtype=np.uint8)
    if kind == "flat":
        return np.full((h, w), int(rng.integers(0, 256)), np.uint8)
    base = int(rng.integers(0, 240))
    return rng.integers(base, base + int(rng.integers(1, 16)), (h, w)).astype(np.uint8)


def _calibrate(rng, acc, target, wild=0.06):
    """Per-channel (mult, shift) mapping the accumulators' spread to about `target` int8 steps;
    a share `wild` of the channels gets an arbitrary multiplier/shift in the full accepted range."""
    acc = acc.reshape(-1, acc.shape[-1]).astype(np.float64)
    cout = acc.shape[1]
    spread = np.maximum(acc.std(axis=0), 1.0)
    mult = np.empty(cout, np.int32)
    shift = np.empty(cout, np.int8)
    for o in range(cout):
        m = float(target * rng.uniform(0.5, 2.0) / spread[o])
        q, sh = quantise.quantize_multiplier(min(max(m, 2.0 ** -31), 2.0 ** 7 * 0.999))
        if rng.random() < wild:
            q, sh = int(rng.integers(1 << 30, 1 << 31)), int(rng.integers(-31, 8))
        mult[o], shift[o] = q, sh
    return mult, shift


def _decode_table(rng, out_channels, zp):
    """A valid random decode table: monotonic Q15 score, Q8 sizes of ~2..300 network pixels, Q8 offsets."""
    v = np.arange(-128, 128, dtype=np.float64) - zp
    t = np.zeros((out_channels, 256), np.int64)
    t[0] = np.floor(SCORE_MAX / (1.0 + np.exp(-v * rng.uniform(0.03, 0.2))) + 0.5)
    for c in (1, 2):
        t[c] = np.floor(256.0 * np.exp(np.log(rng.uniform(4, 40)) + v * rng.uniform(0.01, 0.04)) + 0.5)
    if out_channels == 5:
        for c in (3, 4):
            t[c] = np.floor(128.0 + v * rng.uniform(1.0, 6.0) + 0.5)
    t[0] = np.clip(t[0], 0, SCORE_MAX)
    t[1:3] = np.clip(t[1:3], 0, SIZE_MAX_Q8)
    t[3:] = np.clip(t[3:], OFF_MIN_Q8, OFF_MAX_Q8)
    return t.astype(np.int32)


def random_model(rng, out_channels=5, input_norm=0, width=(8, 12, 16, 12), out_stride=4, input_w=64, input_h=48,
                 extreme_bias=True, name="random", conv5=False):
    """A valid random CNN desc exercising all six ops: conv3x3 stride 2, depthwise (stride 1 and 2),
    pointwise, max-pool, upsample and a concat skip; out_stride 4 (or 8), out_channels 5 (or 3).
    Weights are int8 in [-127, 127]; per-channel mult/shift are calibrated on a random image so that
    activations spread over the int8 range (a few channels get arbitrary mult in [2^30, 2^31-1] and
    shift in [-31, 7]); biases lie within the loader's bound (with extreme_bias a few sit at it).
    The decode table is valid and monotonic. input_w, input_h must be multiples of 8 (16 for
    out_stride 8). conv5: the first conv (stride 2) and the stride-1 conv at f8 are CONV5X5 instead
    (paper 003's op; the default plan and its random draws are unchanged)."""
    c1, c2, c3, c4 = (int(c) for c in width)
    relu = lambda zp: (zp, 127)
    zp_skip = int(rng.integers(-128, -100))     # tensors joined by the concat share a zero point
    plan = [
        dict(op=CONV3X3, stride=2, **{"in": 0}, cin=1, cout=c1),                 # t1 f2
        dict(op=DW3X3, stride=1, **{"in": 1}, cin=c1, cout=c1),                  # t2 f2
        dict(op=PW1X1, stride=1, **{"in": 2}, cin=c1, cout=c2, zp=zp_skip),      # t3 f2
        dict(op=MAXPOOL2, stride=1, **{"in": 3}, cin=c2, cout=c2),               # t4 f4
        dict(op=DW3X3, stride=2, **{"in": 4}, cin=c2, cout=c2, act="none"),      # t5 f8
        dict(op=PW1X1, stride=1, **{"in": 5}, cin=c2, cout=c3),                  # t6 f8
        dict(op=CONV3X3, stride=1, **{"in": 6}, cin=c3, cout=c3, zp=zp_skip),    # t7 f8
        dict(op=UPSAMPLE2, stride=1, **{"in": 7}, cin=c3, cout=c3),              # t8 f4
        dict(op=CONCAT, stride=1, **{"in": 8}, in2=4, cin=c3, cout=c3 + c2),     # t9 f4
        dict(op=CONV3X3, stride=1, **{"in": 9}, cin=c3 + c2, cout=c4, act="relu6"),  # t10 f4
        dict(op=PW1X1, stride=1, **{"in": 10}, cin=c4, cout=out_channels, act="none"),  # t11 head f4
    ]
    if conv5:
        plan[0]["op"] = CONV5X5
        plan[6]["op"] = CONV5X5
    if out_stride == 8:   # one more stride-2 conv before the head: head at f8
        plan[-1:] = [dict(op=CONV3X3, stride=2, **{"in": 10}, cin=c4, cout=c4),
                     dict(op=PW1X1, stride=1, **{"in": 11}, cin=c4, cout=out_channels, act="none")]
    desc = {"input_w": input_w, "input_h": input_h, "input_norm": int(input_norm),
            "norm_lo_permille": int(rng.integers(0, 50)) if input_norm == 1 else 0,
            "norm_hi_permille": int(rng.integers(950, 1001)) if input_norm == 1 else 0,
            "norm_min_range": int(rng.integers(1, 64)) if input_norm == 1 else 0,
            "input_zp": -128, "out_stride": int(out_stride), "out_channels": int(out_channels),
            "score_threshold_q": 0, "max_peaks": int(rng.integers(16, 200)), "name": name, "layers": []}
    a = 16 if out_stride == 8 else 8
    cal_h, cal_w = max(input_h, 4 * a), max(input_w, 4 * a)
    img = _blob_image(rng, cal_h - cal_h % a, cal_w - cal_w % a)
    ts = [preprocess(img, desc)]
    zps = [-128]
    for i, p in enumerate(plan):
        op = p["op"]
        L = {"op": op, "stride": p["stride"], "in": p["in"], "in2": p.get("in2", 0), "cin": p["cin"],
             "cout": p["cout"], "w": None, "bias": None, "mult": None, "shift": None}
        if op in (MAXPOOL2, UPSAMPLE2, CONCAT):
            L.update(out_zp=zps[p["in"]], act_min=-128, act_max=127)
        else:
            zp = p.get("zp", int(rng.integers(-128, -90)))
            act = p.get("act", "relu")
            if act == "none":
                zp = int(rng.integers(-20, 21))
                lo, hi = -128, 127
            elif act == "relu6":
                lo, hi = zp, min(127, zp + int(rng.integers(60, 200)))
            else:
                lo, hi = relu(zp)
            cin, cout = p["cin"], p["cout"]
            shape = {CONV3X3: (cout, 3, 3, cin), DW3X3: (3, 3, cout), PW1X1: (cout, cin),
                     CONV5X5: (cout, 5, 5, cin)}[op]
            w = np.clip(np.rint(rng.normal(0, rng.uniform(20, 70), shape)), -127, 127).astype(np.int8)
            if rng.random() < 0.5:     # full-scale weights somewhere
                w.reshape(-1)[rng.integers(0, w.size, 3)] = rng.choice([-127, 127], 3)
            L.update(w=w, bias=np.zeros(cout, np.int32), out_zp=zp, act_min=lo, act_max=hi)
            acc = layer_acc(L, ts, zps)
            spread = np.maximum(acc.reshape(-1, cout).std(axis=0), 1.0)
            bb = bias_bound(op, cin)
            bias = np.rint(rng.normal(0, 0.5, cout) * spread).astype(np.int64)
            last = i == len(plan) - 1     # the head stays informative: no saturated channels there
            if extreme_bias and not last and rng.random() < 0.3:
                j = int(rng.integers(0, cout))
                bias[j] = bb if rng.random() < 0.5 else -bb
            L["bias"] = np.clip(bias, -bb, bb).astype(np.int32)
            acc = layer_acc(L, ts, zps)
            L["mult"], L["shift"] = _calibrate(rng, acc, target=rng.uniform(15, 50), wild=0.0 if last else 0.06)
        desc["layers"].append(L)
        ts.append(layer_forward(L, ts, zps))
        zps.append(int(L["out_zp"]))
    head = ts[-1]
    hzp = int(np.median(head[:, :, 0]))
    desc["table"] = _decode_table(rng, out_channels, hzp)
    q = np.percentile(head[:, :, 0], 80)
    desc["score_threshold_q"] = int(np.clip(q, -128, 127))
    return desc


def speed(w=320, h=256):
    """(seconds, MACs) of one forward of a random ~54 M multiply-add network at w x h (a benchmark, not a
    test: python3 -m vdtools.formats.cnn_ref)."""
    import time
    rng = np.random.default_rng(0)
    d = random_model(rng, width=(8, 16, 32, 16), input_w=w, input_h=h)
    x = preprocess(random_image(rng, h, w, "blobs"), d)
    t = time.perf_counter()
    forward(d, x)
    return time.perf_counter() - t, macs(d, w, h)


if __name__ == "__main__":
    print("cnn_ref.forward: %.3f s for %d multiply-adds at 320x256" % speed())
