# SPDX-License-Identifier: MIT
"""vdtools.evaluation.cnn_compare: its vectorised AP equals vdtools.metrics.evaluate.ap_from_flags, and the
paired scene-group bootstrap behaves as a paired test should (no data needed)."""
import numpy as np
import pytest

from vdtools.evaluation import cnn_compare as CC
from vdtools.metrics.evaluate import ap_from_flags


def test_ap_np_equals_ap_from_flags():
    rng = np.random.default_rng(5)
    for trial in range(200):
        n = int(rng.integers(0, 40))
        scores = rng.integers(0, 6, n) / 5.0          # many ties: the given order must break them
        tps = rng.integers(0, 2, n)
        n_pos = int(tps.sum() + rng.integers(0, 4))
        want = ap_from_flags(list(zip(scores.tolist(), tps.tolist())), n_pos)[0]
        got = CC.ap_np(scores, tps, n_pos)
        if n_pos == 0:
            assert np.isnan(got) and np.isnan(want)
        else:
            assert got == pytest.approx(want, abs=1e-12), trial
    # hand-worked: TP 0.9, FP 0.8, TP 0.7 over 2 vehicles: precision 1, 1/2, 2/3 -> envelope 1, 2/3, 2/3;
    # recall steps 1/2 at precision 1 and 1/2 at 2/3: AP = 0.5 + 1/3
    assert CC.ap_np([0.9, 0.8, 0.7], [1, 0, 1], 2) == pytest.approx(0.5 + 1 / 3)


def _table(rng, n_groups, p_tp):
    out = {}
    for g in range(n_groups):
        n = int(rng.integers(3, 12))
        out[f"g{g}"] = (rng.random(n), (rng.random(n) < p_tp).astype(float), int(rng.integers(2, 8)))
    return out


def test_paired_bootstrap():
    rng = np.random.default_rng(1)
    a = _table(rng, 8, 0.5)
    same = CC.paired_bootstrap(a, a, 300)
    assert same["diff"] == 0 and same["lo"] == 0 and same["hi"] == 0 and same["p_b_ahead"] == 0
    assert same["n_groups"] == 8 and same["n_boot"] == 300
    # B: A's detections with every FP's score lowered below every TP: never worse on any draw
    b = {g: (np.where(t > 0, s + 1.0, s - 1.0), t, n) for g, (s, t, n) in a.items()}
    r = CC.paired_bootstrap(a, b, 300)
    assert r["diff"] > 0 and r["lo"] >= 0 and r["p_b_ahead"] > 0.9
    assert r["lo"] <= r["diff"] <= r["hi"]
    with pytest.raises(ValueError):
        CC.paired_bootstrap(a, {k: v for k, v in a.items() if k != "g0"}, 10)
