# SPDX-License-Identifier: MIT
"""vd-adapt's figures, measured through the C library as the detector computes them (cnn_eval's Int8 / Pair
with the fused flip passes, suppression, cnn_eval.figures): AP@0.5 and TP / FP at a threshold on the user's
val frames, and, without labels, what can be measured: boxes per frame and agreement."""
import numpy as np

from vdtools.data import cnn_data as CD
from vdtools.evaluation import cnn_eval as CE
from vdtools.formats import cnn_vdm as V
from vdtools.metrics import evaluate as E
from vdtools.metrics.evaluate import one_to_one

AGREE_IOU = 0.5


def predictor(models, flip=True, full_res=False):
    """The detector's CNN source for one .vdm or a pair (the second fused with the first), flip passes on;
    full_res: cfg.cnn_res (the networks read the frame itself, not its half-resolution plane)."""
    first = CE.Int8(models[0], "c", flip=flip, full_res=full_res)
    return first if len(models) == 1 else CE.Pair(first, CE.Int8(models[1], "c", flip=flip, full_res=full_res))


def header_threshold(models):
    """The operating point the detector takes from the files: the (second) network's header threshold."""
    desc = V.unpack(open(models[-1], "rb").read())
    return CE.score_of_logit(desc, desc["score_threshold_q"]) / 32768.0


def detections(models, frames, full_res=False):
    """cnn_eval.run's [(family, frame, boxes after suppression, ground truth)], every peak."""
    return CE.run(predictor(models, full_res=full_res), frames)


AGREE_WEIGHT = 0.25   # tools/demo/common/flipagree.h DEMO_AUTORES_AGREE_WEIGHT
RATING = "rating (mean box score + flip agreement / 4)"


def rating_of(score, agreement, weight=AGREE_WEIGHT):
    """metrics.evaluate.rating_of with this rule's weight."""
    return E.rating_of(score, agreement, weight)


def rating(models, frames, thr, full_res=False):
    """What choose_resolution compares without labels: the rating_of mean_box_score and flip_agreement of the
    same passes (the frames and their mirror images), or None without a box."""
    runs = flip_runs(models, frames, full_res)
    return rating_of(mean_box_score(models, frames, thr, runs=runs), flip_agreement(models, frames, thr, runs=runs))


def choose_resolution(models, frames, thr, labelled=True, resolutions=("half", "full", "quarter")):
    """The networks' input resolution (cfg.cnn_res: half, full or quarter), on frames the networks never saw: the
    one of the highest measure (ties to the earlier of half, full, quarter). With labels the measure is the pooled
    AP@0.5; without, the rating: the mean score of the networks' boxes above thr on the frames and their mirror
    images, plus 1/4 of their agreement with themselves on the mirrored frames (rating), vd_fir_demo's
    --cnn-full-res auto rule. At the wrong resolution the networks still find vehicles or their parts but score
    them lower and agree less. On 260 recordings of the train and val splits (each scene's first 32 frames, as
    they are and under four camera changes: vdtools.adapt.resolution_evidence) the rating chose the resolution
    of the higher AP on 243 and lost 261 AP points in all, where the agreement alone (the rule until 2026-11-30)
    was right on 219 and lost 792; the weight 1/4 did best of 0, 1/16, 1/8, 1/4 and 1/2 on each split; quarter
    resolution joined by the same evidence with frames scaled up (docs/results/cameras.md, "The rule of
    2026-11-30", "Quarter resolution"). A camera whose vehicles are about half (twice) the size of the training
    data's gains a lot from full (quarter) resolution, one whose vehicles are as large loses a lot, so a few dozen
    frames tell them apart.
    (cnn_res, {"measure": name, "half": value, "full": value, ...})."""
    from vdtools.bindings.detector import CNN_RES_NAMES
    from vdtools.metrics.evaluate import first_highest
    res = [r for r in CNN_RES_NAMES if r in resolutions]
    if labelled:
        m = {r: figures(detections(models, frames, full_res=CNN_RES_NAMES.index(r)), thr)["ap"] for r in res}
    else:
        # no box at all at a resolution (None) is no evidence for it
        m = {r: rating(models, frames, thr, full_res=CNN_RES_NAMES.index(r)) or 0.0 for r in res}
    pick = res[first_highest([m[r] for r in res])]
    return CNN_RES_NAMES.index(pick), dict(m, measure="AP@0.5" if labelled else RATING)


def inverted(frames):
    """The frames as the other polarity shows them (255 - v), boxes unchanged."""
    import dataclasses
    out = []
    for fr in frames:
        img = (255 - fr.img).astype(np.uint8)
        out.append(dataclasses.replace(fr, img=img, hot=CD._hot_flags(img, fr.boxes)))
    return out


def choose_polarity(models, frames, thr, labelled=True):
    """White-hot or black-hot (the frames as they are or inverted) for networks that trained on white-hot frames
    only. With labels: the higher pooled AP@0.5, each the better of half and full resolution (ties: as they
    are). Without: vd_fir_demo's --cnn-polarity auto rule (fleet.polarity_choice): the best rating (mean box
    score + agreement / 4) over half, full and quarter resolution of the inverted frames above that of the frames
    as they are by more than the demo's margin; on the train, val and test recordings of ../shared/data it turned
    no white-hot one with vehicles (docs/demo.md, "Black-hot cameras").
    (invert, {"measure": name, "as_is": value, "inverted": value})."""
    from vdtools.evaluation import fleet
    inv = inverted(frames)
    if labelled:
        ap = lambda fs: max(figures(detections(models, fs, full_res=k), thr)["ap"] for k in (0, 1))
        m = dict(as_is=ap(frames), inverted=ap(inv))
        return m["inverted"] > m["as_is"], dict(m, measure="AP@0.5")
    rates = lambda fs: [rating(models, fs, thr, full_res=k) for k in (0, 1, 2)]
    a, b = rates(frames), rates(inv)
    m = dict(as_is=max(v or 0.0 for v in a), inverted=max(v or 0.0 for v in b))
    return fleet.polarity_choice(a, b, len(frames)), dict(m, measure=RATING)


def figures(results, thr):
    """AP@0.5 and the counts at thr of one set of frames (labelled). ap ranks every box; ap_out only the boxes >= thr,
    what the detector outputs at that threshold (vd_fir_demo --config OUT/vd.json --eval gives this one)."""
    rep = CE.figures(results, sorted(set(CE.THRESHOLDS) | {thr}))
    v = next(iter(rep.values()))
    at = v["at"][thr]
    return dict(ap=v["ap"], ap_out=at["ap_out"], n_frames=v["n_frames"], n_vehicles=v["n_vehicles"], thr=thr,
                tp=at["tp"], fp=at["fp"], fn=at["fn"], tp_rate=at["tp_rate"], fp_rate=at["fp_rate"])


BOOT_DRAWS = 400


def _counts(results, thresholds):
    """Per val frame and threshold: (TP, FP) arrays of shape (frames, thresholds) and vehicles per frame."""
    tp = np.zeros((len(results), len(thresholds)))
    fp = np.zeros_like(tp)
    n = np.zeros(len(results))
    for i, (_, fr, dets, gts) in enumerate(results):
        n[i] = len(fr.boxes)
        for j, t in enumerate(thresholds):
            tp[i, j], fp[i, j], _ = CE.counts_at(dets, gts, t)
    return tp, fp, n


def _f1(tp, fp, n):
    """F1 of pooled counts (any leading shape; n broadcasts): 2 TP / (2 TP + FP + FN)."""
    return 2 * tp / np.maximum(tp + fp + n, 1e-9)


def choose_threshold(results, prior, seed=0):
    """The operating point on the user's val frames. cnn_eval's rule (the best F1 among the thresholds with
    TP >= 70 % and FP <= 30 %, else among all) chose 0.40 on a val part of 14 cars
    in docs/results/adapt.md's proxy A: with a few dozen vehicles the best F1 is mostly noise. So the
    one-standard-error rule of model selection (Hastie, Tibshirani, Friedman, ESL 7.10): of the thresholds
    whose pooled F1 is within one bootstrap standard error of the best one's (val frames drawn with
    replacement, BOOT_DRAWS draws, fixed seed), the one closest to `prior`, the shipped header threshold (a
    choice made on far more frames). A val part that clearly favours another point still moves it."""
    thresholds = sorted(set(CE.THRESHOLDS) | {round(prior, 4)})
    tp, fp, n = _counts(results, thresholds)
    f1 = _f1(tp.sum(0), fp.sum(0), n.sum())
    best = int(np.argmax(f1))
    se = 0.0
    if len(results) >= 2:
        w = np.random.default_rng(seed).multinomial(len(results), np.full(len(results), 1 / len(results)),
                                                    BOOT_DRAWS)
        se = float(np.std(_f1(w @ tp[:, best], w @ fp[:, best], w @ n), ddof=1))
    near = [j for j in range(len(thresholds)) if f1[j] >= f1[best] - se]
    return thresholds[min(near, key=lambda j: (abs(thresholds[j] - prior), -f1[j]))]


def boxes_per_frame(results, thr):
    return sum(sum(1 for _, s in dets if s >= thr) for _, _, dets, _ in results) / max(len(results), 1)


def agreement(res_a, thr_a, res_b, thr_b):
    """Share of boxes two result sets of the same frames have in common (F1-like, pooled over frames)."""
    m = n = 0
    for (_, _, da, _), (_, _, db, _) in zip(res_a, res_b):
        r = one_to_one([d[0] for d in da if d[1] >= thr_a], [d[0] for d in db if d[1] >= thr_b], AGREE_IOU)
        if r is not None:
            m, n = m + r[0], n + r[1]
    return 2 * m / n if n else None


def flip_runs(models, frames, full_res=False):
    """The boxes (one pass per network, fused as the pair; every peak) of each frame and of its mirror image,
    mirrored back: the two result lists of cnn_eval.run that flip_agreement and mean_box_score measure."""
    import copy
    pred = predictor(models, flip=False, full_res=full_res)
    mirrored = []
    for fr in frames:
        g = copy.copy(fr)
        g.img = np.ascontiguousarray(fr.img[:, ::-1])
        mirrored.append(g)
    ra, rb = CE.run(pred, frames), CE.run(pred, mirrored)
    w = frames[0].img.shape[1] if frames else 0
    rb = [(f, fr, [((w - b[0] - b[2], b[1], b[2], b[3]), s) for b, s in d], g) for f, fr, d, g in rb]
    return ra, rb


def flip_agreement(models, frames, thr, full_res=False, runs=None):
    """How far the networks agree with themselves: the boxes (one pass per network, fused as the pair) of each
    frame against those of its mirror image, mirrored back; pooled 2 x matched / all at thr. runs: flip_runs'
    result, when it is at hand."""
    ra, rb = runs if runs is not None else flip_runs(models, frames, full_res)
    return agreement(ra, thr, rb, thr)


def score_q8(score):
    """A box score (score_q15 / 32768, cnn_eval) as the detector outputs it: score_q8 = (q15 + 64) >> 7, at most
    255 (lib/src/detector/detector_cnn.c score_q8_of)."""
    return min((int(round(score * 32768)) + 64) >> 7, 255)


def mean_box_score(models, frames, thr, full_res=False, runs=None):
    """The mean score of the boxes >= thr of the frames and their mirror images (one pass per network, as
    flip_agreement), as the detector outputs them (score_q8 / 255); None without a box. What
    vd_fir_demo --cnn-full-res auto compares (tools/demo/common/flipagree.c)."""
    ra, rb = runs if runs is not None else flip_runs(models, frames, full_res)
    q = [score_q8(s) for res in (ra, rb) for _, _, d, _ in res for _, s in d if s >= thr]
    return sum(q) / (255.0 * len(q)) if q else None


def _layers(path):
    d = V.unpack(open(path, "rb").read())
    return [(int(L["op"]), int(L["stride"]), int(L["cin"]), int(L["cout"])) for L in d["layers"]], int(d["max_peaks"])


def rules(before, after, width, height, res=0):
    """What the library's rules depend on, before and after: the layers and top-K of each file (the same
    ones give the same multiply-adds, hence speed, and the same workspace) and the detector workspace at the
    frame size with the demo's budgets (candidates 2 x the largest top-K with the flip pass; detections 32 with
    a pair, else the top-K)."""
    from vdtools.bindings import detector as D

    def workspace(models):
        k = max(_layers(m)[1] for m in models)
        return D.workspace_size(width, height, sources="cnn", cnn_flip=1, cnn_res=int(res),
                                cnn_model=str(models[0]),
                                cnn_model2=str(models[1]) if len(models) > 1 else None, max_candidates=2 * k,
                                max_detections=32 if len(models) > 1 else k)
    import os
    return dict(same_layers_and_top_k=[_layers(b) == _layers(a) for b, a in zip(before, after)],
                workspace_bytes=dict(before=workspace(before), after=workspace(after)),
                file_bytes=dict(before=sum(os.path.getsize(m) for m in before),
                                after=sum(os.path.getsize(m) for m in after)))
