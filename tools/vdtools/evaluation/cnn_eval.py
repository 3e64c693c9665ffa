# SPDX-License-Identifier: MIT
"""Accuracy of the CNN detector on a split of ../shared/data (docs/results/detector.md, CNN section).

Per family (msrs = road level; hit = drone incl. the sequence-0_100 flight) and per split: AP@0.5 (the
matching rules of vdtools.metrics.evaluate / vd_fir_demo --eval, ignore regions honoured, all-point interpolated
precision) of every box the run decodes, and at score thresholds the AP@0.5 of the output (the boxes at or
above the threshold: what scoring the demo's JSON at that threshold gives, at most the TP rate) and TP rate /
FP rate / hot and cold TP. Backends: the int8 network
through the C library (`--backend c`, default; vd_cnn_run + vd_cnn_decode, equal bit for bit to the
numpy reference), the numpy integer reference (`--backend ref`), or the float checkpoint (`--ckpt`).
Boxes then go through overlap suppression at IoU 0.5 as in the detector. `--flip` adds the detector's
horizontal-flip test-time augmentation (cfg.cnn_flip / `vd_fir_demo --cnn-flip on`): a second pass on the
mirrored half-resolution plane whose boxes, mirrored back, are fused with the first pass's (fuse_flip:
matched pairs averaged, unmatched boxes at half their score) before suppression.

The operating point is chosen on the VAL split (largest threshold whose TP rate and FP rate meet the
issue's bar on both families, else the best mean F1) and then only reported on the test split.

    python3 -m vdtools.evaluation.cnn_eval --model models/vd_cnn.vdm --split val --out out/val.json
    python3 -m vdtools.evaluation.cnn_eval --model models/vd_cnn.vdm --split test --thr 0.35 --out out/test.json [--pr out.png]
    python3 -m vdtools.evaluation.cnn_eval --model models/vd_cnn.vdm --backend demo --split val --flip
    python3 -m vdtools.evaluation.cnn_eval --model models/vd_cnn.vdm --backend demo --split train --flip \
        --thr 0.35     # the frames the model trained on: seen-scene against unseen-scene accuracy
"""
import argparse
import json
import time
from pathlib import Path

import cv2
import numpy as np

from vdtools.bindings import clib
from vdtools.data import cnn_data as CD
from vdtools.formats import cnn_ref as R
from vdtools.formats import cnn_vdm as V
from vdtools.bindings import cnn as vd_cnn
from vdtools.bindings import detector as vdet
from vdtools.metrics.evaluate import ap_from_flags, average_precision, inside_share, iou, match_flags

THRESHOLDS = [round(0.05 * i, 2) for i in range(1, 20)]

# Camera-like changes applied to the test frames (--perturb): a proxy for "another camera" (other AGC
# curve, contrast, optics, sensor noise), deterministic (noise seeded per frame index).
PERTURB = {
    "gamma0.6": lambda a, r: 255.0 * (a / 255.0) ** 0.6,
    "gamma1.6": lambda a, r: 255.0 * (a / 255.0) ** 1.6,
    "lowcontrast": lambda a, r: 0.6 * a + 50.0,
    "blur1.5": lambda a, r: cv2.GaussianBlur(a, (7, 7), 1.5),
    "noise6": lambda a, r: a + r.normal(0, 6.0, a.shape),
    # harder changes, closer to a real other camera (docs/results/cameras.md): a global histogram
    # equalisation and a local one (CLAHE) as other AGC curves, a brighter curve with its top clipped (a
    # sunny day), and denoise + sharpen (another camera's image processing)
    "equalize": lambda a, r: cv2.equalizeHist(a.astype(np.uint8)),
    "clahe": lambda a, r: cv2.createCLAHE(clipLimit=3.0, tileGridSize=(8, 8)).apply(a.astype(np.uint8)),
    "bright": lambda a, r: 255.0 * np.minimum(1.0, 1.15 * (a / 255.0) ** 0.5),
    "sharpen": lambda a, r: _sharpen(a),
}
# geometric changes (boxes scale too): the frame shrunk so that cars are 10-30 px, as a wider lens shows them
RESCALE = {"down50": 0.5, "down33": 1 / 3}   # down33: cars about the other camera's size (median ~30 px)
# ... and enlarged (bilinear): cars 1.5x / 2x the training size, as a 1280x1024 sensor or a narrower lens shows them
RESCALE.update({"up150": 1.5, "up200": 2.0})


def _sharpen(a):
    """Edge-preserving denoise, then an unsharp mask of amount 1 (sigma 1): a sharper, denoised picture."""
    d = cv2.bilateralFilter(a.astype(np.uint8), 5, 30.0, 3.0).astype(np.float64)
    return d + 1.0 * (d - cv2.GaussianBlur(d, (0, 0), 1.0))


def perturb(frames, name):
    """The frames as another camera would show them (PERTURB: pixel values; RESCALE: size, boxes scaled)."""
    import copy
    out = []
    for i, fr in enumerate(frames):
        g = copy.copy(fr)
        if name in RESCALE:
            f = RESCALE[name]
            h, w = fr.img.shape
            g.img = cv2.resize(fr.img, (int(round(w * f)), int(round(h * f))),
                               interpolation=cv2.INTER_AREA if f < 1 else cv2.INTER_LINEAR)
            g.boxes, g.ignore = fr.boxes * f, fr.ignore * f
            g.others = fr.others.copy()
            g.others[:, :4] *= f
        else:
            a = fr.img.astype(np.float64)
            g.img = np.clip(np.round(PERTURB[name](a, np.random.default_rng(i))), 0, 255).astype(np.uint8)
        out.append(g)
    return out


def _perturb_chain(text):
    """--perturb's value: one change or several joined by '+' -> [names] (argparse type)."""
    names = text.split("+")
    bad = [n for n in names if n not in PERTURB and n not in RESCALE]
    if bad:
        raise argparse.ArgumentTypeError(f"unknown change {', '.join(map(repr, bad))} (choose from "
                                         f"{', '.join(sorted(PERTURB) + sorted(RESCALE))})")
    return names


def nms(dets, thr=0.5):
    """Greedy suppression by score: a box whose IoU with a kept one is > thr goes (the detector's rule)."""
    keep = []
    for d in sorted(dets, key=lambda d: -d[1]):
        if all(iou(d[0], k[0]) <= thr for k in keep):
            keep.append(d)
    return keep


def res_div(res):
    """The detector's vd__detector_cnn_div: res = cfg.cnn_res (False / 0 half, True / 1 full, 2 quarter)."""
    return vdet.CNN_RES_DIV[int(res)]


def net_input(img, align=16, mirror=False, div=2):
    """Half-resolution plane, padded (edge replicate) to a multiple of the model's alignment: the
    detector's network input. mirror: the flip pass's input, the half-resolution plane mirrored left to
    right before the padding (not the frame: for odd widths the detector drops the last frame column).
    div 1: the frame itself (the detector's cfg.cnn_res FULL); 4: its 4x4 box averages (QUARTER)."""
    h = img if div == 1 else CD.box_mean(img, div)
    return CD.pad_to(np.ascontiguousarray(h[:, ::-1]) if mirror else h, align)


SCORE_ONE_Q15 = 32768
FLIP_IOU_Q15 = 9830   # VD_DETECTOR_CNN_FLIP_IOU_Q15 (detector.h): 0.3 in Q15, rounded down


def thr_from_score(desc, score_q15):
    """vd_cnn_thr_from_score: the smallest logit whose decoded score is >= score_q15, or None when even
    logit 127 scores lower."""
    if not 0 <= score_q15 <= SCORE_ONE_Q15:
        raise ValueError("score_q15 must be 0..32768")
    for i, v in enumerate(desc["table"][0]):
        if int(v) >= score_q15:
            return i - 128
    return None


def iou_q15(a, b):
    """vd_rect_iou_q15: intersection over union in Q15, rounded down (0 for an empty box)."""
    ax, ay, aw, ah = (int(v) for v in a)
    bx, by, bw, bh = (int(v) for v in b)
    if aw <= 0 or ah <= 0 or bw <= 0 or bh <= 0:
        return 0
    iw = min(ax + aw, bx + bw) - max(ax, bx)
    ih = min(ay + ah, by + bh) - max(ay, by)
    inter = iw * ih if iw > 0 and ih > 0 else 0
    union = aw * ah + bw * bh - inter
    return (inter << 15) // union


def score_of_logit(desc, q):
    """The decoded heatmap score (Q15) of int8 value q: the model's score table (vd__cnn_score_of_logit)."""
    return int(desc["table"][0][int(q) + 128])


def flip_decode_score(thr_q15):
    """The score at which both passes of the fused flip pass decode, for the score threshold thr_q15 (T):
    max(1, 2 T - 32768), since a fused score (sa + sb + 1) >> 1 can reach T from there."""
    return max(1, 2 * int(thr_q15) - SCORE_ONE_Q15)


def fuse_flip(a, b, thr_q15):
    """The fused flip pass (lib/src/detector_cnn.c fuse_boxes), integer for integer. a, b: the normal and
    the mirrored pass's clipped boxes [((x, y, w, h), score_q15)] in decode order (clip_boxes). In a's order,
    each box takes the unused b box of the largest iou_q15 >= FLIP_IOU_Q15 (ties: the first in b's order):
    corners averaged, x0 = (ax0 + bx0) >> 1 and y0 likewise rounded down, the exclusive x1, y1 rounded up
    ((ax1 + bx1 + 1) >> 1), score (sa + sb + 1) >> 1; an a box without a match keeps its box with score
    (sa + 1) >> 1 (the other pass voted 0); then every unused b box in order with (sb + 1) >> 1. Boxes
    scoring below thr_q15 are dropped. Returns [((x, y, w, h), score_q15)]: a-derived first, then b's."""
    used = [False] * len(b)
    out = []
    for box, sa in a:
        best, best_iou = None, -1
        for j, (other, _) in enumerate(b):
            q = -1 if used[j] else iou_q15(box, other)
            if q >= FLIP_IOU_Q15 and q > best_iou:
                best, best_iou = j, q
        if best is None:
            out.append((tuple(box), (int(sa) + 1) >> 1))
            continue
        used[best] = True
        (ax, ay, aw, ah), ((bx, by, bw, bh), sb) = box, b[best]
        x0, y0 = (ax + bx) >> 1, (ay + by) >> 1
        x1, y1 = (ax + aw + bx + bw + 1) >> 1, (ay + ah + by + bh + 1) >> 1
        out.append(((x0, y0, x1 - x0, y1 - y0), (int(sa) + int(sb) + 1) >> 1))
    out += [(tuple(box), (int(sb) + 1) >> 1) for j, (box, sb) in enumerate(b) if not used[j]]
    return [(box, s) for box, s in out if s >= thr_q15]


def fused_flip_pass(decode, img, align, frame_w, frame_h, dec_q, thr_q15, div=2):
    """The detector's two passes with cfg.cnn_flip: decode(plane, thr_q) -> decoded boxes, run on the plane
    and on its mirror at dec_q (the logit of flip_decode_score(T), or -128), clipped (the mirror's boxes
    mirrored back) and fused with threshold thr_q15 (T): [((x, y, w, h), score_q15)]. div: net_input's."""
    a = clip_boxes(decode(net_input(img, align, div=div), dec_q), frame_w, frame_h)
    b = clip_boxes(decode(net_input(img, align, mirror=True, div=div), dec_q), frame_w, frame_h,
                   flip_hw=img.shape[1] // div, div=div)
    return fuse_flip(a, b, thr_q15)


def clip_boxes(boxes, frame_w, frame_h, flip_hw=None, div=2):
    """Decoded boxes [(x, y, w, h, score_q15, ...)] -> [((x, y, w, h), score_q15)] inside the frame, empty
    ones dropped (lib/src/detector_cnn.c append_boxes). flip_hw: the boxes of the mirrored half-resolution
    plane (hw = frame_w // 2 columns), mirrored back first: [x, x + w) -> [2 hw - x - w, 2 hw - x); with
    div 1 (full resolution) hw = frame_w and the span is hw."""
    out = []
    for bx, by, bw, bh, s, *_ in boxes:
        bx, by, bw, bh = int(bx), int(by), int(bw), int(bh)
        x0, x1 = (bx, bx + bw) if flip_hw is None else (div * flip_hw - bx - bw, div * flip_hw - bx)
        x0, x1, y1 = max(x0, 0), min(x1, frame_w), min(by + bh, frame_h)
        if x1 > x0 and y1 > by:
            out.append(((x0, by, x1 - x0, y1 - by), int(s)))
    return out


class Int8:
    """Runs a .vdm through the C library (or the numpy reference). flip: the detector's cfg.cnn_flip, the fused
    flip pass: a second pass on the mirrored half-resolution plane (mirrored before the padding, so odd widths
    match C), its boxes mirrored back and fused with the first pass's (fuse_flip)."""

    def __init__(self, model_path, backend="c", flip=False, full_res=False):
        self.blob = Path(model_path).read_bytes()
        self.desc = V.unpack(self.blob)
        self.backend = backend
        self.flip = flip
        self.div = res_div(full_res)   # full_res: the detector's cfg.cnn_res (False / 0, True / 1, 2 quarter)
        self.c = vd_cnn.CModel(self.blob) if backend == "c" else None
        self.align = V.alignment(self.desc)

    def _decode(self, x, thr_q, factor=None, max_peaks=100):
        """Boxes of plane x in the coordinates of a frame `factor` times its size (default self.div: 2 for
        the half-resolution plane, 1 at full resolution)."""
        factor = self.div if factor is None else factor
        fw, fh = x.shape[1] * factor, x.shape[0] * factor
        if self.c is not None:
            return self.c.decode(self.c.run(x), fw, fh, thr_q=thr_q, max_peaks=max_peaks)
        return R.decode(self.desc, R.run(self.desc, x), fw, fh, thr_q=thr_q, max_peaks=max_peaks)

    def __call__(self, img, frame_w, frame_h, thr_q=-128, score_thr_q15=None):
        """[((x, y, w, h), score)], score = score_q15 / 32768. thr_q: int8 heatmap threshold (-128, the
        default for AP curves: every peak); score_thr_q15: a Q15 score threshold instead (the detector's
        cnn_score_thr_q15). With flip the threshold T is score_thr_q15, else the score of logit thr_q (0 for
        -128: every peak of both passes, nothing dropped); both passes decode at the logit of
        flip_decode_score(T) (every peak when T = 0) and fused boxes below T are dropped."""
        if score_thr_q15 is not None and not self.flip:
            thr_q = thr_from_score(self.desc, score_thr_q15)
            if thr_q is None:
                return []
        if not self.flip:
            return [(b, s / 32768.0) for b, s in clip_boxes(self._decode(net_input(img, self.align, div=self.div),
                                                                          thr_q), frame_w, frame_h)]
        if score_thr_q15 is not None:
            t = int(score_thr_q15)
        else:
            t = 0 if thr_q == -128 else score_of_logit(self.desc, thr_q)
        dec_q = -128 if t == 0 else thr_from_score(self.desc, flip_decode_score(t))
        if dec_q is None:
            return []
        fused = fused_flip_pass(self._decode, img, self.align, frame_w, frame_h, dec_q, t, self.div)
        return [(box, s / 32768.0) for box, s in fused]


def fuse_pair(nets, img, frame_w, frame_h, t, flip, every_peak=False, div=2):
    """The detector's cfg.cnn_model2 (lib/src/detector_cnn.c), integer for integer: nets = two (desc, align,
    decode(plane, thr_q)) of the first and the second network. Each decodes, through its own score table, at
    the logit of max(1, P T - (P - 1) 32768), P = 2 (4 with flip: the passes averaged into a final score),
    or every peak with every_peak (AP curves); with flip its two passes are fused without a threshold
    (fused_flip_pass at 0). A network none of whose logits reaches that score adds no box. Then the first
    network's boxes and the second's are fused at T (fuse_flip): [((x, y, w, h), score_q15)]. div: net_input's
    (1: cfg.cnn_res)."""
    p = 4 if flip else 2
    lo = max(1, p * int(t) - (p - 1) * SCORE_ONE_Q15)
    sets = []
    for desc, align, decode in nets:
        q = -128 if every_peak else thr_from_score(desc, lo)
        if q is None:
            sets.append([])
        elif flip:
            sets.append(fused_flip_pass(decode, img, align, frame_w, frame_h, q, 0, div))
        else:
            sets.append(clip_boxes(decode(net_input(img, align, div=div), q), frame_w, frame_h))
    return fuse_flip(sets[0], sets[1], t)


class Pair:
    """Two networks' boxes fused, the detector's cfg.cnn_model2 (vd_fir_demo --cnn-model2; fuse_pair), through
    the C library or the numpy reference, each network at its header's top-K. first, second: Int8 of the same
    backend and flip."""

    def __init__(self, first, second):
        if first.flip != second.flip or first.div != second.div:
            raise ValueError("both networks of a pair run with the same flip and resolution settings")
        self.nets, self.flip, self.div = (first, second), first.flip, first.div

    def __call__(self, img, frame_w, frame_h, thr_q=-128, score_thr_q15=None):
        """As Int8.__call__: T = score_thr_q15 (nothing runs when it is above both networks' top scores),
        else the score of first's logit thr_q (0 for -128: every peak)."""
        if score_thr_q15 is not None:
            t = int(score_thr_q15)
            if all(thr_from_score(n.desc, t) is None for n in self.nets):
                return []
        else:
            t = 0 if thr_q == -128 else score_of_logit(self.nets[0].desc, thr_q)
        nets = [(n.desc, n.align, lambda x, q, n=n: n._decode(x, q, max_peaks=int(n.desc["max_peaks"])))
                for n in self.nets]
        return [(box, s / 32768.0) for box, s in fuse_pair(nets, img, frame_w, frame_h, t, self.flip, t == 0,
                                                                self.div)]


class ExtraScale:
    """Multi-scale test-time augmentation, an experiment (cnn_eval --extra-scale; not in the detector): the
    network's boxes on the frame at a second scale, appended to those of `base` (an Int8) before
    suppression. factor: the frame side divided by the extra plane's side (4: quarter resolution, made by
    two exact 2x2 box averages; 1: the full-resolution frame). The extra scale runs the fused flip pass
    too (every peak, fuse_flip at threshold 0). h_range: keep only the extra scale's boxes whose height in
    frame pixels is in [lo, hi)."""

    def __init__(self, base, factor, h_range=(0, 1 << 30)):
        if factor not in (1, 4):
            raise ValueError("extra scale factor: 1 (full resolution) or 4 (quarter resolution)")
        self.base, self.factor, self.h_range = base, factor, h_range

    def _boxes(self, img, fw, fh, mirror):
        plane = img if self.factor == 1 else CD.half(CD.half(img))
        plane = np.ascontiguousarray(plane[:, ::-1]) if mirror else plane
        dec = self.base._decode(CD.pad_to(plane, self.base.align), -128, self.factor)
        f = self.factor
        return clip_boxes(dec, fw, fh, flip_hw=(img.shape[1] // f) * f // 2 if mirror else None)

    def __call__(self, img, frame_w, frame_h):
        lo, hi = self.h_range
        extra = fuse_flip(self._boxes(img, frame_w, frame_h, False), self._boxes(img, frame_w, frame_h, True), 0)
        return self.base(img, frame_w, frame_h) + [(b, sc / 32768.0) for b, sc in extra if lo <= b[3] < hi]


class Tiles:
    """Tiled inference at full resolution, an experiment (cnn_eval --tiles; not in the detector): the pair (an
    int8 Pair of the C backend with flip and full_res) on an nx x ny grid of tiles half the frame's width and
    height, evenly spaced (overlapping for nx or ny > 2), each tile a network input of its own, its boxes moved
    into the frame; run()'s suppression merges the tiles. A tile of half the frame's sides has the workspace
    of the half-resolution run, so this is the one exact-memory way to full resolution on 256 KiB
    (docs/architecture.md, "Why full resolution does not fit"). Each network's input normalisation is taken
    over the whole frame (padded as the detector pads it) and the tiles run through a copy of the model without
    one, so a tile differs from the whole-frame run by its borders alone: Tiles(pair, 1, 1, 1.0) is the pair
    at full resolution."""

    def __init__(self, pair, nx, ny, frac=0.5):
        if not (isinstance(pair, Pair) and pair.flip and pair.div == 1 and all(n.c is not None for n in pair.nets)):
            raise ValueError("--tiles runs an int8 pair of the C backend with --flip and --full-res")
        self.nx, self.ny, self.frac = int(nx), int(ny), float(frac)
        self.nets = []
        for n in pair.nets:
            d0 = dict(n.desc, input_norm=0, norm_lo_permille=0, norm_hi_permille=0, norm_min_range=0)
            self.nets.append((n, vd_cnn.CModel(V.pack(d0))))

    def _pos(self, k, n, size, tile):
        return 0 if n == 1 else int(round(k * (size - tile) / (n - 1)))

    def __call__(self, img, frame_w, frame_h):
        h, w = img.shape
        tw, th = int(round(w * self.frac)), int(round(h * self.frac))
        planes = []
        for n, c in self.nets:
            pad = CD.pad_to(img, n.align)
            q = (R.preprocess(pad, n.desc)[:h, :w, 0].astype(np.int16) + 128).astype(np.uint8)
            dec = (lambda x, t, n=n, c=c: c.decode(c.run(x), x.shape[1], x.shape[0], thr_q=t,
                                                   max_peaks=int(n.desc["max_peaks"])))
            planes.append((q, n.align, dec))
        out = []
        for j in range(self.ny):
            y0 = self._pos(j, self.ny, h, th)
            for i in range(self.nx):
                x0 = self._pos(i, self.nx, w, tw)
                sets = [fused_flip_pass(dec, np.ascontiguousarray(q[y0:y0 + th, x0:x0 + tw]), align, tw, th, -128, 0,
                                        1) for q, align, dec in planes]
                out += [((x + x0, y + y0, bw, bh), sc / 32768.0) for (x, y, bw, bh), sc in fuse_flip(sets[0], sets[1], 0)]
        return out


def float_boxes_q15(boxes):
    """Float boxes of the half-resolution plane [(x, y, w, h, score)] -> [(x, y, w, h, score_q15)] in frame
    pixels, corners rounded to the nearest pixel, so that clip_boxes, fuse_flip and fuse_pair (the detector's
    integer rules) fuse a float network's passes exactly as they fuse the int8 network's."""
    out = []
    for x, y, w, h, s in boxes:
        x0, y0 = int(round(2 * x)), int(round(2 * y))
        x1, y1 = int(round(2 * (x + w))), int(round(2 * (y + h)))
        out.append((x0, y0, x1 - x0, y1 - y0, min(SCORE_ONE_Q15, int(round(s * SCORE_ONE_Q15)))))
    return out


class Float:
    """A float checkpoint (or models/float/*.npz), every peak scoring >= 0.02. flip: the fused flip pass with
    the detector's integer rule (fuse_flip at threshold 0 on the float scores in Q15), so that the float
    figures of the shipped operating point (flip passes, a pair) stand beside the int8 ones."""

    def __init__(self, ckpt, flip=False):
        import torch
        from vdtools.training import cnn_export as E
        from vdtools.training import cnn_train as T
        self.torch, self.T, self.flip = torch, T, flip
        self.net, _ = E.load_net(ckpt)

    def _peaks(self, img, mirror=False):
        """decode_float's boxes (half-resolution plane, float) of the frame or its mirror."""
        with self.torch.no_grad():
            o = self.net(self.T.to_input(net_input(img, self.net.align, mirror=mirror), self.net.norm))
        return self.T.decode_float(o, 0.02)

    def boxes_q15(self, img, frame_w, frame_h):
        """[((x, y, w, h), score_q15)] clipped to the frame, the flip passes fused when flip."""
        def one(mirror):
            return clip_boxes(float_boxes_q15(self._peaks(img, mirror)), frame_w, frame_h,
                              flip_hw=img.shape[1] // 2 if mirror else None)
        return fuse_flip(one(False), one(True), 0) if self.flip else one(False)

    def __call__(self, img, frame_w, frame_h, thr_q=None):
        if not self.flip:   # unchanged since the first float figures: boxes as decoded, not rounded
            return [((x * 2, y * 2, w * 2, h * 2), s) for x, y, w, h, s in self._peaks(img)]
        return [(b, s / 32768.0) for b, s in self.boxes_q15(img, frame_w, frame_h)]


class FloatEnsemble(Float):
    """An experiment (cnn_eval --ensemble; not in the detector): several float networks whose output maps are
    averaged before decoding (heatmap probabilities and box channels, on the region all of them cover: the
    padding is right and bottom), the ceiling of what ensembling or distilling them could give one network.
    Decoded and flip-fused as Float."""

    def __init__(self, ckpts, flip=False):
        super().__init__(ckpts[0], flip)
        self.nets = [self.net] + [Float(c).net for c in ckpts[1:]]

    def _peaks(self, img, mirror=False):
        torch = self.torch
        with torch.no_grad():
            p, box = self.T.mean_maps([n(self.T.to_input(net_input(img, n.align, mirror=mirror), n.norm)) for n in self.nets])
            o = torch.cat([torch.logit(p.clamp(1e-6, 1 - 1e-6))[:, None], box], 1)
        return self.T.decode_float(o, 0.02)


class FloatPair:
    """Two float networks fused by the pair rule (fuse_pair's last step, fuse_flip at threshold 0 on every
    box): the float counterpart of Pair, for the pair's int8-vs-float figure. Each network keeps every peak
    >= 0.02 (up to 100), not its header's top-K."""

    def __init__(self, first, second):
        if first.flip != second.flip:
            raise ValueError("both networks of a pair run with the same flip setting")
        self.nets = (first, second)

    def __call__(self, img, frame_w, frame_h, thr_q=None):
        a, b = (n.boxes_q15(img, frame_w, frame_h) for n in self.nets)
        return [(box, s / 32768.0) for box, s in fuse_flip(a, b, 0)]


def run(pred, frames):
    """[(family, frame, dets after suppression, gts)]."""
    out = []
    for fr in frames:
        h, w = fr.img.shape
        dets = nms(pred(fr.img, w, h))
        gts = [tuple(b) + (True, False) for b in fr.boxes.tolist()] + \
              [tuple(b) + (False, True) for b in fr.ignore.tolist()]
        out.append((CD.family(fr), fr, dets, gts))
    return out


def run_demo(demo, model, frames, extra=(), tmp="out/cnn_eval", paper=None, model2=None):
    """The whole C detector (vd_fir_demo --sources cnn, temporal off, score threshold 0.05 so that the
    AP sees the low-score tail) on frames; results as run(). One demo call per family (file names of
    the two HIT-UAV folders could collide). extra: more demo flags (e.g. --cnn-flip on)."""
    import subprocess
    tmp = Path(tmp)
    tmp.mkdir(parents=True, exist_ok=True)
    out = []
    fams = {}
    for fr in frames:
        fams.setdefault(fr.dataset, []).append(fr)
    # Every box both passes decode (2 x top-K) survives suppression: the demo keeps top-K detections, which
    # the low-score tail of the AP curve can exceed with the flip pass.
    # model2 (--cnn-model2): both networks' top-K, each twice.
    k2 = None if paper is not None else 2 * sum(V.unpack(Path(m).read_bytes())["max_peaks"]
                                                for m in (model, model2) if m is not None)
    for ds, frs in sorted(fams.items()):
        lst, js = tmp / f"{ds}.txt", tmp / f"{ds}.jsonl"
        paths = {}
        for fr in frs:
            p = CD.frame_path(fr)
            paths[Path(p).name] = fr
        lst.write_text("".join(f"{Path(CD.frame_path(fr)).resolve()}\n" for fr in frs))   # list entries are read relative to the list
        if paper is None:
            src = ["--sources", "cnn", "--cnn-model", str(model), "--model", "none", "--cnn-thr", "0.05",
                   "--max-candidates", str(k2), "--max-detections", str(k2)] + \
                  ["--cnn-model2", str(model2) if model2 else "none"]
        else:   # the paper pipeline with a DBN model, for the comparison rows (score threshold 0.05 for AP)
            src = ["--model", str(model), "--score-thr", "0.05"] + list(paper)
        cmd = [str(demo), "--input", str(lst)] + src + ["--temporal", "off", "--json", str(js), "--quiet"] + list(extra)
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
        for line in js.read_text().splitlines():
            rec = json.loads(line)
            fr = paths[Path(rec["frame"]).name]
            dets = [(tuple(d["box"]), float(d["score"])) for d in rec["detections"]]
            gts = [tuple(b) + (True, False) for b in fr.boxes.tolist()] + \
                  [tuple(b) + (False, True) for b in fr.ignore.tolist()]
            out.append((CD.family(fr), fr, dets, gts))
    return out


def counts_at(dets, gts, thr):
    """One frame's detections [(box, score)] kept at score >= thr against its ground truth: (TP, FP, matched
    ground-truth indices); a detection in an ignore region counts as neither."""
    flags, matched = match_flags([d for d in dets if d[1] >= thr], gts)
    return sum(1 for _, f in flags if f == 1), sum(1 for _, f in flags if f == 0), matched


def figures(results, thresholds=THRESHOLDS):
    """{family: {ap, n_frames, n_vehicles, pr: (recall, precision), at: {thr: {...}}}}."""
    fams = {}
    for fam, fr, dets, gts in results:
        fams.setdefault(fam, []).append((fr, dets, gts))
    rep = {}
    for fam, items in sorted(fams.items()):
        ap, rec, prec = average_precision([(d, g) for _, d, g in items])
        # Matching is greedy by falling score, so a box's flag does not depend on the boxes scored below it: the
        # flags of the output at threshold t are the full ranking's flags >= t, matched once here.
        flags = [sf for _, d, g in items for sf in match_flags(d, g)[0] if sf[1] is not None]
        n_pos = sum(1 for _, _, g in items for x in g if x[4])
        at = {}
        for t in thresholds:
            tp = fp = n = hot_tp = hot_n = 0
            for fr, dets, gts in items:
                t_tp, t_fp, matched = counts_at(dets, gts, t)
                tp += t_tp
                fp += t_fp
                n += len(fr.boxes)
                hot_n += int(fr.hot.sum())
                hot_tp += sum(1 for k in matched if k < len(fr.boxes) and fr.hot[k])
            cold_n = n - hot_n
            # ap_out: the AP of what a detector running at threshold t outputs (its boxes >= t ranked by
            # score), the figure that scoring the demo's JSON gives; `ap` above ranks every box the run
            # decoded (down to 0.05 through the demo) and bounds it from above: the boxes >= t are the top
            # of that ranking, and appending lower-scored boxes never lowers an all-point AP.
            ap_out = ap_from_flags([sf for sf in flags if sf[0] >= t], n_pos)[0]
            at[t] = dict(tp=tp, fp=fp, fn=n - tp, tp_rate=tp / max(n, 1), fp_rate=fp / max(tp + fp, 1),
                         hot_tp_rate=hot_tp / max(hot_n, 1), cold_tp_rate=(tp - hot_tp) / max(cold_n, 1),
                         hot=hot_n, cold=cold_n, ap_out=ap_out)
        rep[fam] = dict(ap=ap, n_frames=len(items), n_vehicles=sum(len(fr.boxes) for fr, _, _ in items),
                        pr=(rec, prec), at=at)
    return rep


def subset_ap(results):
    """{subset: (AP@0.5, frames, vehicles)}."""
    by = {}
    for fam, fr, dets, gts in results:
        by.setdefault(CD.subset(fr), []).append((fr, dets, gts))
    return {k: (average_precision([(d, g) for _, d, g in v])[0], len(v), sum(len(fr.boxes) for fr, _, _ in v))
            for k, v in sorted(by.items())}


def angle_ap(results):
    """{"day 30": (AP@0.5, vehicles), ...} of the drone-view frames by camera angle (cnn_data.hit_view: the
    HIT-UAV file name; the flight too), day before night, angles ascending."""
    by = {}
    for fam, fr, dets, gts in results:
        view = CD.hit_view(fr)
        if view is not None:
            by.setdefault(view, []).append((fr, dets, gts))
    return {f"{'night' if night else 'day'} {deg}": (average_precision([(d, g) for _, d, g in v])[0],
                                                     sum(len(fr.boxes) for fr, _, _ in v))
            for (night, deg), v in sorted(by.items())}


HEIGHT_BINS = (0, 24, 32, 48, 64, 96, 160, 1 << 30)


def height_recall(results, thr, bins=HEIGHT_BINS):
    """{family: [(lo, hi, vehicles, found, localised)]} by annotated box height (frame pixels): `found` = some
    detection with IoU >= 0.5 scores >= thr, `localised` = some detection with IoU >= 0.5 at any score (what
    a lower threshold could still find). Per vehicle, without the one-to-one matching of AP: a diagnosis of
    where misses are, not an accuracy figure."""
    out = {}
    for fam, fr, dets, gts in results:
        rows = out.setdefault(fam, [[lo, hi, 0, 0, 0] for lo, hi in zip(bins[:-1], bins[1:])])
        for g in fr.boxes.tolist():
            s = max((d[1] for d in dets if iou(d[0], tuple(g)) >= 0.5), default=None)
            r = next(r for r in rows if r[0] <= g[3] < r[1])
            r[2] += 1
            r[3] += int(s is not None and s >= thr)
            r[4] += int(s is not None)
    return {k: [tuple(r) for r in v if r[2]] for k, v in sorted(out.items())}


FP_KINDS = ("background", "road_user", "misplaced", "part", "around", "duplicate")


def fp_kinds(results, thr):
    """{family: {kind: count}} of the false positives scoring >= thr (match_flags' rules, so the same ones the
    FP rate counts), by how they meet the labelled vehicles: `duplicate` IoU >= 0.5 with a vehicle a better
    box already took; else, with IoU >= 0.1 to some vehicle, `part` (>= 70 % of the box inside it), `around`
    (>= 70 % of the vehicle inside the box) or `misplaced`; below 0.1 with every vehicle, `road_user` when
    it meets a labelled person or bicycle (IoU >= 0.1, or half of it inside the box; Frame.others), else
    `background` (an unlabelled car or another object; until 2026-11-28 road users counted as background).
    A diagnosis: is a suppression or box rule worth trying, or is it recognition, and of what?"""
    out = {}
    for fam, fr, dets, gts in results:
        users = fr.others[:, :4].tolist()
        kinds = out.setdefault(fam, dict.fromkeys(FP_KINDS, 0))
        dets = sorted(dets, key=lambda d: -d[1])    # stable: match_flags' order, so its flags line up
        flags, _ = match_flags(dets, gts)
        cars = [g[:4] for g in gts if g[4]]
        for (box, score), (_, flag) in zip(dets, flags):
            if flag != 0 or score < thr:
                continue
            best = max(cars, key=lambda g: iou(box, g), default=None)
            v = iou(box, best) if best is not None else 0.0
            if v >= 0.5:
                kinds["duplicate"] += 1
            elif v < 0.1:
                on_user = any(iou(box, u) >= 0.1 or inside_share(u, box) >= 0.5 for u in users)
                kinds["road_user" if on_user else "background"] += 1
            elif inside_share(box, best) >= 0.7:
                kinds["part"] += 1
            elif inside_share(best, box) >= 0.7:
                kinds["around"] += 1
            else:
                kinds["misplaced"] += 1
    return dict(sorted(out.items()))


def choose_threshold(rep):
    """Operating point on the val split: the threshold with TP >= 70 % and FP <= 30 % on every family and
    the highest mean F1 among those; else the highest mean F1 overall."""
    def f1(a):
        p, r = 1 - a["fp_rate"], a["tp_rate"]
        return 2 * p * r / max(p + r, 1e-9)
    best = None
    for t in THRESHOLDS:
        ok = all(v["at"][t]["tp_rate"] >= 0.70 and v["at"][t]["fp_rate"] <= 0.30 for v in rep.values())
        score = (ok, float(np.mean([f1(v["at"][t]) for v in rep.values()])))
        if best is None or score > best[0]:
            best = (score, t)
    return best[1]


def plot_pr(rep, path, title):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(5, 4), dpi=100)
    for fam, v in rep.items():
        rec, prec = v["pr"]
        ax.plot(rec, prec, label=f"{fam} (AP@0.5 {100 * v['ap']:.1f})")
    ax.set_xlabel("recall (TP rate)")
    ax.set_ylabel("precision (1 - FP rate)")
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1.01)
    ax.grid(alpha=0.3)
    ax.legend(loc="lower left")
    ax.set_title(title)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def summary(rep, thr=None):
    out = {}
    for fam, v in rep.items():
        d = dict(ap=v["ap"], n_frames=v["n_frames"], n_vehicles=v["n_vehicles"])
        if thr is not None:
            d["at_thr"] = v["at"][thr]
        d["at"] = v["at"]
        out[fam] = d
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--model", help=".vdm (int8)")
    ap.add_argument("--model2", help="a second .vdm fused with --model (the detector's cnn_model2, "
                    "vd_fir_demo --cnn-model2; class Pair)")
    ap.add_argument("--ckpt", help="float checkpoint instead of --model")
    ap.add_argument("--ckpt2", help="a second float checkpoint fused with --ckpt by the pair rule (FloatPair): "
                                    "the float counterpart of --model2")
    ap.add_argument("--ensemble", action="append", default=[], help="experiment (repeatable): a further float "
                    "checkpoint whose output maps are averaged with --ckpt's before decoding (FloatEnsemble)")
    ap.add_argument("--backend", default="c", choices=("c", "ref", "demo"),
                    help="c: vd_cnn_run/decode + suppression here; ref: numpy reference; demo: the whole C "
                         "detector through vd_fir_demo (--demo), the figures docs/results/detector.md reports")
    ap.add_argument("--demo", default=str(clib.REPO / "build" / "tools" / "vd_fir_demo"))
    ap.add_argument("--split", default="val", choices=("val", "test", "train", "all"),
                    help="all: every frame (only with --subset, for a model trained without that subset); "
                         "train: the frames the model trained on, for the generalisation gap (not accuracy)")
    ap.add_argument("--subset", choices=("msrs-night",),
                    help="only these frames: the another-camera estimate of docs/results/detector.md (a model "
                         "trained with cnn_train --exclude msrs-night, run on the night MSRS frames it never saw)")
    ap.add_argument("--data", default=str(clib.REPO.parent / "shared" / "data"))
    ap.add_argument("--paper", help="evaluate the paper pipeline instead: demo flags, e.g. \"--sources hotspot\" "
                    "(--model is then a DBN model; --backend demo)")
    ap.add_argument("--thr", type=float, help="operating point to report (default: chosen here, val split only)")
    ap.add_argument("--perturb", type=_perturb_chain, metavar="|".join(sorted(PERTURB) + sorted(RESCALE)),
                    help="camera-like change of the frames (backends c/ref); several chained with '+', applied "
                         "in that order, e.g. bright+down33")
    ap.add_argument("--flip", action="store_true",
                    help="horizontal-flip test-time augmentation: a second pass on the mirrored half-resolution "
                         "plane, its boxes fused with the first pass's (backends c/ref; with --backend demo: "
                         "vd_fir_demo --cnn-flip on)")
    ap.add_argument("--full-res", action="store_true",
                    help="the networks read the frame at full resolution instead of half (the detector's "
                         "cfg.cnn_res, vd_fir_demo --cnn-full-res; backends c/ref/demo)")
    ap.add_argument("--res", choices=vdet.CNN_RES_NAMES,
                    help="the networks' input resolution (the detector's cfg.cnn_res, vd_fir_demo --cnn-res; "
                         "full = --full-res; backends c/ref/demo)")
    ap.add_argument("--extra-scale", type=int, choices=(1, 4),
                    help="experiment: also run the network (fused flip pass) on the frame at full (1) or quarter (4) "
                         "resolution and append those boxes before suppression (backends c/ref; ExtraScale)")
    ap.add_argument("--extra-h", help="with --extra-scale: keep only its boxes of height lo:hi frame pixels "
                    "(lo <= h < hi; default all)")
    ap.add_argument("--tiles", metavar="NXxNY",
                    help="experiment: the pair (--model2, --flip, --full-res, backend c) on NX x NY tiles half the "
                         "frame's sides, e.g. 2x2, 3x3 (Tiles)")
    ap.add_argument("--out", help="JSON report")
    ap.add_argument("--pr", help="precision-recall PNG")
    a = ap.parse_args(argv)
    if a.split == "all" and not a.subset:
        raise SystemExit("--split all is only for --subset (frames the model never trained on)")
    if a.split == "train" and a.subset:
        raise SystemExit("--subset is for a model trained without it: use --split all")
    if a.flip and a.paper:
        raise SystemExit("--flip is for the networks (--model or --ckpt), not --paper")
    if a.ckpt2 and not a.ckpt:
        raise SystemExit("--ckpt2 pairs two float networks: give --ckpt too")
    if a.res is not None:
        if a.full_res and a.res != "full":
            raise SystemExit("--full-res and --res disagree")
        a.full_res = vdet.CNN_RES_NAMES.index(a.res)   # cfg.cnn_res (Int8's full_res takes 0/1/2)
    if a.full_res and (a.ckpt or a.paper or a.extra_scale):
        raise SystemExit("--full-res is for the int8 networks (--model, --model2) without --extra-scale")
    if a.extra_scale and a.backend == "demo":
        raise SystemExit("--extra-scale is an experiment of backends c/ref (the detector has no such pass)")
    frames = CD.load_frames(a.data, splits=("train", "val", "test") if a.split == "all" else (a.split,))
    if a.subset == "msrs-night":     # the rule of cnn_train --exclude msrs-night
        frames = [f for f in frames if CD.subset(f) == "msrs-night"]
    for name in a.perturb or []:
        frames = perturb(frames, name)
    t0 = time.time()
    if a.backend == "demo" and not a.ckpt:
        res = run_demo(a.demo, a.model, frames, paper=None if a.paper is None else a.paper.split(),
                       extra=[] if a.paper else ["--cnn-flip", "on" if a.flip else "off"]
                       + ["--cnn-res", vdet.CNN_RES_NAMES[int(a.full_res)]], model2=a.model2)
    else:
        if a.ensemble and (not a.ckpt or a.ckpt2):
            raise SystemExit("--ensemble averages float networks with --ckpt (not a pair)")
        if a.ensemble:
            pred = FloatEnsemble([a.ckpt] + a.ensemble, flip=a.flip)
        else:
            pred = Float(a.ckpt, flip=a.flip) if a.ckpt else Int8(a.model, a.backend, flip=a.flip, full_res=a.full_res)
        if a.ckpt2:
            pred = FloatPair(pred, Float(a.ckpt2, flip=a.flip))
        if a.model2:
            if a.ckpt or a.extra_scale:
                raise SystemExit("--model2 pairs two int8 networks (--model), without --extra-scale")
            pred = Pair(pred, Int8(a.model2, a.backend, flip=a.flip, full_res=a.full_res))
        if a.extra_scale:
            if a.ckpt or not a.flip:
                raise SystemExit("--extra-scale is for the int8 network with --flip")
            h = {} if a.extra_h is None else dict(h_range=tuple(int(v) for v in a.extra_h.split(":")))
            pred = ExtraScale(pred, a.extra_scale, **h)
        if a.tiles:
            nx, ny = (int(v) for v in a.tiles.lower().split("x"))
            pred = Tiles(pred, nx, ny)
        res = run(pred, frames)
    sec = time.time() - t0
    # --thr may be off the grid, e.g. the exact score of a header's threshold (the demo's default)
    rep = figures(res, sorted(set(THRESHOLDS) | ({a.thr} if a.thr is not None else set())))
    thr = a.thr
    if thr is None:
        if a.split != "val":
            raise SystemExit("choose the operating point on the val split, then pass --thr")
        thr = choose_threshold(rep)
    for fam, v in rep.items():
        at = v["at"][thr]
        print(f"{a.split} {fam}: {v['n_frames']} frames, {v['n_vehicles']} vehicles; AP@0.5 {100 * v['ap']:.1f}; "
              f"at {thr}: AP@0.5 of the output {100 * at['ap_out']:.1f}, "
              f"TP {100 * at['tp_rate']:.1f} % FP {100 * at['fp_rate']:.1f} % "
              f"(hot {100 * at['hot_tp_rate']:.1f} %, cold {100 * at['cold_tp_rate']:.1f} %)")
    subsets = subset_ap(res)
    print("AP@0.5 per subset: " + ", ".join(f"{k} {100 * ap:.1f} ({nf} frames, {nv} vehicles)"
                                             for k, (ap, nf, nv) in subsets.items()))
    angles = angle_ap(res)
    if angles:
        print("drone AP@0.5 per camera angle (degrees): " + ", ".join(f"{k} {100 * ap:.1f} ({nv})"
                                                                       for k, (ap, nv) in angles.items()))
    heights = height_recall(res, thr)
    for fam, rows in heights.items():
        print(f"{fam} by box height (px: vehicles, found at {thr} %, a box with IoU >= 0.5 at any score %): " +
              ", ".join(f"{lo}-{hi if hi < 1 << 30 else ''}: {n}, {100 * f / n:.0f}, {100 * l / n:.0f}"
                        for lo, hi, n, f, l in rows))
    kinds = fp_kinds(res, thr)
    for fam, k in kinds.items():
        print(f"{fam} false positives at {thr} by kind: " + ", ".join(f"{n} {v}" for n, v in k.items()))
    print(f"threshold {thr}; {'flip pass on; ' if a.flip else ''}{len(frames)} frames in {sec:.1f} s")
    if a.pr:
        second = a.model2 or a.ckpt2
        name = Path(a.model or a.ckpt).name + (f" + {Path(second).name}" if second else "")
        plot_pr(rep, a.pr, f"CNN detector, {a.split} split ({name})")
    if a.out:
        Path(a.out).write_text(json.dumps(dict(split=a.split, model=a.model or a.ckpt, model2=a.model2 or a.ckpt2, thr=thr,
                                               flip=a.flip, **({"ensemble": a.ensemble} if a.ensemble else {}),
                                               families=summary(rep, thr),
                                               subsets={k: dict(ap=ap, n_frames=nf, n_vehicles=nv)
                                                        for k, (ap, nf, nv) in subsets.items()},
                                               angles={k: dict(ap=ap, n_vehicles=nv) for k, (ap, nv) in angles.items()},
                                               fp_kinds=kinds,
                                               by_height={k: [dict(lo=lo, hi=hi, vehicles=n, found=f, localised=l)
                                                              for lo, hi, n, f, l in v] for k, v in heights.items()}),
                                          indent=1) + "\n")


if __name__ == "__main__":
    main()
