# SPDX-License-Identifier: MIT
"""How much AP@0.5 can temporal analysis add on a set of sequences? Ceilings from the detector's own output
(issue 38, docs/results/temporal.md "What temporal analysis can add here").

AP@0.5 pools every output box of every frame by score. Temporal analysis can change a box's score (the
track-aware scores), add boxes (a track's predicted box while it is lost, a weak detection kept because it
continues a track) and remove boxes. So, per run of the demo with `--temporal off`:

- **re-scoring ceiling** = TP rate: no order of the same boxes can do better than all true positives first,
  whose all-point interpolated AP is exactly the share of vehicles they find. AP on - off from re-scoring
  alone is at most TP rate - AP off.
- **recovery ceiling**: add, as perfect boxes ranked first, every vehicle the boxes miss in a frame but
  found in an earlier frame of its sequence (a causal tracker knows nothing else): (TP + those) / vehicles.
  Ground-truth identities come from vdtools.metrics.tracking.gt_tracks (linked across the camera's motion).
- **weak-box ceiling**: the same with the missed vehicles that a box under the threshold localises
  (IoU >= 0.5, from a second run at `--cnn-thr LOW`), and those of them found in an earlier frame too.

Each is an upper bound of what any temporal method can reach with that information. Two realisable
measures beside them, with the camera's motion between frames taken as known (vdtools.metrics.tracking's
camera_shift on the detections of the two frames, the shift most boxes agree on):

- **coasting**: every detection of the previous frame that no detection continues (IoU >= 0.3 after the
  shift) is carried over, shifted, as a box of its own; how many land on a missed vehicle (IoU >= 0.5), and
  the AP with them ranked below every real box;
- **weak boxes that continue**: the boxes under the threshold (the low run) that overlap no output box
  (IoU < 0.5) and continue a detection of the previous frame (IoU >= 0.3 after the shift), added at their own
  scores (ByteTrack's second tier); how many are vehicles, and the AP with them;
- **both** together.

And a learned re-scoring (`--learned`): each box's score replaced by a classifier's probability that it is a
vehicle, from its score and its track's history (`--temporal on --track-scores off`: the track's length so far,
its previous frame's score, its best and mean earlier score, whether it was seen in the previous frame, the
frame's box count), logistic regression and gradient-boosted trees (scikit-learn) fit on the train sequences'
boxes and applied to the chosen split's: how much of the re-scoring ceiling a track's history can earn.

    python3 -m vdtools.evaluation.temporal_bound --sequences val [--low 0.05] [--learned] [--out FILE]
    python3 -m vdtools.evaluation.temporal_bound --figure PNG REC.json [REC.json ...]   # records -> a picture
"""
import argparse
import json
from pathlib import Path

from vdtools.bindings import clib
from vdtools.evaluation import temporal_eval as TE
from vdtools.metrics.evaluate import ap_from_flags, iou, match_flags
from vdtools.metrics.tracking import camera_shift, gt_tracks


def _boxes(recs, name):
    return [(tuple(d["box"]), d["score"]) for d in recs[name]]


def bounds(sequences, low_recs=None):
    """sequences: [(frames, {frame name: detections})] of a --temporal off run (each frame: .name, .vehicles,
    .ignore); low_recs: the same frames' detections of a run at a low score threshold, or None. Returns the
    counts and the ceilings (fractions)."""
    n = dict(vehicles=0, tp=0, missed=0, missed_seen_before=0, missed_seen_prev=0, missed_weak_box=0,
             missed_weak_box_seen_before=0)
    flags_all = []
    for frames, recs in sequences:
        ids = gt_tracks([[tuple(b) for b in fr.vehicles] for fr in frames])
        found_ids = set()
        prev_found = set()
        for k, fr in enumerate(frames):
            flags, matched = match_flags(_boxes(recs, fr.name), TE.gts_of(fr))
            flags_all += [(s, f) for s, f in flags if f is not None]
            nv = len(fr.vehicles)
            matched = set(m for m in matched if m < nv)
            n["vehicles"] += nv
            n["tp"] += len(matched)
            weak = []
            if low_recs is not None:
                weak = [tuple(d["box"]) for d in low_recs[fr.name]]
            cur_found = set()
            for i in range(nv):
                gid = ids[k][i]
                if i in matched:
                    cur_found.add(gid)
                    continue
                n["missed"] += 1
                before = gid in found_ids
                n["missed_seen_before"] += before
                n["missed_seen_prev"] += gid in prev_found
                box = tuple(fr.vehicles[i])
                if any(iou(w, box) >= 0.5 for w in weak):
                    n["missed_weak_box"] += 1
                    n["missed_weak_box_seen_before"] += before
            found_ids |= cur_found
            prev_found = cur_found
    v = max(n["vehicles"], 1)
    n["ap_off"] = ap_from_flags(flags_all, n["vehicles"])[0]
    n["tp_rate"] = n["tp"] / v
    n["ceiling_rescore"] = n["tp_rate"]
    n["ceiling_recover_prev"] = (n["tp"] + n["missed_seen_prev"]) / v
    n["ceiling_recover_before"] = (n["tp"] + n["missed_seen_before"]) / v
    if low_recs is not None:
        n["ceiling_weak_boxes_of_seen"] = (n["tp"] + n["missed_weak_box_seen_before"]) / v
        n["ceiling_weak_boxes"] = (n["tp"] + n["missed_weak_box"]) / v
    return n


def _continues(box, prev, dx, dy):
    return any(iou((p[0] + dx, p[1] + dy, p[2], p[3]), box) >= 0.3 for p in prev)


def realisable(sequences, low_recs, thr):
    """The coasting and weak-box measures of the module's docstring: sequences and low_recs as bounds() (low_recs
    required), thr the run's score threshold (boxes of the low run below it are the weak ones)."""
    n = dict(vehicles=0, coasted=0, coasted_tp=0, weak_continuing=0, weak_continuing_tp=0)
    flags = {"off": [], "coast": [], "weak": [], "both": []}
    for frames, recs in sequences:
        prev = []
        for fr in frames:
            gts = TE.gts_of(fr)
            n["vehicles"] += len(fr.vehicles)
            dets = _boxes(recs, fr.name)
            cur = [d[0] for d in dets]
            dx, dy = camera_shift(prev, cur) if prev and cur else (0.0, 0.0)
            coast = [((p[0] + dx, p[1] + dy, p[2], p[3]), -1.0) for p in prev if not _continues(p, cur, -dx, -dy)]
            weak = [(b, s) for b, s in _boxes(low_recs, fr.name)
                    if s < thr and all(iou(b, c) < 0.5 for c in cur) and _continues(b, prev, dx, dy)]
            # the added boxes rank after the frame's own (coasted: -1, weak: under thr), so each match below
            # pairs the own boxes as the "off" one does and counts the added ones' matches on top
            found = {}
            for key, extra in (("off", []), ("coast", coast), ("weak", weak), ("both", weak + coast)):
                fl, matched = match_flags(dets + extra, gts)
                flags[key] += [(s, f) for s, f in fl if f is not None]
                found[key] = len(matched)
            n["coasted"] += len(coast)
            n["coasted_tp"] += found["coast"] - found["off"]
            n["weak_continuing"] += len(weak)
            n["weak_continuing_tp"] += found["weak"] - found["off"]
            prev = cur
    for key, fl in flags.items():
        n[f"ap_{key}"] = ap_from_flags(fl, n["vehicles"])[0]
    return n


FEATURES = ("score", "track length so far", "previous frame's score", "best earlier score",
            "seen in the previous frame", "mean earlier score", "boxes in the frame")


def track_features(sequences):
    """[(frames, recs)] of a --temporal on run (detections with "track") -> (X, y, vehicles): one row of
    FEATURES per box that is not ignored, y 1 for a true positive (match_flags), 0 else."""
    X, y, nv = [], [], 0
    for frames, recs in sequences:
        hist = {}
        for k, fr in enumerate(frames):
            dets = recs[fr.name]
            nv += len(fr.vehicles)
            order = sorted(range(len(dets)), key=lambda i: (-dets[i]["score"], i))   # match_flags' order
            flags, _ = match_flags([(tuple(d["box"]), d["score"]) for d in dets], TE.gts_of(fr))
            flag = {order[j]: flags[j][1] for j in range(len(order))}
            for i, d in enumerate(dets):
                h = hist.get(d["track"], [])
                prev = h[-1][1] if h and h[-1][0] == k - 1 else None
                earlier = [e[1] for e in h]
                if flag[i] is not None:
                    X.append([d["score"], len(h), prev or 0.0, max(earlier, default=0.0),
                              0.0 if prev is None else 1.0, sum(earlier) / len(earlier) if earlier else 0.0,
                              len(dets)])
                    y.append(flag[i])
            for d in dets:
                hist.setdefault(d["track"], []).append((k, d["score"]))
    return X, y, nv


def learned_rescoring(train, evaluate):
    """AP@0.5 of evaluate's boxes (track_features of each) by their own score and by the probability of a
    logistic regression and of gradient-boosted trees fit on train's boxes."""
    import numpy as np
    from sklearn.ensemble import HistGradientBoostingClassifier
    from sklearn.linear_model import LogisticRegression
    (xt, yt, _), (xv, yv, nv) = train, evaluate
    xt, xv = np.asarray(xt, float), np.asarray(xv, float)
    out = dict(ap_own=ap_from_flags(list(zip(xv[:, 0], yv)), nv)[0])
    for name, model in (("logistic", LogisticRegression(max_iter=2000)),
                        ("trees", HistGradientBoostingClassifier(max_iter=200, max_depth=3, random_state=0))):
        p = model.fit(xt, yt).predict_proba(xv)[:, 1]
        out[f"ap_{name}"] = ap_from_flags(list(zip(p, yv)), nv)[0]
    return out


def _pts(x):
    return f"{100 * x:.1f}"


def report(split, n):
    on = f" (on: {_pts(n['ap_on'])}, {100 * (n['ap_on'] - n['ap_off']):+.1f})" if "ap_on" in n else ""
    lines = [f"{split}: {n['vehicles']} vehicles; temporal off AP@0.5 {_pts(n['ap_off'])}{on}, TP {_pts(n['tp_rate'])} % "
             f"({n['tp']}); missed {n['missed']}, of which found in the previous frame {n['missed_seen_prev']}, "
             f"in any earlier frame {n['missed_seen_before']}"]
    lines.append(f"  ceiling, re-scoring the same boxes: {_pts(n['ceiling_rescore'])} "
                 f"(on - off <= {100 * (n['ceiling_rescore'] - n['ap_off']):+.1f})")
    lines.append(f"  ceiling, + every miss found in the previous frame: {_pts(n['ceiling_recover_prev'])} "
                 f"({100 * (n['ceiling_recover_prev'] - n['ap_off']):+.1f}); in any earlier frame: "
                 f"{_pts(n['ceiling_recover_before'])} ({100 * (n['ceiling_recover_before'] - n['ap_off']):+.1f})")
    if "ceiling_weak_boxes" in n:
        lines.append(f"  misses localised by a box under the threshold: {n['missed_weak_box']} "
                     f"({n['missed_weak_box_seen_before']} found in an earlier frame); ceiling with those found "
                     f"before: {_pts(n['ceiling_weak_boxes_of_seen'])} "
                     f"({100 * (n['ceiling_weak_boxes_of_seen'] - n['ap_off']):+.1f}), with all: "
                     f"{_pts(n['ceiling_weak_boxes'])} ({100 * (n['ceiling_weak_boxes'] - n['ap_off']):+.1f})")
    if "coasted" in n:
        lines.append(f"  coasting every unmatched detection of the previous frame: {n['coasted']} boxes, "
                     f"{n['coasted_tp']} on a missed vehicle; AP {_pts(n['ap_coast'])} "
                     f"({100 * (n['ap_coast'] - n['ap_off']):+.1f})")
        lines.append(f"  weak boxes continuing a detection of the previous frame: {n['weak_continuing']}, "
                     f"{n['weak_continuing_tp']} vehicles; AP {_pts(n['ap_weak'])} "
                     f"({100 * (n['ap_weak'] - n['ap_off']):+.1f})")
        lines.append(f"  both: AP {_pts(n['ap_both'])} ({100 * (n['ap_both'] - n['ap_off']):+.1f})")
    if "learned" in n:
        m = n["learned"]
        lines.append(f"  learned re-scoring (fit on train, track history features): own score {_pts(m['ap_own'])}, "
                     f"logistic {_pts(m['ap_logistic'])} ({100 * (m['ap_logistic'] - m['ap_own']):+.1f}), "
                     f"trees {_pts(m['ap_trees'])} ({100 * (m['ap_trees'] - m['ap_own']):+.1f})")
    return "\n".join(lines)


def figure(records, path):
    """One group of bars per record: what temporal analysis adds over --temporal off (AP points), measured and
    ceilings, and the issue's +3."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    bars = [("shipped track scores", None), ("learnt re-scoring", "learned"), ("weak boxes + coasting", "ap_both"),
            ("re-scoring ceiling", "ceiling_rescore"), ("+ misses found in the previous frame", "ceiling_recover_prev")]
    fig, ax = plt.subplots(figsize=(7.5, 3.6), dpi=100)
    width = 0.8 / len(bars)
    for j, (label, key) in enumerate(bars):
        xs, ys = [], []
        for i, (name, n) in enumerate(records):
            if key is None:   # temporal on, the shipped scores
                v = 100 * (n["ap_on"] - n["ap_off"]) if "ap_on" in n else None
            elif key == "learned":
                m = n.get("learned")
                v = None if m is None else 100 * (max(m["ap_logistic"], m["ap_trees"]) - m["ap_own"])
            else:
                v = 100 * (n[key] - n["ap_off"]) if key in n else None
            if v is not None:
                xs.append(i + (j - (len(bars) - 1) / 2) * width)
                ys.append(v)
        ax.bar(xs, ys, width, label=label)
    ax.axhline(3.0, color="k", linestyle="--", linewidth=1, label="issue 38's bar: +3")
    ax.set_xticks(range(len(records)))
    ax.set_xticklabels([name for name, _ in records])
    ax.set_ylabel("AP@0.5 over temporal off (points)")
    ax.grid(axis="y", alpha=0.3)
    ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--demo", default=str(clib.REPO / "build" / "tools" / "vd_fir_demo"))
    ap.add_argument("--data", default=str(clib.DATA_DIR))
    ap.add_argument("--sequences", default="val", choices=("0_100", "train", "val", "test"))
    ap.add_argument("--low", type=float, default=0.05,
                    help="score threshold of the weak-box run (--cnn-thr; 0 leaves that run out)")
    ap.add_argument("--thr", type=float, default=0.3076,
                    help="the run's score threshold (the demo's default: the pair's header threshold)")
    ap.add_argument("--extra", default="", help="more demo flags for both runs")
    ap.add_argument("--learned", action="store_true",
                    help="also the learned re-scoring: runs the train sequences and this split with --temporal on "
                         "--track-scores off (train: ~2 min)")
    ap.add_argument("--tmp", default="out/temporal_bound")
    ap.add_argument("--out", help="JSON record")
    ap.add_argument("--figure", help="draw the records given as arguments into this PNG, run nothing")
    ap.add_argument("records", nargs="*", help="with --figure: JSON records of this tool")
    a = ap.parse_args(argv)
    if a.figure:
        recs = []
        for r in a.records:
            n = json.loads(Path(r).read_text())
            recs.append((n["split"], n))
        figure(recs, a.figure)
        return
    seqs = TE.load_sequences(a.data, a.sequences)
    if not seqs:
        raise SystemExit(f"no sequences for {a.sequences} in {a.data}")
    tmp = Path(a.tmp)
    tmp.mkdir(parents=True, exist_ok=True)
    extra = a.extra.split()
    runs, low = [], {} if a.low > 0 else None
    for sid, frames in seqs:
        recs, _ = TE._run_demo(a.demo, frames, tmp / f"{sid}_off.jsonl", "off", extra)
        runs.append((frames, recs))
        if low is not None:
            lrecs, _ = TE._run_demo(a.demo, frames, tmp / f"{sid}_low.jsonl", "off",
                                    extra + ["--cnn-thr", str(a.low)])
            low.update(lrecs)
    n = bounds(runs, low)
    n["ap_on"] = TE.run(a.demo, "on", seqs, extra, tmp=str(tmp))["ap50"]   # the demo's defaults: temporal on
    if low is not None:
        thr = a.thr
        r = realisable(runs, low, thr)
        n.update({k: v for k, v in r.items() if k not in ("vehicles", "ap_off")})
    if a.learned:
        def tracked(split):
            done = []
            for sid, frames in TE.load_sequences(a.data, split):
                recs, _ = TE._run_demo(a.demo, frames, tmp / f"{sid}_tracks.jsonl", "on",
                                       extra + ["--track-scores", "off"])
                done.append((frames, recs))
            return track_features(done)
        n["learned"] = learned_rescoring(tracked("train"), tracked(a.sequences))
    print(report(a.sequences, n))
    if a.out:
        Path(a.out).write_text(json.dumps(dict(split=a.sequences, low=a.low, extra=a.extra, **n), indent=1) + "\n")


if __name__ == "__main__":
    main()
