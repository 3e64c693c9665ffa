# SPDX-License-Identifier: MIT
"""Reporting helpers of vdtools.evaluation.cnn_eval that the other CNN tests do not reach: the drone AP per
HIT-UAV camera angle (angle_ap), hand-worked on made-up results (no data, no model)."""
from types import SimpleNamespace

import numpy as np
import pytest

from vdtools.evaluation import cnn_eval


def _result(fam, name, boxes, dets):
    fr = SimpleNamespace(path=f"frames/{name}", boxes=np.array(boxes, np.float32).reshape(-1, 4))
    gts = [tuple(b) + (True, False) for b in fr.boxes.tolist()]
    return fam, fr, dets, gts


def test_angle_ap_groups_drone_frames_by_time_and_angle():
    box = (10, 10, 20, 20)
    res = [_result("hit", "0_100_30_0_00001.jpg", [box], [(box, 0.9)]),           # day 30: found
           _result("hit", "0_120_30_0_00002.jpg", [box, (50, 50, 20, 20)], []),  # day 30: two missed
           _result("hit", "1_60_90_0_00003.jpg", [box], [((60, 60, 20, 20), 0.8)]),   # night 90: a false positive
           _result("hit", "1_60_5_0_00004.jpg", [box], [(box, 0.5)]),            # night 5 sorts before 90
           _result("msrs", "00001N.png", [box], [])]                             # road level: not a drone angle
    got = cnn_eval.angle_ap(res)
    assert list(got) == ["day 30", "night 5", "night 90"]
    # day 30: 1 of 3 vehicles found at precision 1 -> all-point AP 1/3
    assert got["day 30"][0] == pytest.approx(1 / 3) and got["day 30"][1] == 3
    assert got["night 5"] == (pytest.approx(1.0), 1) and got["night 90"] == (pytest.approx(0.0), 1)
    assert cnn_eval.angle_ap(res[-1:]) == {}
