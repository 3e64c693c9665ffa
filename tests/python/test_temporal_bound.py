# SPDX-License-Identifier: MIT
"""vdtools.evaluation.temporal_bound (issue 38): the ceilings of what temporal analysis can add, on a hand-made
three-frame sequence worked out by hand. No data, no library needed."""
from types import SimpleNamespace

import pytest

from vdtools.evaluation import temporal_bound as TB


def frame(name, vehicles):
    return SimpleNamespace(name=name, vehicles=vehicles, ignore=[])


def det(box, score):
    return {"box": list(box), "score": score}


def shifted(b, dx):
    return (b[0] + dx, b[1], b[2], b[3])


A, B, FP = (10, 10, 20, 20), (100, 10, 20, 20), (200, 200, 20, 20)
# The camera pans 5 px a frame. Frame 0: A (0.9) and B (0.8) found, a false positive (0.7). Frame 1: A found
# (0.6), B missed but a box under the threshold lies on it. Frame 2: nothing found.
FRAMES = [frame("f0", [A, B]), frame("f1", [shifted(A, 5), shifted(B, 5)]),
          frame("f2", [shifted(A, 10), shifted(B, 10)])]
OFF = {"f0": [det(A, 0.9), det(B, 0.8), det(FP, 0.7)], "f1": [det(shifted(A, 5), 0.6)], "f2": []}
LOW = {"f0": OFF["f0"], "f1": OFF["f1"] + [det(shifted(B, 6), 0.1)], "f2": []}


def test_hand_worked_ceilings():
    n = TB.bounds([(FRAMES, OFF)], LOW)
    # 6 vehicles, 3 found; misses: B in f1 (found in f0, the previous frame; a weak box on it), A in f2 (found
    # in f1, the previous frame), B in f2 (found in f0 only: earlier, not previous).
    assert (n["vehicles"], n["tp"], n["missed"]) == (6, 3, 3)
    assert (n["missed_seen_prev"], n["missed_seen_before"]) == (2, 3)
    assert (n["missed_weak_box"], n["missed_weak_box_seen_before"]) == (1, 1)
    # AP: by score TP, TP, FP, TP over 6 vehicles: precision 1 up to recall 2/6, then 3/4 at 3/6.
    assert n["ap_off"] == pytest.approx((1 + 1 + 0.75) / 6)
    assert n["ceiling_rescore"] == pytest.approx(3 / 6)          # every TP first: AP = the TP rate
    assert n["ceiling_recover_prev"] == pytest.approx(5 / 6)
    assert n["ceiling_recover_before"] == pytest.approx(6 / 6)
    assert n["ceiling_weak_boxes_of_seen"] == pytest.approx(4 / 6)
    assert n["ceiling_weak_boxes"] == pytest.approx(4 / 6)
    assert "on - off <= +4.2" in TB.report("t", n)


def test_hand_worked_realisable():
    n = TB.realisable([(FRAMES, OFF)], LOW, 0.3076)
    # The camera shift (5, 0) from f0's detections to f1's (ties: the smallest). Coasted: B and the false
    # positive into f1 (B lands on the missed B), f1's A into f2 (IoU 0.6 with A there; f2 has no detection,
    # so no shift): 3 boxes, 2 on vehicles. Weak: f1's box on B (0.1) continues f0's B: 1 box, a vehicle.
    assert (n["coasted"], n["coasted_tp"]) == (3, 2)
    assert (n["weak_continuing"], n["weak_continuing_tp"]) == (1, 1)
    assert n["ap_off"] == pytest.approx((1 + 1 + 0.75) / 6)
    # coasted boxes rank last: T T F T | T F T -> precision envelope 1, 1, 0.8, 0.8, 5/7 at recall 1/6 .. 5/6
    assert n["ap_coast"] == pytest.approx((1 + 1 + 0.8 + 0.8 + 5 / 7) / 6)
    # the weak box at 0.1: T T F T T -> 1, 1, 0.8, 0.8
    assert n["ap_weak"] == pytest.approx((1 + 1 + 0.8 + 0.8) / 6)
    # both: the weak box takes B in f1 first, so the box coasted onto B there is a false positive:
    # T T F T T | F F T -> 1, 1, 0.8, 0.8, 5/8
    assert n["ap_both"] == pytest.approx((1 + 1 + 0.8 + 0.8 + 5 / 8) / 6)


def test_track_features_hand_worked():
    tracked = {"f0": [dict(det(A, 0.9), track=1), dict(det(B, 0.8), track=2), dict(det(FP, 0.7), track=3)],
               "f1": [dict(det(shifted(A, 5), 0.6), track=1)], "f2": []}
    x, y, nv = TB.track_features([(FRAMES, tracked)])
    assert nv == 6 and y == [1, 1, 0, 1]
    assert x[0] == [0.9, 0, 0.0, 0.0, 0.0, 0.0, 3]                 # a first sighting
    assert x[3] == [0.6, 1, 0.9, 0.9, 1.0, 0.9, 1]                 # track 1 again, seen in the frame before
    m = TB.learned_rescoring((x, y, nv), (x, y, nv))
    assert m["ap_own"] == pytest.approx((1 + 1 + 0.75) / 6)
    assert 0.0 <= m["ap_logistic"] <= 0.5 and 0.0 <= m["ap_trees"] <= 0.5   # never above the TP rate 3 / 6


def test_without_weak_run():
    n = TB.bounds([(FRAMES, OFF)], None)
    assert "ceiling_weak_boxes" not in n and n["missed_weak_box"] == 0
    assert "under the threshold" not in TB.report("t", n)
