# SPDX-License-Identifier: MIT
"""vdtools.metrics.tracking (issue 38): MOTA, IDF1 and ID switches on a tiny hand-made case worked out by hand,
the ground-truth identities across camera motion, and the sums checked against py-motmetrics' own MOTA and
IDF1 (its overall row over several sequences). No data needed."""
import numpy as np
import pytest

from vdtools.metrics import tracking as T

mm = pytest.importorskip("motmetrics", reason="py-motmetrics not installed (tools/setup.sh installs it)")

A, B = (0, 0, 10, 10), (50, 0, 10, 10)          # two vehicles, the camera still
FP = (200, 200, 10, 10)                          # a box on no vehicle
IGN = (300, 300, 20, 20)                         # an ignore region (DontCare / person)


def det(box, track):
    return {"box": list(box), "track": track}


# 3 frames, 6 vehicle boxes (A and B in each). Tracks: A is track 7 throughout; B is track 8, then 9 (one ID
# switch), then missed; frame 2 has a false positive; frame 3 a box on the ignore region (dropped).
SEQ = [
    ([A, B], [], [det(A, 7), det(B, 8)]),
    ([A, B], [], [det(A, 7), det(B, 9), det(FP, 10)]),
    ([A, B], [IGN], [det(A, 7), det(IGN, 11)]),
]


def test_hand_worked_counts():
    c = T.sequence_counts(SEQ)
    # misses: B in frame 3; FP: frame 2's; switches: B 8 -> 9.
    # IDF1: one identity per GT: A <-> 7 (3 frames), B <-> 8 or 9 (1 frame): IDTP 4 of 6 GT and 6 hypotheses.
    assert c == dict(num_objects=6, num_misses=1, num_false_positives=1, num_switches=1, idtp=4, idfp=2, idfn=2)
    s = T.scores(c)
    assert s["mota"] == pytest.approx(1 - (1 + 1 + 1) / 6)        # 0.5
    assert s["idf1"] == pytest.approx(2 * 4 / (2 * 4 + 2 + 2))    # 2/3
    assert s["id_switches"] == 1


def test_no_tracks_each_box_its_own_identity():
    # Temporal off: no "track", so every box is a new identity: A switches in frames 2 and 3, B in frame 2.
    off = [(v, i, [{"box": d["box"]} for d in ds]) for v, i, ds in SEQ]
    c = T.sequence_counts(off)
    assert (c["num_misses"], c["num_false_positives"], c["num_switches"]) == (1, 1, 3)
    assert (c["idtp"], c["idfp"], c["idfn"]) == (2, 4, 4)
    s = T.scores(c)
    assert s["mota"] == pytest.approx(1 / 6) and s["idf1"] == pytest.approx(1 / 3)


def test_keep_selects_hypotheses():
    # keep only tracks 7: B is missed in all 3 frames, no FP, no switch.
    c = T.sequence_counts(SEQ, keep=lambda d: d["track"] == 7)
    assert (c["num_misses"], c["num_false_positives"], c["num_switches"], c["idtp"]) == (3, 0, 0, 3)
    assert T.scores(c)["mota"] == pytest.approx(0.5)


def test_iou_below_half_is_no_match():
    # A box shifted by 4 px of 10 (IoU 6*10 / (200 - 60) = 0.43) is a miss plus a false positive.
    c = T.sequence_counts([([A], [], [det((4, 0, 10, 10), 1)])])
    assert (c["num_objects"], c["num_misses"], c["num_false_positives"]) == (1, 1, 1)


def test_gt_identities_follow_camera_motion():
    dx, dy = 30, 5
    moved = [(x + dx, y + dy, w, h) for x, y, w, h in (A, B)]
    assert T.camera_shift([A, B], moved) == (dx, dy)
    # Linked across the shift; a vehicle appearing later gets a new id; one that left frees nothing.
    assert T.gt_tracks([[A, B], moved, [moved[1], (400, 400, 12, 12)]]) == [[1, 2], [1, 2], [2, 3]]
    # Without the shift, A moved by 30 px (IoU 0) would have been a new identity.
    assert T.gt_tracks([[A], [(30, 0, 10, 10)]]) == [[1], [1]]   # one box: its own displacement is the shift


def _dist(veh, hyp):
    """1 - IoU, NaN below IoU 0.5 (mm.distances.iou_matrix's rule; it calls np.asfarray, gone in NumPy 2)."""
    d = np.full((len(veh), len(hyp)), np.nan)
    for i, (ax, ay, aw, ah) in enumerate(veh):
        for j, (bx, by, bw, bh) in enumerate(hyp):
            iw = max(0, min(ax + aw, bx + bw) - max(ax, bx))
            ih = max(0, min(ay + ah, by + bh) - max(ay, by))
            o = iw * ih / (aw * ah + bw * bh - iw * ih)
            if o >= 0.5:
                d[i, j] = 1 - o
    return d


def _acc(seq):
    """py-motmetrics' accumulator for a sequence, built directly (identities as in the hand case)."""
    acc = mm.MOTAccumulator(auto_id=True)
    for (veh, _ign, dets), g in zip(seq, T.gt_tracks([f[0] for f in seq])):
        hyp = [d for d in dets if tuple(d["box"]) != IGN]
        acc.update(g, [d["track"] for d in hyp], _dist(veh, [d["box"] for d in hyp]))
    return acc


def test_sums_agree_with_motmetrics_overall():
    # A second sequence: one vehicle, tracked then switched; together with SEQ, motmetrics' overall MOTA and
    # IDF1 (its own definitions) equal tracking.scores of the summed counts.
    seq2 = [([A], [], [det(A, 1)]), ([A], [], [det(A, 2)]), ([A], [], [det(A, 2), det(FP, 3)])]
    total = T.add_counts(T.sequence_counts(SEQ), T.sequence_counts(seq2))
    mh = mm.metrics.create()
    summ = mh.compute_many([_acc(SEQ), _acc(seq2)], names=["a", "b"], metrics=["mota", "idf1", "num_switches"],
                           generate_overall=True)
    ov = summ.loc["OVERALL"]
    s = T.scores(total)
    assert s["mota"] == pytest.approx(float(ov["mota"]))
    assert s["idf1"] == pytest.approx(float(ov["idf1"]))
    assert s["id_switches"] == int(ov["num_switches"]) == 2
    # by hand: 9 objects, 1 miss, 2 FP, 2 switches; IDTP 4 + 2 (A <-> 2 in frames 2, 3)
    assert s["mota"] == pytest.approx(1 - 5 / 9)
    assert s["idf1"] == pytest.approx(2 * 6 / (2 * 6 + 4 + 3))
