# SPDX-License-Identifier: MIT
"""Other rules for fusing the four passes of the default pair (two networks, each with its mirrored pass), an
experiment (docs/results/detector.md, "The fusion rule"): the library fuses each network's two passes and then
the two networks with one rule (lib/src/detector/detector_cnn.c fuse_boxes: greedy match at IoU >= 0.3,
corners and scores averaged, an unmatched box at half its score). Here the same boxes — each pass decoded at
every peak through the C library, clipped as the detector clips them — go through other rules in float, then
overlap suppression at 0.5 and AP@0.5 per family, with a paired scene-group bootstrap against the library's
rule (vdtools.evaluation.cnn_compare).

Rules: `hier(...)` is the library's two-level scheme with its knobs (match IoU, score-weighted corners, the
first network's weight in the pair, the factor of an unmatched box); `wbf(...)` clusters the boxes of all
four passes at once (weighted boxes fusion: a cluster's box is the score-weighted mean of its members, its
score the mean over the four passes, a missing pass counting 0).

    python3 -m vdtools.evaluation.fusion_rules --split val
"""
import argparse

from vdtools.bindings import clib
from vdtools.data import cnn_data as CD
from vdtools.evaluation import cnn_compare as C
from vdtools.evaluation import cnn_eval as E
from vdtools.metrics.evaluate import iou

THR = 0.3076   # the pair's header threshold, for the TP / FP columns


def fuse(a, b, thr=0.3, wcorner=False, wa=0.5, unmatched=None):
    """Two box sets [((x, y, w, h), score)] fused in float: for each a box in order, the unused b box of the
    largest IoU >= thr is its match; corners averaged (score-weighted with wcorner), score wa sa + (1 - wa) sb;
    an unmatched a box scores wa sa (unmatched * sa if given), an unmatched b box (1 - wa) sb (unmatched * sb).
    With the defaults this is fuse_boxes' rule without its integer rounding."""
    used = [False] * len(b)
    out = []
    for box, sa in a:
        best, best_iou = None, -1.0
        for j, (other, _) in enumerate(b):
            if not used[j]:
                q = iou(box, other)
                if q >= thr and q > best_iou:
                    best, best_iou = j, q
        if best is None:
            out.append((box, wa * sa if unmatched is None else unmatched * sa))
            continue
        used[best] = True
        other, sb = b[best]
        fa = sa / (sa + sb) if wcorner and sa + sb > 0 else 0.5
        fb = 1.0 - fa
        x0, y0 = fa * box[0] + fb * other[0], fa * box[1] + fb * other[1]
        x1 = fa * (box[0] + box[2]) + fb * (other[0] + other[2])
        y1 = fa * (box[1] + box[3]) + fb * (other[1] + other[3])
        out.append(((x0, y0, x1 - x0, y1 - y0), wa * sa + (1 - wa) * sb))
    out += [(o, (1 - wa) * sb if unmatched is None else unmatched * sb) for j, (o, sb) in enumerate(b) if not used[j]]
    return out


def wbf(sets, thr=0.55, wcorner=True):
    """Weighted boxes fusion over all sets at once: boxes by score descending join the cluster of largest IoU
    >= thr with their fused box that holds no box of their set yet, else start one; score = the sum of the
    members' scores / the number of sets."""
    boxes = sorted(((bx, s, k) for k, st in enumerate(sets) for bx, s in st), key=lambda t: -t[1])
    clusters = []   # [fused box, members, sets present]
    for bx, s, k in boxes:
        best, best_iou = None, -1.0
        for ci, (fb, _, ks) in enumerate(clusters):
            if k not in ks:
                q = iou(bx, fb)
                if q >= thr and q > best_iou:
                    best, best_iou = ci, q
        if best is None:
            clusters.append([bx, [(bx, s)], {k}])
            continue
        c = clusters[best]
        c[1].append((bx, s))
        c[2].add(k)
        ws = [m[1] if wcorner else 1.0 for m in c[1]]
        tot = sum(ws) or 1.0
        x0 = sum(w * m[0][0] for w, m in zip(ws, c[1])) / tot
        y0 = sum(w * m[0][1] for w, m in zip(ws, c[1])) / tot
        x1 = sum(w * (m[0][0] + m[0][2]) for w, m in zip(ws, c[1])) / tot
        y1 = sum(w * (m[0][1] + m[0][3]) for w, m in zip(ws, c[1])) / tot
        c[0] = (x0, y0, x1 - x0, y1 - y0)
    return [(fb, sum(m[1] for m in mem) / len(sets)) for fb, mem, _ in clusters]


def _float(boxes):
    return [(tuple(float(v) for v in bx), s / 32768.0) for bx, s in boxes]


def library(passes):
    """The detector's rule, integer for integer (cnn_eval.fuse_flip), at every peak."""
    n1 = E.fuse_flip(passes[0][0], passes[0][1], 0)
    n2 = E.fuse_flip(passes[1][0], passes[1][1], 0)
    return [(b, s / 32768.0) for b, s in E.fuse_flip(n1, n2, 0)]


def hier(thr=0.3, wcorner=False, wa=0.5, unmatched=None):
    """The library's two levels (each network's passes, then the pair) with other knobs; unmatched: (factor
    within a network, factor in the pair) or None (the scores' own weights)."""
    u = unmatched or (None, None)

    def rule(passes):
        one = [fuse(_float(a), _float(b), thr, wcorner, unmatched=u[0]) for a, b in passes]
        return fuse(one[0], one[1], thr, wcorner, wa, unmatched=u[1])
    return rule


def wbf_rule(thr=0.55, wcorner=True):
    return lambda passes: wbf([_float(s) for a, b in passes for s in (a, b)], thr, wcorner)


RULES = {"library": library, "float": hier()}
RULES.update({f"iou {t}": hier(thr=t) for t in (0.2, 0.4, 0.5, 0.6)})
RULES["score-weighted corners"] = hier(wcorner=True)
RULES.update({f"first network {w}": hier(wa=w) for w in (0.4, 0.6)})
RULES.update({f"unmatched {a}, {b}": hier(unmatched=(a, b)) for a, b in ((0.4, 0.5), (0.6, 0.5), (0.5, 0.4),
                                                                              (0.5, 0.6), (0.4, 0.4))})
RULES.update({f"wbf {t}": wbf_rule(thr=t) for t in (0.4, 0.55, 0.7)})
RULES["wbf 0.55, mean corners"] = wbf_rule(wcorner=False)


def passes_of(frames, first, second):
    """Per frame the clipped boxes of the four passes at every peak: [((net1 a, net1 b), (net2 a, net2 b))]."""
    out = []
    for fr in frames:
        h, w = fr.img.shape
        rec = []
        for n in (first, second):
            k = int(n.desc["max_peaks"])
            a = E.clip_boxes(n._decode(E.net_input(fr.img, n.align), -128, max_peaks=k), w, h)
            b = E.clip_boxes(n._decode(E.net_input(fr.img, n.align, mirror=True), -128, max_peaks=k), w, h,
                             flip_hw=w // 2)
            rec.append((a, b))
        out.append(rec)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--model", default=str(clib.REPO / "models" / "vd_cnn.vdm"))
    ap.add_argument("--model2", default=str(clib.REPO / "models" / "vd_cnn2.vdm"))
    ap.add_argument("--data", default=str(clib.DATA_DIR))
    ap.add_argument("--split", default="val", choices=("train", "val"), help="choose on these, never on test")
    ap.add_argument("--boot", type=int, default=500, help="bootstrap draws of the scene groups")
    a = ap.parse_args(argv)
    frames = CD.load_frames(a.data, splits=(a.split,))
    passes = passes_of(frames, E.Int8(a.model, "c", flip=True), E.Int8(a.model2, "c", flip=True))
    base = None
    for name, rule in RULES.items():
        each = iter(passes)   # cnn_eval.run calls the predictor once per frame, in order
        res = E.run(lambda img, w, h, each=each, rule=rule: rule(next(each)), frames)
        rep = E.figures(res, [THR])
        line = f"{name:24s}" + "".join(f"  {fam} AP {100 * v['ap']:.1f} TP {100 * v['at'][THR]['tp_rate']:.1f} % "
                                       f"FP {100 * v['at'][THR]['fp_rate']:.1f} %" for fam, v in rep.items())
        tables = C.group_tables(res)
        if base is None:
            base = tables
        else:
            for fam in tables:
                r = C.paired_bootstrap(base[fam], tables[fam], n_boot=a.boot)
                line += f"  | {fam} {100 * r['diff']:+.1f} ({100 * r['lo']:+.1f} .. {100 * r['hi']:+.1f})"
        print(line, flush=True)


if __name__ == "__main__":
    main()
