# SPDX-License-Identifier: MIT
"""The bundled synthetic clip (tools/vdtools/data/clip.py): deterministic, documented formats,
ground truth in the HIT-UAV layout, and a scene the paper's rules can work on."""
import json

import numpy as np
import pytest

from vdtools.data import clip


@pytest.fixture(scope="module")
def small_clip(tmp_path_factory):
    out = tmp_path_factory.mktemp("clip")
    doc = clip.generate(out, frames=12, seed=1)
    return out, doc


def test_u8_mapping_constants():
    # 30.00 degC = 30315 cK -> 150 (paper 001's threshold); -30 degC -> 0; 72 degC -> 255; clamped outside
    assert clip.ck_to_u8(30315) == 150
    assert clip.ck_to_u8(24315) == 0 and clip.ck_to_u8(0) == 0
    assert clip.ck_to_u8(24315 + 255 * 40) == 255 and clip.ck_to_u8(65535) == 255
    assert clip.ck_to_u8(30315 + 19) == 150 and clip.ck_to_u8(30315 + 20) == 151
    assert clip.c2ck(30.0) == 30315


def test_deterministic(tmp_path, small_clip):
    out, _ = small_clip
    clip.generate(tmp_path, frames=12, seed=1)
    for sub in ("u16", "u8"):
        for t in (0, 7, 11):
            name = f"frame_{t:04d}.pgm"
            assert (tmp_path / sub / name).read_bytes() == (out / sub / name).read_bytes()
    assert (tmp_path / "annotations.json").read_text() == (out / "annotations.json").read_text()
    other = tmp_path / "other"
    clip.generate(other, frames=2, seed=2)
    assert (other / "u16" / "frame_0001.pgm").read_bytes() != (out / "u16" / "frame_0001.pgm").read_bytes()


def test_pgm_formats(small_clip):
    out, _ = small_clip
    raw16 = (out / "u16" / "frame_0003.pgm").read_bytes()
    assert raw16.startswith(b"P5\n640 512\n65535\n")
    a16 = np.frombuffer(raw16[len(b"P5\n640 512\n65535\n"):], dtype=">u2").reshape(512, 640)
    assert np.array_equal(a16, clip.read_pgm(out / "u16" / "frame_0003.pgm"))
    raw8 = (out / "u8" / "frame_0003.pgm").read_bytes()
    assert raw8.startswith(b"P5\n640 512\n255\n") and len(raw8) == len(b"P5\n640 512\n255\n") + 640 * 512
    a8 = clip.read_pgm(out / "u8" / "frame_0003.pgm")
    assert np.array_equal(a8, clip.ck_to_u8(a16))          # the documented mapping, exactly
    # physically plausible: cold sky (< -5 degC) at the top, road 0..20 degC at the bottom
    assert np.median(a16[:40]) < clip.c2ck(-5)
    assert clip.c2ck(0) < np.median(a16[-40:]) < clip.c2ck(20)
    assert not list(out.glob("**/.*tmp"))                  # no temporary files left


def test_ground_truth_layout(small_clip):
    out, doc = small_clip
    disk = json.loads((out / "annotations.json").read_text())
    assert disk["annotation"] == disk["annotations"]       # HIT-UAV quirk + the plain COCO key
    assert {c["id"]: c["name"] for c in disk["categories"]}[1] == "Car"
    names = {im["id"]: im["filename"] for im in disk["images"]}
    assert len(names) == 12 and all((out / "u16" / n).is_file() for n in names.values())
    assert all(im["width"] == 640 and im["height"] == 512 for im in disk["images"])
    cars = [a for a in disk["annotation"] if a["category_id"] == 1]
    people = [a for a in disk["annotation"] if a["category_id"] == 0]
    assert len(cars) >= 3 * 12 and people
    for a in disk["annotation"]:
        x, y, w, h = a["bbox"]
        assert 0 <= x and 0 <= y and x + w <= 640 and y + h <= 512 and w >= 12 and h >= 8
        assert a["image_id"] in names and a["area"] == w * h
    for a in cars:
        assert 0.5 <= a["bbox"][3] / a["bbox"][2] <= 0.95     # rear-view car outline
    for a in people:
        assert a["bbox"][3] / a["bbox"][2] > 1.5               # tall: the aspect rule rejects them


def test_cars_have_hot_parts_lamps_are_small(small_clip):
    out, doc = small_clip
    for t in range(0, 12, 4):
        a16 = clip.read_pgm(out / "u16" / f"frame_{t:04d}.pgm")
        for a in doc["annotation"]:
            if a["image_id"] != t or a["category_id"] != 1:
                continue
            x, y, w, h = a["bbox"]
            region = a16[y:y + h, x:x + w]
            # engine / exhaust / tyres above 30 degC, a cabin cooler than that
            assert (region >= 30315).sum() >= 0.2 * w * h
            assert region.max() >= clip.c2ck(36)
            assert region.min() < clip.c2ck(30)
        # hot pixels above the horizon (lamps) come in blobs smaller than the 120 px area rule
        sky = a16[:150] >= 30315
        assert sky.sum() < 120 * 8
