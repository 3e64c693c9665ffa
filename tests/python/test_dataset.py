# SPDX-License-Identifier: MIT
"""Verifier data set builder: annotation loading, group splits (no group in two splits), candidate
stage vs cv2, geometry, and samples of real frames."""
import numpy as np
import pytest

from vdtools.data import dataset


def test_iou_and_expand():
    assert dataset.iou((0, 0, 10, 10), (0, 0, 10, 10)) == 1.0
    assert dataset.iou((0, 0, 10, 10), (10, 0, 10, 10)) == 0.0
    assert dataset.iou((0, 0, 10, 10), (5, 0, 10, 10)) == pytest.approx(50 / 150)
    # 1.5x horizontally, 2x vertically about the centre, clipped to the frame
    assert dataset.expand_rect((10, 10, 20, 10), 100, 100) == (5, 5, 30, 20)
    assert dataset.expand_rect((0, 0, 20, 10), 100, 100) == (0, 0, 25, 15)


def test_cv2_candidates_apply_paper_rules():
    img = np.zeros((60, 80), np.uint8)
    img[5:20, 5:25] = 200      # 20x15: aspect 0.75, area 300 -> kept
    img[30:33, 5:60] = 200     # 55x3: aspect 0.05 -> dropped
    img[40:45, 40:45] = 200    # area 25 -> dropped
    img[40:50, 60:70] = 149    # below threshold 150
    assert dataset._candidates_cv2(img, 150) == [(5, 5, 20, 15)]


def _fake_frames():
    fr = []
    for g in range(20):
        for k in range(3):
            fr.append(dataset.FrameRec("msrs", f"m{g}_{k}", None, f"msrs:{g}"))
    for g in range(10):
        fr.append(dataset.FrameRec("hit", f"h{g}", None, f"hit:1_{g}_30"))
    fr.append(dataset.FrameRec("seq", "s0", None, "seq:0_100"))
    return fr


def test_splits_never_share_a_group_and_are_stable_under_growth():
    fr = _fake_frames()
    a = dataset.assign_splits(fr, seed=0)
    assert a == dataset.assign_splits(fr, seed=0)
    assert set(a) == {f.group for f in fr}          # each group exactly one split (dict)
    assert a["seq:0_100"] == "test"
    # growth: more frames in old groups and new groups never move an existing group
    more = fr + [dataset.FrameRec("msrs", f"x{g}", None, f"msrs:{g}") for g in range(15, 60)]
    b = dataset.assign_splits(more, seed=0)
    assert all(b[g] == s for g, s in a.items())
    # nor does dropping groups
    c = dataset.assign_splits(fr[:7], seed=0)
    assert all(c[g] == a[g] for g in c)
    # committed groups keep their recorded split; new groups follow the hash alone
    fixed = dataset.committed_splits()
    assert a["msrs:1"] == fixed["msrs:1"] == "test" and a["msrs:0"] == "train"
    assert b["msrs:59"] == dataset.hash_split("msrs:59")
    # the hash rule gives about 70/15/15 over many groups
    n = {s: 0 for s in dataset.SPLITS}
    for g in range(3000):
        n[dataset.hash_split(f"msrs:{g}")] += 1
    assert abs(n["train"] / 3000 - 0.70) < 0.03 and abs(n["val"] / 3000 - 0.15) < 0.03


def test_real_annotations_and_group_split(data_dir):
    """Counts come from the data's own manifest (robust to growth), not hard-coded totals."""
    import csv
    frames = dataset.all_frames(data_dir)
    by = {d: [f for f in frames if f.dataset == d] for d in ("msrs", "hit", "seq")}
    with open(data_dir / "msrs" / "manifest.csv") as fh:
        manifest = list(csv.DictReader(fh))
    assert len(by["msrs"]) == len(manifest) >= 553 and len(by["hit"]) >= 480 and len(by["seq"]) == 91
    assert sum(len(f.vehicles) for f in by["msrs"]) == sum(int(r["car_boxes"]) for r in manifest)
    # persons and bicycles (cnn_train --aux) by class, as the manifest counts them
    for cls, col in ((0, "person_boxes"), (1, "bicycle_boxes")):
        assert sum(1 for f in by["msrs"] for o in f.others if o[4] == cls) == sum(int(r[col]) for r in manifest)
    assert {o[4] for f in by["hit"] for o in f.others} == {0, 1}
    assert sum(len(f.vehicles) for f in by["hit"]) >= 2268 + 47
    a = dataset.assign_splits(frames, 0)
    split_groups = {s: {g for g, v in a.items() if v == s} for s in dataset.SPLITS}
    assert not (split_groups["train"] & split_groups["val"]) and not (split_groups["train"] & split_groups["test"])
    assert all(a[f.group] == "test" for f in by["seq"])
    # every group the committed models were built on keeps its split
    assert all(a[g] == s for g, s in dataset.committed_splits().items() if g in a)
    for d in ("msrs", "hit"):
        n = len(by[d])
        share = sum(1 for f in by[d] if a[f.group] == "train") / n
        assert 0.6 < share < 0.85
    # every HIT-UAV frame of the annotation file is read, the vehicle-free ones too (hard negatives in
    # training, false positives where there is nothing to find in evaluation), counted from the file itself
    import json
    with open(data_dir / "hit-uav" / "frames" / "annotations.json") as fh:
        ann = json.load(fh)
    with_vehicle = {b["image_id"] for b in ann["annotation"] if b["category_id"] in (1, 3)}
    assert len(by["hit"]) == len(ann["images"])
    assert sum(1 for f in by["hit"] if not f.vehicles) == sum(1 for i in ann["images"] if i["id"] not in with_vehicle)
    # a flight's frames are one group, whatever vehicles they hold: vehicle-free frames are in their flight's split
    assert {f.group for f in by["hit"] if not f.vehicles} <= {f.group for f in by["hit"] if f.vehicles} | set(a)


def test_vehicle_free_frames_reach_the_cnn_splits(data_dir):
    """The CNN's frame loader keeps frames without a vehicle in every split (training negatives, FP measure)."""
    from vdtools.data import cnn_data
    frames = cnn_data.load_frames(data_dir, splits=("val",))
    assert any(len(f.boxes) == 0 and f.dataset == "hit" for f in frames)
    assert all(f.split == "val" for f in frames)


def test_frame_samples_on_real_frame(data_dir):
    _, seq = dataset.load_hit(data_dir)
    fr = seq[0]
    rng = np.random.default_rng(0)
    out = list(dataset.frame_samples(fr, "test", "grey", rng, [(40, 40)]))
    pos = [o for o in out if o[1] == 1]
    neg = [o for o in out if o[1] == 0]
    assert len(pos) == sum(1 for b in fr.vehicles if dataset._ok(b))
    assert all(o[0].shape == (32, 32) and o[0].dtype == np.uint8 for o in out)
    for s, lab, src, rect, hot in neg:
        assert all(dataset.iou(rect, v) < dataset.NEG_IOU for v in fr.vehicles)
    # train split adds mirrored and jittered positives
    tr = list(dataset.frame_samples(fr, "train", "grey", np.random.default_rng(0), [(40, 40)]))
    assert sum(1 for o in tr if o[1] == 1) > len(pos)


def test_mined_samples_on_real_frame(data_dir):
    """Window / contrast hard negatives and window positives of one MSRS frame with cars."""
    fr = next(f for f in dataset.load_msrs(data_dir) if len(f.vehicles) >= 2)
    img = dataset.read_frame(fr.path)
    out = list(dataset.mined_samples(img, fr, "train", "grey", np.random.default_rng(0)))
    again = list(dataset.mined_samples(img, fr, "train", "grey", np.random.default_rng(0)))
    assert [o[3] for o in out] == [o[3] for o in again]            # seeded
    neg = [o for o in out if o[1] == 0]
    assert 0 < sum(1 for o in neg if o[2] == "window") <= dataset.NEG_WINDOW_PER_FRAME["train"]
    assert sum(1 for o in neg if o[2] == "contrast") <= dataset.NEG_CONTRAST_PER_FRAME
    for s, lab, src, rect, hot in out:
        assert s.shape == (32, 32) and s.dtype == np.uint8
        best = max(dataset.iou(rect, v) for v in fr.vehicles)
        assert (best >= dataset.WIN_POS_IOU) if lab else (best < dataset.NEG_IOU)
    # the structure level is the detector's pre-filter: flat windows score 0
    flat = np.full((64, 64), 90, np.uint8)
    assert dataset._window_levels(flat, np.array([[0, 0, 32, 32]]))[0] == 0


def test_cached_set_splits_are_disjoint_by_group():
    p = dataset.cache_path("grey", 0)
    if not p.exists():
        pytest.skip(f"no cached data set at {p} (python3 -m vdtools.data.dataset --mode grey)")
    ds = dataset.load(p)
    g = {s: set(ds["group"][ds["split"] == s]) for s in dataset.SPLITS}
    assert not (g["train"] & g["val"]) and not (g["train"] & g["test"]) and not (g["val"] & g["test"])
    assert set(ds["source"][ds["split"] != "train"]) <= {"box", "candidate", "random", "window", "contrast",
                                                         "window_pos"}  # no augmentation
    # mined negatives never overlap a vehicle of their frame
    neg = (ds["y"] == 0) & np.isin(ds["source"], ("window", "contrast"))
    pos = ds["y"] == 1
    assert neg.any() and set(ds["split"][neg]) == set(dataset.SPLITS)
    for f in np.unique(ds["frame"][neg])[:40]:
        v = ds["rect"][pos & (ds["frame"] == f) & (ds["source"] == "box")]
        for r in ds["rect"][neg & (ds["frame"] == f)]:
            assert all(dataset.iou(tuple(r), tuple(b)) < dataset.NEG_IOU for b in v)
    assert ds["X"].shape[1:] == (32, 32) and len(ds["X"]) == len(ds["y"])
