# SPDX-License-Identifier: MIT
"""Parts of vdtools.evaluation.cnn_eval that the other CNN tests do not reach: the drone AP per HIT-UAV camera
angle (angle_ap), hand-worked on made-up results (no data, no model); the command's own checks; and its
operating-point choice on the val split (real data and the committed model)."""
import json
from types import SimpleNamespace

import numpy as np
import pytest

from vdtools.bindings.clib import REPO
from vdtools.evaluation import cnn_eval

MODEL = REPO / "models" / "vd_cnn.vdm"


def _result(fam, name, boxes, dets):
    fr = SimpleNamespace(dataset="hit" if fam == "hit" else fam, name=name,
                         boxes=np.array(boxes, np.float32).reshape(-1, 4))
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


def test_output_ap_ranks_only_the_boxes_at_the_threshold():
    """figures' ap_out is the AP of what a detector at threshold t outputs. Two frames, one car each: frame 1
    has the car at 0.9 and a false box at 0.5, frame 2 its car at 0.2 only. Every box ranked: TP, FP, TP ->
    recall 1/2 at precision 1, recall 1 at precision 2/3 -> AP 1/2 + 1/2 * 2/3 = 5/6. At t = 0.3 the output is
    TP, FP: recall 1/2 at precision 1 -> AP 1/2; at t = 0.95 nothing is output -> AP 0."""
    car = (10, 10, 20, 20)
    res = [_result("msrs", "a.png", [car], [(car, 0.9), ((100, 100, 20, 20), 0.5)]),
           _result("msrs", "b.png", [car], [(car, 0.2)])]
    for r in res:
        r[1].hot = np.array([True])
    rep = cnn_eval.figures(res, thresholds=[0.1, 0.3, 0.95])["msrs"]
    assert rep["ap"] == pytest.approx(5 / 6)
    assert rep["at"][0.1]["ap_out"] == pytest.approx(5 / 6)
    assert rep["at"][0.3]["ap_out"] == pytest.approx(0.5)
    assert rep["at"][0.3]["tp_rate"] == pytest.approx(0.5) and rep["at"][0.3]["fp_rate"] == pytest.approx(0.5)
    assert rep["at"][0.95]["ap_out"] == pytest.approx(0.0)


def test_split_rules_are_checked_before_any_frame_is_read(tmp_path):
    for argv in (["--split", "all"], ["--split", "train", "--subset", "msrs-night"], ["--ckpt2", "x.npz"]):
        with pytest.raises(SystemExit):      # the data folder does not exist: reading it would fail otherwise
            cnn_eval.main(["--model", str(MODEL), "--data", str(tmp_path / "none")] + argv)


def test_val_run_chooses_the_operating_point(data_dir, tmp_path):
    """Without --thr on val the command chooses the threshold (choose_threshold) and records it."""
    if not MODEL.is_file():
        pytest.skip("models/vd_cnn.vdm absent")
    out = tmp_path / "val.json"
    cnn_eval.main(["--model", str(MODEL), "--data", str(data_dir), "--split", "val", "--flip", "--out", str(out)])
    rep = json.loads(out.read_text())
    assert rep["thr"] in cnn_eval.THRESHOLDS and rep["flip"] and set(rep["families"]) == {"hit", "msrs"}
    assert rep["families"]["hit"]["at_thr"] == rep["families"]["hit"]["at"][str(rep["thr"])]
    assert rep["angles"] and all(k.split()[0] in ("day", "night") for k in rep["angles"])


def test_float_boxes_are_rounded_to_frame_pixels_and_scored_in_q15():
    """float_boxes_q15: half-resolution (x, y, w, h, score) -> frame corners rounded to the nearest pixel
    (2 x: 5.2 -> 10.4 -> 10; 5.2 + 10.1 = 15.3 -> 30.6 -> 31), score x 32768 rounded, capped at 1.0."""
    got = cnn_eval.float_boxes_q15([(5.2, 3.0, 10.1, 4.26, 0.5), (0.0, 0.0, 1.0, 1.0, 1.0)])
    assert got == [(10, 6, 21, 9, 16384), (0, 0, 2, 2, 32768)]


def test_float_pair_fuses_with_the_pair_rule():
    """FloatPair: the two networks' boxes fused as fuse_flip at threshold 0: the matched pair averaged
    (corners, score (0.5 + 0.25) -> (16384 + 8192 + 1) >> 1 = 12288), the unmatched box at half score."""
    a = SimpleNamespace(flip=True, boxes_q15=lambda img, w, h: [((10, 10, 20, 20), 16384)])
    b = SimpleNamespace(flip=True, boxes_q15=lambda img, w, h: [((12, 10, 20, 20), 8192), ((60, 60, 8, 8), 3000)])
    got = cnn_eval.FloatPair(a, b)(None, 100, 100)
    assert got == [((11, 10, 20, 20), 12288 / 32768.0), ((60, 60, 8, 8), 1500 / 32768.0)]
    with pytest.raises(ValueError):
        cnn_eval.FloatPair(a, SimpleNamespace(flip=False))


def test_false_positives_are_sorted_by_how_they_meet_the_vehicles():
    """fp_kinds on a hand-made frame with one car (0, 0, 40, 20) and one ignore region: the best box takes the
    car (TP, not counted); a second box on it (IoU 0.8) is a duplicate; a box of its left quarter (IoU 0.25,
    all inside) a part; a box twice its size around it (IoU 0.25, car inside) around; a box shifted by half
    its width (IoU 1/3) misplaced; a box far away background; a box inside the ignore region and a
    background box under the threshold are not counted."""
    car = (0, 0, 40, 20)
    dets = [((0, 0, 40, 20), 0.9), ((0, 0, 40, 16), 0.8), ((0, 0, 10, 20), 0.7), ((0, 0, 80, 40), 0.6),
            ((20, 0, 40, 20), 0.55), ((200, 200, 20, 20), 0.5), ((300, 300, 10, 10), 0.5),
            ((400, 0, 20, 20), 0.1)]
    gts = [car + (True, False), (300, 300, 20, 20, False, True)]
    got = cnn_eval.fp_kinds([("msrs", SimpleNamespace(others=np.zeros((0, 5), np.float32)), dets, gts)], 0.3)
    assert got == {"msrs": dict(background=1, road_user=0, misplaced=1, part=1, around=1, duplicate=1)}
    # with a labelled bicycle (190, 190, 20, 30): the far box (200, 200, 20, 20) overlaps it by IoU 0.25, so it
    # is a road user; a person (205, 205, 4, 8) wholly inside that box would be one too
    fr = SimpleNamespace(others=np.array([[190, 190, 20, 30, 1]], np.float32))
    got = cnn_eval.fp_kinds([("msrs", fr, dets, gts)], 0.3)
    assert got["msrs"]["road_user"] == 1 and got["msrs"]["background"] == 0
    fr = SimpleNamespace(others=np.array([[205, 205, 4, 8, 0]], np.float32))
    assert cnn_eval.fp_kinds([("msrs", fr, dets, gts)], 0.3)["msrs"]["road_user"] == 1


def test_perturb_rescale_moves_boxes_with_the_frame():
    """down50 (the cameras proxy's small cars) halves the frame by area averaging and every box with it;
    the pixel changes keep size and boxes."""
    from types import SimpleNamespace
    from vdtools.evaluation import cnn_eval as E
    img = np.arange(64 * 80, dtype=np.int64).reshape(64, 80).astype(np.uint8)
    fr = SimpleNamespace(img=img, boxes=np.array([[8, 4, 20, 10]], np.float32), ignore=np.array([[0, 0, 4, 2]], np.float32),
                         others=np.array([[2, 2, 6, 6, 0]], np.float32))
    g = E.perturb([fr], "down50")[0]
    assert g.img.shape == (32, 40) and g.img[0, 0] == (0 + 1 + 80 + 81 + 2) // 4
    np.testing.assert_allclose(g.boxes, [[4, 2, 10, 5]])
    np.testing.assert_allclose(g.ignore, [[0, 0, 2, 1]])
    np.testing.assert_allclose(g.others, [[1, 1, 3, 3, 0]])
    assert fr.others[0, 0] == 2            # the input frame is not changed
    for name in ("equalize", "clahe", "bright", "sharpen"):
        h = E.perturb([fr], name)[0]
        assert h.img.shape == img.shape and h.img.dtype == np.uint8 and h.boxes is fr.boxes
    # down33: a third, rounded (80 x 64 -> 27 x 21); boxes scaled by exactly 1/3
    t = E.perturb([fr], "down33")[0]
    assert t.img.shape == (21, 27)
    np.testing.assert_allclose(t.boxes, [[8 / 3, 4 / 3, 20 / 3, 10 / 3]], rtol=1e-6)
    # --perturb chains changes with '+', in order; an unknown name is refused by argparse
    assert E._perturb_chain("bright+down33") == ["bright", "down33"]
    import argparse
    import pytest
    with pytest.raises(argparse.ArgumentTypeError, match="nope"):
        E._perturb_chain("bright+nope")
