# SPDX-License-Identifier: MIT
"""Can a split tell two detectors apart? A paired bootstrap over scene groups of the AP@0.5 difference.

cnn_eval gives one AP per family and split. Whether a difference between two networks is larger than
what the choice of scenes alone produces depends on how many scene groups the split holds (the val
split has 3 road-level groups): this draws the split's scene groups with replacement (the unit the
splits are made of, vdtools.data.dataset.assign_splits), recomputes both networks' AP on the same draw
and reports the spread of B − A. Both networks run through the same backend on the same frames
(`--backend demo`: the whole C detector, as cnn_eval).

    python3 -m vdtools.evaluation.cnn_compare --a models/vd_cnn.vdm --b models/vd_cnn2.vdm \
        --backend demo --flip --split val [--boot 2000] [--out out/cmp.json]
    python3 -m vdtools.evaluation.cnn_compare --a models/vd_cnn.vdm --b models/vd_cnn.vdm+models/vd_cnn2.vdm \
        --backend demo --flip --split test      # the pair (vd_fir_demo's default) against one network
"""
import argparse
import json
from pathlib import Path

import numpy as np

from vdtools.bindings import clib
from vdtools.data import cnn_data as CD
from vdtools.evaluation import cnn_eval as E
from vdtools.metrics.evaluate import match_flags


def ap_np(scores, tps, n_pos):
    """AP@0.5 of pooled detections as vdtools.metrics.evaluate.ap_from_flags (all-point interpolated,
    ties in the given order), vectorised for the bootstrap: scores, tps (1 TP / 0 FP) arrays."""
    if n_pos == 0:
        return float("nan")
    order = np.argsort(-np.asarray(scores, dtype=np.float64), kind="stable")
    t = np.asarray(tps, dtype=np.float64)[order]
    if t.size == 0:
        return 0.0
    tp = np.cumsum(t)
    rec = tp / n_pos
    prec = tp / np.arange(1, t.size + 1)
    env = np.maximum.accumulate(prec[::-1])[::-1]
    return float(np.sum(np.diff(rec, prepend=0.0) * env))


def group_tables(results):
    """{family: {group: (scores, tps, n_pos)}} of cnn_eval.run / run_demo results (ignored detections out)."""
    out = {}
    for fam, fr, dets, gts in results:
        flags, _ = match_flags(dets, gts)
        s, t, n = out.setdefault(fam, {}).setdefault(fr.group, ([], [], [0]))
        s += [sc for sc, f in flags if f is not None]
        t += [f for _, f in flags if f is not None]
        n[0] += sum(1 for g in gts if g[4])
    return {fam: {g: (np.asarray(s, np.float64), np.asarray(t, np.float64), n[0]) for g, (s, t, n) in v.items()}
            for fam, v in out.items()}


def _pooled_ap(table, groups):
    s = np.concatenate([table[g][0] for g in groups])
    t = np.concatenate([table[g][1] for g in groups])
    return ap_np(s, t, sum(table[g][2] for g in groups))


def paired_bootstrap(ta, tb, n_boot=2000, seed=0):
    """ta, tb: one family's group tables of networks A and B on the same frames. Returns AP of each, the
    difference B − A, its 2.5 / 97.5 percentiles over n_boot draws of the groups with replacement, and
    the share of draws where B is ahead. Draws without a vehicle are drawn again."""
    groups = sorted(ta)
    if sorted(tb) != groups:
        raise ValueError("the two networks were not run on the same scene groups")
    rng = np.random.default_rng(seed)
    diffs = []
    tries = 0
    while len(diffs) < n_boot and tries < 20 * n_boot:     # bounded: a split with no vehicle at all ends here
        tries += 1
        pick = [groups[i] for i in rng.integers(0, len(groups), len(groups))]
        if sum(ta[g][2] for g in pick) == 0:
            continue
        diffs.append(_pooled_ap(tb, pick) - _pooled_ap(ta, pick))
    a, b = _pooled_ap(ta, groups), _pooled_ap(tb, groups)
    d = np.asarray(diffs)
    return dict(ap_a=a, ap_b=b, diff=b - a, lo=float(np.percentile(d, 2.5)) if d.size else float("nan"),
                hi=float(np.percentile(d, 97.5)) if d.size else float("nan"),
                p_b_ahead=float(np.mean(d > 0)) if d.size else float("nan"), n_groups=len(groups),
                n_boot=int(d.size))


def _results(model, a, frames):
    """Detections of one network (.vdm or .pt), or of a pair "FIRST.vdm+SECOND.vdm" (cfg.cnn_model2)."""
    if model.endswith(".pt"):
        return E.run(E.Float(model), frames)
    first, _, second = model.partition("+")
    if a.backend == "demo":
        return E.run_demo(a.demo, first, frames, extra=["--cnn-flip", "on" if a.flip else "off"],
                          model2=second or None)
    pred = E.Int8(first, a.backend, flip=a.flip)
    return E.run(E.Pair(pred, E.Int8(second, a.backend, flip=a.flip)) if second else pred, frames)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--a", required=True, help="network A: .vdm (int8), .pt (float checkpoint), or a pair of "
                    ".vdm files FIRST+SECOND (the detector's cnn_model2)")
    ap.add_argument("--b", required=True, help="network B, the same kinds")
    ap.add_argument("--backend", default="demo", choices=("c", "ref", "demo"), help="for .vdm networks")
    ap.add_argument("--demo", default=str(clib.REPO / "build" / "tools" / "vd_fir_demo"))
    ap.add_argument("--flip", action="store_true", help="the fused flip pass (int8 networks)")
    ap.add_argument("--split", default="val", choices=("val", "test", "train"))
    ap.add_argument("--data", default=str(clib.REPO.parent / "shared" / "data"))
    ap.add_argument("--boot", type=int, default=2000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", help="JSON report")
    a = ap.parse_args(argv)
    frames = CD.load_frames(a.data, splits=(a.split,))
    ta, tb = group_tables(_results(a.a, a, frames)), group_tables(_results(a.b, a, frames))
    rep = {}
    for fam in sorted(ta):
        r = paired_bootstrap(ta[fam], tb[fam], a.boot, a.seed)
        r["n_frames_by_group"] = sorted(sum(1 for f in frames if CD.family(f) == fam and f.group == g)
                                        for g in ta[fam])
        rep[fam] = r
        print(f"{a.split} {fam}: {r['n_groups']} scene groups; AP@0.5 A {100 * r['ap_a']:.1f}, B {100 * r['ap_b']:.1f}, "
              f"B - A {100 * r['diff']:+.1f} (95 % of {r['n_boot']} group draws: {100 * r['lo']:+.1f} .. "
              f"{100 * r['hi']:+.1f}; B ahead in {100 * r['p_b_ahead']:.0f} %)")
    if a.out:
        Path(a.out).write_text(json.dumps(dict(split=a.split, a=a.a, b=a.b, backend=a.backend, flip=a.flip,
                                               boot=a.boot, seed=a.seed, families=rep), indent=1) + "\n")


if __name__ == "__main__":
    main()
