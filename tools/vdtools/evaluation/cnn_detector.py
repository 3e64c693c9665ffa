# SPDX-License-Identifier: MIT
"""The C detector's CNN source (lib/src/detector/detector_cnn.c, vd_detector_cfg_t.cnn_*) in Python, integer for
integer: what `vd_fir_demo --sources cnn --temporal off` reports for an 8-bit frame.

Pipeline: vdtools.evaluation.cnn_eval.net_input (half resolution, edge padding to the model's alignment) ->
numpy integer reference (vdtools.formats.cnn_ref, equal to vd_cnn_run) -> decode at the header's top-K into a
2 nw x 2 nh frame -> boxes clipped to the real frame (as cnn_eval.Int8) -> score_q8 -> the detector's
budget (max_candidates) and overlap suppression (vd_suppress_nms) -> max_detections. With flip
(cfg.cnn_flip, `--cnn-flip on`) the fused flip pass: both passes (the plane and its mirror) decode at the
logit of cnn_eval.flip_decode_score(T), T the Q15 score threshold; the mirrored pass's boxes are mirrored
back (cnn_eval.clip_boxes) and the two sets fused (cnn_eval.fuse_flip, which drops fused scores below T)
before the budget.

Differences from cnn_eval.run (kept here so cnn_eval is not changed):
- suppression is the C rule: a stable sort by score_q8 (not the Q15 score: boxes whose scores round to
  the same Q8 keep the decode order, logit descending then raster), and a box goes when its IoU, as
  Q15 rounded down (vd_rect_iou_q15), is > iou_q15 (16384 = 0.5); cnn_eval.nms compares a float IoU
  with > 0.5, which differs for IoU in (0.5, 16385/32768), i.e. unions above 16384 px;
- the decode's top-K is the header's max_peaks (cnn_eval.Int8 passes 100; equal for models with
  max_peaks 100);
- a score threshold is applied as the int8 logit threshold vd_cnn_thr_from_score gives (with flip: that of
  the lower decode score, then T on the fused scores).

    from vdtools.evaluation import cnn_detector as CDet
    dets = CDet.detect(desc, img)   # [((x, y, w, h), score_q8)], best first
"""
from vdtools.evaluation import cnn_eval
from vdtools.formats import cnn_ref as R
from vdtools.formats import cnn_vdm as V

SCORE_ONE_Q15 = cnn_eval.SCORE_ONE_Q15
thr_from_score = cnn_eval.thr_from_score   # vd_cnn_thr_from_score
iou_q15 = cnn_eval.iou_q15                 # vd_rect_iou_q15


def score_q8(score_q15):
    """The detector's Q15 -> Q8 score: rounded half up, 1.0 saturating at 255."""
    return min(255, (int(score_q15) + 64) >> 7)


def nms_q15(dets, iou_thr_q15=16384, max_keep=None):
    """vd_suppress_nms on [(box, score_q8, ...)]: stable sort by score_q8 (best first), then a box is
    dropped when iou_q15 with a kept one is > iou_thr_q15; at most max_keep are kept."""
    keep = []
    for d in sorted(dets, key=lambda d: -d[1]):
        if all(iou_q15(d[0], k[0]) <= iou_thr_q15 for k in keep) and (max_keep is None or len(keep) < max_keep):
            keep.append(d)
    return keep


def score_threshold(desc, score_thr_q15=0):
    """The detector's T, the score threshold in Q15: cfg.cnn_score_thr_q15, or (0) the decoded score of the
    header's logit threshold."""
    return int(score_thr_q15) if score_thr_q15 else cnn_eval.score_of_logit(desc, desc["score_threshold_q"])


def boxes(desc, img, score_thr_q15=0, flip=False, full_res=False):
    """The CNN source's candidates of an 8-bit frame, in order: [((x, y, w, h), score_q15)].
    score_thr_q15: cfg.cnn_score_thr_q15 (0: the header's threshold). flip: cfg.cnn_flip, the fused flip
    pass (A-derived boxes first, then the mirrored pass's leftovers). full_res: cfg.cnn_res (False / 0 half,
    True / 1 full, 2 quarter resolution)."""
    fh, fw = img.shape
    div = cnn_eval.res_div(full_res)
    if fw < div or fh < div:
        return []   # no network input pixel: the detector runs nothing
    thr = int(desc["score_threshold_q"])
    if score_thr_q15:
        thr = thr_from_score(desc, score_thr_q15)
    t = score_threshold(desc, score_thr_q15)
    if flip and thr is not None:
        thr = thr_from_score(desc, cnn_eval.flip_decode_score(t))
    if thr is None:
        return []   # no logit scores that high: the detector never runs the network
    align = V.alignment(desc)

    def decode(x, q):   # the header's top-K, as the detector
        return R.decode(desc, R.run(desc, x), div * x.shape[1], div * x.shape[0], thr_q=q)
    if flip:
        return cnn_eval.fused_flip_pass(decode, img, align, fw, fh, thr, t, div)
    return cnn_eval.clip_boxes(decode(cnn_eval.net_input(img, align, div=div), thr), fw, fh)


def pair_boxes(desc, desc2, img, score_thr_q15=0, flip=False, full_res=False):
    """The CNN source's candidates with cfg.cnn_model2 (desc2), in order: [((x, y, w, h), score_q15)]: both
    networks through the numpy reference at their headers' top-K, fused by cnn_eval.fuse_pair at T (desc2's
    header threshold, the pair's operating point, or score_thr_q15); with score_thr_q15 above both networks'
    top scores nothing runs. full_res: cfg.cnn_res (as boxes)."""
    fh, fw = img.shape
    div = cnn_eval.res_div(full_res)
    if fw < div or fh < div:
        return []
    t = score_threshold(desc2, score_thr_q15)
    if score_thr_q15 and thr_from_score(desc, score_thr_q15) is None and thr_from_score(desc2, score_thr_q15) is None:
        return []

    def net(d):   # the header's top-K, as the detector
        return d, V.alignment(d), lambda x, q: R.decode(d, R.run(d, x), div * x.shape[1], div * x.shape[0], thr_q=q)
    return cnn_eval.fuse_pair([net(desc), net(desc2)], img, fw, fh, t, flip, div=div)


def detect(desc, img, score_thr_q15=0, nms_iou_q15=16384, max_candidates=None, max_detections=None, flip=False,
           desc2=None, full_res=False):
    """Detections of vd_detector_run with sources = cnn, no rescoring, temporal analysis off:
    [((x, y, w, h), score_q8)], best first. score_thr_q15: cfg.cnn_score_thr_q15 (0 = the header's
    threshold); max_candidates / max_detections: the detector's budgets (None = unlimited); flip:
    cfg.cnn_flip; desc2: cfg.cnn_model2 (pair_boxes); full_res: cfg.cnn_res."""
    bx = (boxes(desc, img, score_thr_q15, flip, full_res) if desc2 is None
          else pair_boxes(desc, desc2, img, score_thr_q15, flip, full_res))
    cands = [(b, score_q8(s)) for b, s in bx]
    if max_candidates is not None:
        cands = cands[:max_candidates]
    return nms_q15(cands, nms_iou_q15, max_detections)
