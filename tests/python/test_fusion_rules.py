# SPDX-License-Identifier: MIT
"""vdtools.evaluation.fusion_rules (the fusion-rule experiment of docs/results/detector.md): the float rules on
hand-worked boxes, and the library rule equal to cnn_eval's integer one. No data, no library needed."""
import pytest

from vdtools.evaluation import cnn_eval as E
from vdtools.evaluation import fusion_rules as F

A = ((0.0, 0.0, 10.0, 10.0), 0.8)
B = ((2.0, 0.0, 10.0, 10.0), 0.4)     # IoU with A: 80 / 120 = 0.667
FAR = ((50.0, 50.0, 10.0, 10.0), 0.6)


def test_fuse_defaults_average_and_halve():
    out = F.fuse([A, FAR], [B])
    assert out[0][0] == pytest.approx((1.0, 0.0, 10.0, 10.0)) and out[0][1] == pytest.approx(0.6)
    assert out[1] == (FAR[0], pytest.approx(0.3))                    # unmatched: the other pass voted 0


def test_fuse_knobs():
    # score-weighted corners: x0 = (0.8 * 0 + 0.4 * 2) / 1.2
    out = F.fuse([A], [B], wcorner=True)
    assert out[0][0][0] == pytest.approx(0.8 / 1.2)
    assert F.fuse([A], [B], wa=0.6)[0][1] == pytest.approx(0.6 * 0.8 + 0.4 * 0.4)
    assert F.fuse([A], [B], thr=0.7) == [(A[0], pytest.approx(0.4)), (B[0], pytest.approx(0.2))]
    assert F.fuse([A], [B], thr=0.7, unmatched=0.6)[1][1] == pytest.approx(0.24)


def test_wbf_clusters_across_sets():
    # A and B in one cluster (sets 0 and 1), FAR alone (set 2); 4 sets: scores / 4
    out = F.wbf([[A], [B], [FAR], []], thr=0.5)
    assert out[0][1] == pytest.approx((0.8 + 0.4) / 4) and out[0][0][0] == pytest.approx(0.8 / 1.2)
    assert out[1] == (FAR[0], pytest.approx(0.6 / 4))
    # two boxes of one set never share a cluster
    assert len(F.wbf([[A, B]], thr=0.5)) == 2


def test_library_rule_is_the_integer_one():
    a = [((0, 0, 10, 10), 26214)]
    b = [((2, 0, 10, 10), 13107)]
    passes = ((a, b), (b, []))
    one, two = E.fuse_flip(a, b, 0), E.fuse_flip(b, [], 0)
    assert F.library(passes) == [(bx, s / 32768.0) for bx, s in E.fuse_flip(one, two, 0)]
