# SPDX-License-Identifier: MIT
"""vd-adapt (tools/vdtools/adapt, docs/adapt.md): the plumbing, not the accuracy.

- Every bad input gets exit status 2, one line on stderr, and neither OUT nor its work folder OUT.tmp-*:
  these checks run before PyTorch is imported, so they need neither PyTorch nor the C library.
- End to end on a few synthetic frames with a couple of training steps (PyTorch, the C library and
  vd_fir_demo): labelled and unlabelled, the outputs exist and are well-formed, vd_fir_demo runs OUT/vd.json,
  and an interrupted run resumes from its checkpoint.
- The split and the label readers (YOLO, COCO and HIT-UAV's COCO dialect) by hand.
"""
import json
import os
import subprocess
import sys

import cv2
import numpy as np
import pytest

from vdtools.adapt import cli
from vdtools.adapt import inputs as I

from buildpaths import REPO, run_demo

W, H = 160, 128


def _frames(folder, n=8, size=(W, H), labels=None, seed=0, skip_label=(3,)):
    """n synthetic frames (noise + 1-2 bright rectangles) as PNG in folder, YOLO labels (class 2) in labels."""
    rng = np.random.default_rng(seed)
    folder.mkdir(parents=True, exist_ok=True)
    if labels is not None:
        labels.mkdir(parents=True, exist_ok=True)
    w, h = size
    for i in range(n):
        img = rng.normal(60, 8, (h, w)).clip(0, 255).astype(np.uint8)
        rows = []
        for _ in range(int(rng.integers(1, 3))):
            bw, bh = (int(v) for v in rng.integers(12, 24, 2))
            x, y = int(rng.integers(0, w - bw)), int(rng.integers(0, h - bh))
            img[y:y + bh, x:x + bw] = 200
            rows.append(f"2 {(x + bw / 2) / w:.5f} {(y + bh / 2) / h:.5f} {bw / w:.5f} {bh / h:.5f}\n")
        cv2.imwrite(str(folder / f"f{i:03d}.png"), img)
        if labels is not None and i not in skip_label:
            (labels / f"f{i:03d}.txt").write_text("".join(rows))
    return folder


def _adapt(args, capsys):
    """vd-adapt in this process: (exit status, stderr lines)."""
    rc = cli.main([str(a) for a in args])
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    return rc, err


def _nothing_written(out):
    assert not out.exists(), f"{out} was created"
    assert not list(out.parent.glob(out.name + ".tmp-*")), "a work folder was left behind"
    assert not list(out.parent.glob("." + out.name + ".probe-*"))


def _bad(capsys, out, args, needle):
    rc, err = _adapt(list(args) + ["--out", out], capsys)
    assert rc == 2, err
    assert len(err) == 1, err
    assert err[0].startswith("vd-adapt: error: ") and needle in err[0], err[0]
    _nothing_written(out)


# ---------------------------------------------------------------- bad input (no PyTorch needed)

def test_missing_and_empty_folder(tmp_path, capsys):
    out = tmp_path / "out"
    _bad(capsys, out, ["--images", tmp_path / "nope"], "no such folder")
    (tmp_path / "empty").mkdir()
    (tmp_path / "empty" / "notes.txt").write_text("no frames here")
    _bad(capsys, out, ["--images", tmp_path / "empty"], "no frames in it")


def test_labels_that_match_no_frame(tmp_path, capsys):
    imgs = _frames(tmp_path / "images")
    lab = tmp_path / "labels"
    lab.mkdir()
    (lab / "other.txt").write_text("2 0.5 0.5 0.1 0.1\n")
    out = tmp_path / "out"
    _bad(capsys, out, ["--images", imgs, "--labels", lab], "matches a frame")
    coco = tmp_path / "a.json"
    coco.write_text(json.dumps(dict(images=[dict(id=1, file_name="x.png", width=W, height=H)], annotations=[],
                                    categories=[dict(id=1, name="car")])))
    _bad(capsys, out, ["--images", imgs, "--labels", coco], "matches a frame")
    _bad(capsys, out, ["--images", imgs, "--labels", tmp_path / "none.json"], "no such folder or file")


def test_mixed_frame_sizes(tmp_path, capsys):
    imgs = _frames(tmp_path / "images", n=5)
    _frames(tmp_path / "images2", n=1, size=(W * 2, H))
    os.replace(tmp_path / "images2" / "f000.png", imgs / "g000.png")
    _bad(capsys, tmp_path / "out", ["--images", imgs], "mixed frame sizes")


def test_unknown_class_id(tmp_path, capsys):
    imgs = _frames(tmp_path / "images", labels=tmp_path / "labels")
    out = tmp_path / "out"
    _bad(capsys, out, ["--images", imgs, "--labels", tmp_path / "labels", "--classes", "7"], "unknown class id 7")
    (tmp_path / "labels" / "classes.txt").write_text("person\nbicycle\ncar\n")
    (tmp_path / "labels" / "f000.txt").write_text("5 0.5 0.5 0.1 0.1\n")
    _bad(capsys, out, ["--images", imgs, "--labels", tmp_path / "labels"], "unknown class id 5")
    coco = tmp_path / "a.json"
    coco.write_text(json.dumps(dict(images=[dict(id=1, file_name="f000.png")], categories=[dict(id=1, name="car")],
                                    annotations=[dict(id=9, image_id=1, category_id=4, bbox=[1, 1, 9, 9])])))
    _bad(capsys, out, ["--images", imgs, "--labels", coco], "unknown class id 4")


def test_corrupt_image(tmp_path, capsys):
    imgs = _frames(tmp_path / "images")
    blob = (imgs / "f002.png").read_bytes()
    (imgs / "f002.png").write_bytes(blob[:len(blob) // 2])
    _bad(capsys, tmp_path / "out", ["--images", imgs], "f002.png: corrupt")
    (imgs / "f002.png").write_bytes(blob)
    _, enc = cv2.imencode(".jpg", np.random.default_rng(0).integers(0, 255, (H, W), np.uint8))
    (imgs / "f009.jpg").write_bytes(enc.tobytes()[:enc.size // 2])     # truncated: OpenCV would decode it
    _bad(capsys, tmp_path / "out", ["--images", imgs], "f009.jpg: corrupt")


def test_unwritable_out(tmp_path, capsys):
    imgs = _frames(tmp_path / "images")
    (tmp_path / "file").write_text("x")
    _bad(capsys, tmp_path / "file" / "out", ["--images", imgs], "is not an existing folder")
    full = tmp_path / "full"
    full.mkdir()
    (full / "old.txt").write_text("x")
    rc, err = _adapt(["--images", imgs, "--out", full], capsys)
    assert rc == 2 and len(err) == 1 and "not an empty folder" in err[0]
    assert sorted(p.name for p in full.iterdir()) == ["old.txt"]
    if os.path.isdir("/proc/self"):     # mkdir fails there even for root
        rc, err = _adapt(["--images", imgs, "--out", "/proc/self/vd-adapt-out"], capsys)
        assert rc == 2 and len(err) == 1 and "cannot write" in err[0], err


def test_too_few_labelled_frames(tmp_path, capsys):
    out = tmp_path / "out"
    imgs = _frames(tmp_path / "a", n=3, labels=tmp_path / "la")
    _bad(capsys, out, ["--images", imgs, "--labels", tmp_path / "la"], "too few frames")
    imgs = _frames(tmp_path / "b", n=8, labels=tmp_path / "lb", skip_label=range(1, 8))
    _bad(capsys, out, ["--images", imgs, "--labels", tmp_path / "lb"], "too few labelled frames")


def test_bad_arguments_are_one_line(tmp_path, capsys):
    imgs = _frames(tmp_path / "images")
    _bad(capsys, tmp_path / "out", ["--images", imgs, "--val-frac", "1.5"], "--val-frac")
    _bad(capsys, tmp_path / "out", ["--images", imgs, "--classes", "2"], "give --labels too")
    _bad(capsys, tmp_path / "out", ["--images", imgs, "--lr", "0"], "--lr")
    _frames(tmp_path / "images2", labels=tmp_path / "labels2")
    _bad(capsys, tmp_path / "out", ["--images", tmp_path / "images2", "--labels", tmp_path / "labels2",
                                    "--self-train"], "--self-train is for frames without labels")
    rc, err = _adapt(["--images", imgs], capsys)          # argparse's own error, on one line too
    assert rc == 2 and len(err) == 1 and "--out" in err[0]


# ---------------------------------------------------------------- split and label readers (no PyTorch)

def _uf(n, with_vehicle):
    out = []
    for i in range(n):
        f = I.UserFrame(f"f{i:03d}", None, np.zeros((8, 8), np.uint8))
        if i in with_vehicle:
            f.boxes = np.array([[1, 1, 4, 4]], np.float32)
        out.append(f)
    return out


def test_split_blocks_keeps_neighbours_together_and_spreads_val():
    frames = _uf(48, range(48))
    assert I.split_blocks(frames, 0.25) == 3                 # ceil(48 / 16)
    val_blocks = sorted({f.block for f in frames if f.part == "val"})
    assert val_blocks == [2, 6, 10, 14]                      # 4 of 16 blocks, evenly spread
    for b in range(16):                                      # a block is never cut
        assert len({f.part for f in frames if f.block == b}) == 1
    frames = _uf(8, {0, 1})                                  # vehicles only in the first block of two frames
    with pytest.raises(I.InputError, match="all fall in one part"):
        I.split_blocks(frames, 0.25)
    frames = _uf(8, {0, 7})
    I.split_blocks(frames, 0.25)
    assert {f.part for f in frames if len(f.boxes)} == {"adapt", "val"}


def test_yolo_and_coco_labels(tmp_path):
    imgs = _frames(tmp_path / "images", n=4, labels=tmp_path / "labels", skip_label=())
    (tmp_path / "labels" / "classes.txt").write_text("person\nbicycle\ncar\ndontcare\n")
    (tmp_path / "labels" / "f001.txt").write_text("0 0.5 0.5 0.1 0.1\n2 0.5 0.5 0.25 0.5\n3 0.1 0.1 0.1 0.1\n")
    frames = I.read_frames(I.list_frames(imgs))
    info = I.read_labels(tmp_path / "labels", frames)
    assert info["vehicle_classes"] == [2]                    # "car" by name, no --classes needed
    np.testing.assert_allclose(frames[1].boxes, [[0.375 * W, 0.25 * H, 0.25 * W, 0.5 * H]])
    assert len(frames[1].ignore) == 1                         # dontcare
    doc = dict(images=[dict(id=7, filename="f002.png", width=W, height=H)],      # HIT-UAV's dialect
               annotation=[dict(id=1, image_id=7, category_id=1, bbox=[10, 20, 30, 40]),
                           dict(id=2, image_id=7, category_id=3, bbox=[50, 60, 10, 10]),
                           dict(id=3, image_id=7, category_id=4, bbox=[0, 0, 5, 5])],
               categories=[dict(id=0, name="Person"), dict(id=1, name="Car"), dict(id=3, name="OtherVehicle"),
                           dict(id=4, name="DontCare")])
    (tmp_path / "hit.json").write_text(json.dumps(doc))
    frames = I.read_frames(I.list_frames(imgs))
    info = I.read_labels(tmp_path / "hit.json", frames)
    assert info["vehicle_classes"] == [1, 3] and info["matched"] == 1
    np.testing.assert_allclose(frames[2].boxes, [[10, 20, 30, 40], [50, 60, 10, 10]])
    assert len(frames[2].ignore) == 1 and frames[2].labelled and not frames[0].labelled


def test_16bit_frames_read_as_the_demo_reads_them(tmp_path):
    """16-bit frames map to grey as vd_fir_demo's --grey-window auto maps them: radiometric ones (inside the fixed
    0-51 C window) by that window; a camera's raw counts (all outside it) by each frame's own window, decided on
    the first frame for all of them, so the networks train on the scene and not on a black plane."""
    from vdtools.data import dataset as D
    rng = np.random.default_rng(4)
    scene = [np.clip(rng.normal(100 + 20 * k, 30, (H, W)), 0, 255).astype(np.uint16) for k in range(3)]
    for kind, to16 in (("radiometric", lambda g: 27315 + g * 20), ("counts", lambda g: 1000 + g * 64)):
        d = tmp_path / kind
        d.mkdir()
        for k, g in enumerate(scene):
            cv2.imwrite(str(d / f"f{k}.png"), to16(g).astype(np.uint16))
        frames = I.read_frames(I.list_frames(d))
        for fr, g in zip(frames, scene):
            raw = to16(g).astype(np.uint16)
            if kind == "radiometric":
                assert D.grey_outside_permille(raw) == 0
                np.testing.assert_array_equal(fr.img, D.grey_of_ck(raw))
            else:
                assert D.grey_outside_permille(raw) == 1000 and not D.grey_of_ck(raw).any()   # fixed: black
                np.testing.assert_array_equal(fr.img, D.grey_of_ck(raw, *D.grey_window_ck(raw)))
                assert fr.img.std() > 40   # the scene's contrast, stretched to 0..255
    # the first frame decides: a radiometric first frame keeps the fixed window for a later raw one
    d = tmp_path / "mixed"
    d.mkdir()
    cv2.imwrite(str(d / "a.png"), (27315 + scene[0] * 20).astype(np.uint16))
    cv2.imwrite(str(d / "b.png"), (1000 + scene[1] * 64).astype(np.uint16))
    frames = I.read_frames(I.list_frames(d))
    assert not frames[1].img.any()


def test_hit_uav_annotations_read(data_dir, tmp_path):
    """The real HIT-UAV annotations.json (its `annotation` / `filename` dialect) on a few of its frames."""
    src = data_dir / "hit-uav" / "frames"
    names = sorted(p.name for p in (src / "images").iterdir())[:6]
    imgs = tmp_path / "images"
    imgs.mkdir()
    for n in names:
        os.symlink(src / "images" / n, imgs / n)
    frames = I.read_frames(I.list_frames(imgs))
    info = I.read_labels(src / "annotations.json", frames)
    assert info["vehicle_classes"] == [1, 3] and info["matched"] == 6
    doc = json.loads((src / "annotations.json").read_text())
    ids = {im["id"]: im["filename"] for im in doc["images"]}
    want = sum(1 for a in doc["annotation"] if ids[a["image_id"]] in names and a["category_id"] in (1, 3))
    assert sum(len(f.boxes) for f in frames) == want


# ---------------------------------------------------------------- end to end (PyTorch, C library, demo)

def _run(args, timeout=900):
    env = dict(os.environ, PYTHONPATH=str(REPO / "tools") + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-m", "vdtools.adapt", *map(str, args), "--quiet", "--threads", "1"],
                          capture_output=True, text=True, timeout=timeout, env=env)


def _check_outputs(out, demo, images, n_nets=2):
    from vdtools.formats import cnn_vdm as V
    from vdtools.training.cnn_targets import NORM_CODE
    names = ["vd_cnn", "vd_cnn2"][:n_nets]
    for n in names:
        desc = V.unpack((out / f"{n}.vdm").read_bytes())
        assert desc["name"] == n
        assert (out / f"{n}_vdm.c").is_file() and (out / f"{n}_vdm.h").is_file()
        assert json.loads((out / f"{n}.scales.json").read_text())["adapted_by"] == "vd-adapt"
        # the float weights keep the input normalisation their .vdm reads (vd_cnn2: equalise), so that
        # --base OUT/float/... adapts the same network again
        with np.load(out / "float" / f"{n}.npz") as z:
            norm = str(z["__norm__"]) if "__norm__" in z.files else "stretch"   # files before --norm: stretch
            assert NORM_CODE[norm] == desc["input_norm"], n
    assert not (out / "ckpt.pt").exists() and not list(out.parent.glob(out.name + ".tmp-*"))
    cfg = json.loads((out / "vd.json").read_text())
    assert cfg["cnn-model"] == str(out / "vd_cnn.vdm") and cfg["sources"] == "cnn" and 0 < cfg["cnn-thr"] < 1
    rep = json.loads((out / "report.json").read_text())
    assert rep["command"].startswith("vd-adapt ") and rep["time"]["wall_s"] > 0
    assert rep["outputs"]["demo_check"]["accepted"] is True
    js = out.parent / "check.jsonl"
    run_demo(demo, "--config", out / "vd.json", "--input", images, "--json", js, "--quiet", "--temporal", "off")
    assert len(js.read_text().splitlines()) == len(list(images.glob("*.png")))
    return rep, (out / "report.md").read_text()


def _best(measured):
    """The resolution choose_resolution takes: the highest measure, ties to the earlier of half, full, quarter."""
    res = [r for r in ("half", "full", "quarter") if r in measured]
    return max(res, key=lambda r: (measured[r], -res.index(r)))


def test_end_to_end_labelled(tmp_path, vdlib, demo):
    pytest.importorskip("torch", reason="PyTorch is not installed (tools/setup.sh installs it)")
    imgs = _frames(tmp_path / "images", labels=tmp_path / "labels")
    out = tmp_path / "out"
    p = _run(["--images", imgs, "--labels", tmp_path / "labels", "--classes", "2", "--out", out, "--steps", "2",
              "--replay", "none", "--demo", demo])
    assert p.returncode == 0, p.stderr
    rep, md = _check_outputs(out, demo, imgs)
    assert rep["labelled"] and rep["training"]["steps"] == 2
    assert rep["frames"]["adapt"] + rep["frames"]["val"] == 8 and rep["frames"]["val"] >= 2
    for k in ("before", "after"):
        assert 0.0 <= rep["val"][k]["ap"] <= 1.0 and rep["val"][k]["n_vehicles"] == rep["frames"]["val_vehicles"]
        # the output's AP ranks a subset of the boxes of the full ranking (those >= the threshold)
        assert 0.0 <= rep["val"][k]["ap_out"] <= rep["val"][k]["ap"] + 1e-12
    assert "AP@0.5 of the output" in md and "Time taken" in md
    # --resolution auto with labels: the three input resolutions measured on all 8 labelled frames, the best kept
    res = rep["resolution"]
    assert res["asked"] == "auto" and res["measured"]["measure"] == "AP@0.5"
    assert res["res"] == _best(res["measured"]) and res["full_res"] == (res["res"] == "full")
    # the choice is pinned in vd.json (the demo's default, auto, would measure it again)
    assert json.loads((out / "vd.json").read_text())["cnn-res"] == res["res"]
    # --polarity auto with labels: AP@0.5 of the frames as they are and inverted (each the better of half and full
    # resolution), the higher kept and pinned in vd.json (the demo's own polarity measurement would judge the
    # adapted networks by the shipped ones' habit)
    pol = rep["polarity"]
    assert pol["asked"] == "auto" and pol["measured"]["measure"] == "AP@0.5"
    assert pol["black_hot"] == (pol["measured"]["inverted"] > pol["measured"]["as_is"])
    assert json.loads((out / "vd.json").read_text())["cnn-polarity"] == ("black-hot" if pol["black_hot"] else "white-hot")


def test_end_to_end_unlabelled_resumes(tmp_path, vdlib, demo):
    pytest.importorskip("torch", reason="PyTorch is not installed (tools/setup.sh installs it)")
    imgs = _frames(tmp_path / "images")
    out = tmp_path / "out"
    args = ["--images", imgs, "--out", out, "--steps", "3", "--rounds", "2", "--replay", "none", "--demo", demo,
            "--resolution", "full", "--self-train"]
    p = _run(args + ["--interrupt-after", "1"])
    assert p.returncode == 3 and "resume" in p.stderr, p.stderr
    assert not out.exists() and len(list(tmp_path.glob("out.tmp-*"))) == 1
    p = _run(args)
    assert p.returncode == 0, p.stderr
    rep, md = _check_outputs(out, demo, imgs)
    assert not rep["labelled"] and rep["training"]["resumed"] and rep["training"]["steps"] == 3
    assert [r["round"] for r in rep["pseudo_labels"]["rounds"]] == [0, 1]
    assert "gain is not measured" in md and "boxes per frame" in md
    # --resolution full, kept across the resume: vd.json turns the detector's full-resolution input on (and
    # _check_outputs ran the demo with it)
    assert rep["resolution"] == dict(full_res=True, res="full", asked="full", chosen_on="asked", measured=None)
    assert json.loads((out / "vd.json").read_text())["cnn-res"] == "full"
    assert "**full**" in md


def test_end_to_end_unlabelled_chooses_resolution_by_rating(tmp_path, vdlib, demo):
    """Without labels and without --self-train (the default): the resolution is chosen by the rating (mean box
    score + flip agreement / 4), the
    shipped networks are written unchanged (files, firmware arrays, float weights) and nothing is trained."""
    pytest.importorskip("torch", reason="PyTorch is not installed (tools/setup.sh installs it)")
    imgs = _frames(tmp_path / "images")
    out = tmp_path / "out"
    p = _run(["--images", imgs, "--out", out, "--replay", "none", "--demo", demo])
    assert p.returncode == 0, p.stderr
    rep, md = _check_outputs(out, demo, imgs)
    res = rep["resolution"]
    assert res["asked"] == "auto" and res["measured"]["measure"] == "rating (mean box score + flip agreement / 4)"
    assert res["res"] == _best(res["measured"])
    assert all(0.0 <= res["measured"][r] <= 1.125 for r in ("half", "full", "quarter"))
    assert "rating (mean box score + flip agreement / 4) of the before networks" in md
    assert rep["training"]["trained"] is False and rep["training"]["steps"] == 0 and "pseudo_labels" not in rep
    assert "the networks were not trained" in md and "shipped (unchanged)" in md
    for n in ("vd_cnn", "vd_cnn2"):
        assert (out / f"{n}.vdm").read_bytes() == (REPO / "models" / f"{n}.vdm").read_bytes()
        assert (out / "float" / f"{n}.npz").read_bytes() == (REPO / "models" / "float" / f"{n}.npz").read_bytes()
    assert rep["val"]["boxes_per_frame"]["before"] == rep["val"]["boxes_per_frame"]["after"]
    assert json.loads((out / "vd.json").read_text())["cnn-thr"] == round(rep["threshold"]["before"], 4)


def test_doubled_frame_is_the_frame_at_full_resolution():
    """tune.doubled: every pixel 2 x 2, boxes x 2; its half-resolution plane (cnn_data.half) is the frame."""
    import numpy as np
    from vdtools.adapt import tune as TU
    from vdtools.data import cnn_data as CD
    img = np.array([[10, 20, 30], [40, 50, 60]], np.uint8)
    fr = CD.Frame("user", "a.png", "a.png", "user:0", "adapt", img, np.array([[1, 0, 2, 1]], np.float32),
                  np.zeros((0, 4), np.float32), np.array([True]))
    d = TU.doubled(fr)
    assert d.img.shape == (4, 6) and d.img[3, 5] == 60 and d.img[0, 1] == 10 and d.img[2, 2] == 50
    assert d.boxes.tolist() == [[2, 0, 4, 2]] and fr.boxes.tolist() == [[1, 0, 2, 1]]
    assert np.array_equal(CD.half(d.img), img)


def test_halved_frame_is_the_frame_at_quarter_resolution():
    """tune.halved: the 2 x 2 means, boxes / 2; its half-resolution plane is the frame's 4 x 4 means (up to the
    rounding of two means in turn: here exact, every 2 x 2 block flat)."""
    import numpy as np
    from vdtools.adapt import tune as TU
    from vdtools.data import cnn_data as CD
    img = np.repeat(np.repeat(np.array([[10, 20], [30, 41]], np.uint8), 2, 0), 2, 1)   # 4 x 4, flat 2 x 2 blocks
    img = np.tile(img, (2, 2))                                                          # 8 x 8
    fr = CD.Frame("user", "a.png", "a.png", "user:0", "adapt", img, np.array([[4, 0, 4, 2]], np.float32),
                  np.zeros((0, 4), np.float32), np.array([True]))
    h = TU.halved(fr)
    assert h.img.shape == (4, 4) and h.img[0, 0] == 10 and h.img[1, 1] == 41
    assert h.boxes.tolist() == [[2, 0, 2, 1]] and fr.boxes.tolist() == [[4, 0, 4, 2]]
    assert np.array_equal(CD.half(h.img), CD.box_mean(img, 4))   # (10 + 20 + 30 + 41 + 2) // 4 = 25
    assert CD.box_mean(img, 4)[0, 0] == 25 and TU.at_res(fr, 0) is fr and TU.at_res(fr, 2).img.shape == (4, 4)


def test_end_to_end_quarter_resolution(tmp_path, vdlib, demo):
    """--resolution quarter (vehicles about twice the training size): the shipped networks kept without labels,
    vd.json says cnn-res quarter, and the demo runs it."""
    pytest.importorskip("torch", reason="PyTorch is not installed (tools/setup.sh installs it)")
    imgs = _frames(tmp_path / "images")
    out = tmp_path / "out"
    p = _run(["--images", imgs, "--out", out, "--replay", "none", "--demo", demo, "--resolution", "quarter"])
    assert p.returncode == 0, p.stderr
    rep, md = _check_outputs(out, demo, imgs)
    assert rep["resolution"] == dict(full_res=False, res="quarter", asked="quarter", chosen_on="asked", measured=None)
    assert json.loads((out / "vd.json").read_text())["cnn-res"] == "quarter" and "**quarter**" in md


def test_threshold_rule_needs_evidence_to_leave_the_shipped_point():
    """measure.choose_threshold: the one-standard-error rule. Four val frames, one car each: at the prior
    (0.3076) TP 4 and FP 2 (F1 8/10), from 0.35 up TP 3 and FP 0 (F1 6/7, the best). Within one bootstrap
    standard error of four frames, so the prior stays; the same frames 100 times over make the gap certain,
    and the best point wins. cnn_eval's rule, which vd-adapt used before, takes 0.35 (TP 75 %, FP 0 %) from
    the four frames already."""
    from types import SimpleNamespace
    from vdtools.adapt import measure as M
    from vdtools.evaluation import cnn_eval as CE
    car, fp_box = (100, 100, 40, 30), (300, 300, 40, 30)
    def frame(dets):
        return ("user", SimpleNamespace(boxes=[car], hot=np.array([True])), [(b, s) for b, s in dets], [car + (True, False)])
    frames = [frame([(car, 0.9)]), frame([(car, 0.9), (fp_box, 0.33)]), frame([(car, 0.9), (fp_box, 0.33)]),
              frame([(car, 0.32)])]
    assert M.choose_threshold(frames, prior=0.3076) == 0.3076
    assert M.choose_threshold(frames * 100, prior=0.3076) == 0.35
    assert CE.choose_threshold(CE.figures(frames)) == 0.35
    assert M.choose_threshold(frames, prior=0.3076, seed=1) == 0.3076    # not one lucky draw


def test_end_to_end_black_hot_camera(tmp_path, vdlib, demo):
    """--polarity auto (the default) with labels on a black-hot camera (the bundled clip's frames written as
    255 - v, its COCO annotations): the shipped networks' AP on the frames inverted is the higher, so the user's
    frames are inverted before anything else and vd.json has the demo read them black-hot; the report says so."""
    pytest.importorskip("torch", reason="PyTorch is not installed (tools/setup.sh installs it)")
    clip = REPO / "tools" / "demo" / "hit-uav-clip"
    ann = json.loads((clip / "annotations.json").read_text())
    imgs = tmp_path / "images"
    imgs.mkdir()
    for im in ann["images"]:
        g = cv2.imread(str(clip / "images" / im["filename"]), cv2.IMREAD_GRAYSCALE)
        im["filename"] = im["filename"].rsplit(".", 1)[0] + ".png"
        cv2.imwrite(str(imgs / im["filename"]), 255 - g)
    (tmp_path / "ann.json").write_text(json.dumps(ann))
    out = tmp_path / "out"
    p = _run(["--images", imgs, "--labels", tmp_path / "ann.json", "--classes", "1,3", "--out", out, "--steps", "1",
              "--replay", "none", "--resolution", "half", "--demo", demo])
    assert p.returncode == 0, p.stderr
    rep, md = _check_outputs(out, demo, imgs)
    pol = rep["polarity"]
    assert pol["asked"] == "auto" and pol["black_hot"] is True and pol["measured"]["measure"] == "AP@0.5"
    assert pol["measured"]["inverted"] > pol["measured"]["as_is"] + 0.05   # measured: 0.83 against 0.70 (every peak)
    assert json.loads((out / "vd.json").read_text())["cnn-polarity"] == "black-hot" and "**black-hot**" in md
    # the val figures are those of the frames inverted: the shipped networks' AP there, not the black-hot one's
    assert rep["val"]["before"]["ap"] > 0.3


def test_base_quantised_here_follows_the_polarity(tmp_path, vdlib, demo):
    """A --base without its int8 files is quantised here; without replayed frames it calibrates on the user's
    frames, so for a black-hot camera it is quantised again on them inverted (as the networks will read them)."""
    pytest.importorskip("torch", reason="PyTorch is not installed (tools/setup.sh installs it)")
    imgs = _frames(tmp_path / "images")
    out = tmp_path / "out"
    p = _run(["--images", imgs, "--out", out, "--replay", "none", "--demo", demo, "--resolution", "half",
              "--polarity", "black-hot", "--base", REPO / "models" / "float" / "vd_cnn.npz"])
    assert p.returncode == 0, p.stderr
    rep, _md = _check_outputs(out, demo, imgs, n_nets=1)
    assert rep["before_quantised_here"] and rep["before_models"] == ["before-inverted/vd_cnn.vdm"]
    assert rep["polarity"] == dict(black_hot=True, asked="black-hot", chosen_on="asked", measured=None)
    assert json.loads((out / "vd.json").read_text())["cnn-polarity"] == "black-hot"
