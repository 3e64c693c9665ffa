# SPDX-License-Identifier: MIT
"""The C detector's CNN source (lib/src/detector_cnn.c, vd_detector_cfg_t.cnn_*) in Python, integer for
integer: what `vd_fir_demo --sources cnn --temporal off` reports for an 8-bit frame.

Pipeline: vdtools.evaluation.cnn_eval.net_input (half resolution, edge padding to the model's alignment) ->
numpy integer reference (vdtools.formats.cnn_ref, equal to vd_cnn_run) -> decode at the header's top-K into a
2 nw x 2 nh frame -> boxes clipped to the real frame (as cnn_eval.Int8) -> score_q8 -> the detector's
budget (max_candidates) and overlap suppression (vd_suppress_nms) -> max_detections. With flip
(cfg.cnn_flip, `--cnn-flip on`) a second pass on the mirrored half-resolution plane follows the first, its
boxes mirrored back (cnn_eval.clip_boxes) and appended before the budget.

Differences from cnn_eval.run (kept here so cnn_eval is not changed):
- suppression is the C rule: a stable sort by score_q8 (not the Q15 score: boxes whose scores round to
  the same Q8 keep the decode order, logit descending then raster), and a box goes when its IoU, as
  Q15 rounded down (vd_rect_iou_q15), is > iou_q15 (16384 = 0.5); cnn_eval.nms compares a float IoU
  with > 0.5, which differs for IoU in (0.5, 16385/32768), i.e. unions above 16384 px;
- the decode's top-K is the header's max_peaks (cnn_eval.Int8 passes 100; equal for models with
  max_peaks 100);
- a score threshold is applied as the int8 logit threshold vd_cnn_thr_from_score gives.

    from vdtools.evaluation import cnn_detector as CDet
    dets = CDet.detect(desc, img)   # [((x, y, w, h), score_q8)], best first
"""
import numpy as np

from vdtools.data import cnn_data as CD
from vdtools.evaluation import cnn_eval
from vdtools.formats import cnn_ref as R
from vdtools.formats import cnn_vdm as V

SCORE_ONE_Q15 = 32768


def thr_from_score(desc, score_q15):
    """vd_cnn_thr_from_score: the smallest logit whose decoded score is >= score_q15, or None when even
    logit 127 scores lower."""
    if not 0 <= score_q15 <= SCORE_ONE_Q15:
        raise ValueError("score_q15 must be 0..32768")
    for i, v in enumerate(desc["table"][0]):
        if int(v) >= score_q15:
            return i - 128
    return None


def score_q8(score_q15):
    """The detector's Q15 -> Q8 score: rounded half up, 1.0 saturating at 255."""
    return min(255, (int(score_q15) + 64) >> 7)


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


def nms_q15(dets, iou_thr_q15=16384, max_keep=None):
    """vd_suppress_nms on [(box, score_q8, ...)]: stable sort by score_q8 (best first), then a box is
    dropped when iou_q15 with a kept one is > iou_thr_q15; at most max_keep are kept."""
    keep = []
    for d in sorted(dets, key=lambda d: -d[1]):
        if all(iou_q15(d[0], k[0]) <= iou_thr_q15 for k in keep) and (max_keep is None or len(keep) < max_keep):
            keep.append(d)
    return keep


def boxes(desc, img, thr_q=None, flip=False):
    """The CNN source's candidates of an 8-bit frame, in decode order: [((x, y, w, h), score_q15)].
    thr_q: int8 heatmap threshold (None: the header's). flip: cfg.cnn_flip, the mirrored pass's boxes
    (mirrored back) after the first pass's."""
    fh, fw = img.shape
    if fw < 2 or fh < 2:
        return []   # no half-resolution pixel: the detector runs nothing
    align = V.alignment(desc)
    planes = [cnn_eval.net_input(img, align)]
    if flip:   # the half-resolution plane mirrored, then padded (not the frame: odd widths)
        planes.append(CD.pad_to(np.ascontiguousarray(CD.half(img)[:, ::-1]), align))
    out = []
    for k, x in enumerate(planes):
        dec = R.decode(desc, R.run(desc, x), 2 * x.shape[1], 2 * x.shape[0], thr_q=thr_q)
        out += cnn_eval.clip_boxes(dec, fw, fh, flip_hw=fw // 2 if k else None)
    return out


def detect(desc, img, score_thr_q15=0, nms_iou_q15=16384, max_candidates=None, max_detections=None, flip=False):
    """Detections of vd_detector_run with sources = cnn, no rescoring, temporal analysis off:
    [((x, y, w, h), score_q8)], best first. score_thr_q15: cfg.cnn_score_thr_q15 (0 = the header's
    threshold); max_candidates / max_detections: the detector's budgets (None = unlimited); flip:
    cfg.cnn_flip."""
    thr = None
    if score_thr_q15:
        thr = thr_from_score(desc, score_thr_q15)
        if thr is None:
            return []
    cands = [(b, score_q8(s)) for b, s in boxes(desc, img, thr, flip)]
    if max_candidates is not None:
        cands = cands[:max_candidates]
    return nms_q15(cands, nms_iou_q15, max_detections)
