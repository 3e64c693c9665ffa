# SPDX-License-Identifier: MIT
"""The C detector through vdtools.bindings.detector: candidate-stage counts against an OpenCV/numpy
oracle on real MSRS / HIT-UAV frames, synthetic scenes, and the temporal exp tables."""
import glob

import numpy as np
import pytest

cv2 = pytest.importorskip("cv2")

from vdtools.bindings import detector as vdet  # noqa: E402


def oracle_counts(img, thr):
    """hot pixels, components, kept by the paper's rules (cv2 + numpy)."""
    mask = (img >= thr).astype(np.uint8)
    n, _, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    kept = 0
    for x, y, w, h, area in stats[1:]:
        aspect_q8 = (256 * h + w // 2) // w   # round-half-up(256 h / w)
        if area >= 120 and 77 <= aspect_q8 <= 384:
            kept += 1
    return int(mask.sum()), n - 1, kept


def adaptive_oracle(img, permille=990, floor=96):
    hist = np.bincount(img.ravel(), minlength=256)
    target = -(-img.size * permille // 1000)
    t = int(np.searchsorted(np.cumsum(hist), target))
    return max(floor, t)


def real_frames(data_dir, n=12):
    files = sorted(glob.glob(str(data_dir / "msrs" / "**" / "*N.png"), recursive=True))[:n]
    files += sorted(glob.glob(str(data_dir / "hit-uav" / "frames" / "images" / "*.jpg")))[:n]
    if not files:
        pytest.skip(f"no frames found under {data_dir}")
    return files


@pytest.mark.parametrize("mode", ["constant", "adaptive"])
def test_candidate_stage_matches_opencv_on_real_frames(vdlib, data_dir, mode):
    det = vdet.Detector(max_width=640, max_height=512, thr_mode=mode, max_components=4096)
    for f in real_frames(data_dir):
        img = cv2.imread(f, cv2.IMREAD_GRAYSCALE)
        dets, st = det.run(img)
        thr = 150 if mode == "constant" else adaptive_oracle(img)
        assert st["hot_thr_u8"] == thr, f
        hot, comps, kept = oracle_counts(img, thr)
        assert (st["hot_pixels"], st["components"], st["kept"]) == (hot, comps, kept), f
        m = (img >= thr).astype(np.int8)
        assert st["runs"] == int((np.diff(np.pad(m, ((0, 0), (1, 0))), axis=1) == 1).sum()), f
        assert st["overflow_runs"] == 0, f
        assert st["refined"] <= min(kept, 64)
        assert len(dets) == st["verified"] - st["suppressed"] - st["overflow_detections"]
        for d in dets:
            x, y, w, h = d["box"]
            cx, cy, cw, ch = d["candidate"]
            assert w > 0 and h > 0 and cx <= x and cy <= y and x + w <= cx + cw and y + h <= cy + ch
            assert d["score_q8"] == 255 and d["flags"] & vdet.FLAG_UNVERIFIED


def synthetic_scene(u16=False):
    img = np.full((120, 160), 40, np.uint8)
    img[30:50, 20:50] = 180          # car 30 x 20
    img[10:16, 100:106] = 250        # lamp, 36 px
    img[20:80, 130:136] = 220        # pole, h/w = 10
    if not u16:
        return img
    # 40 grey -> 20 C, hot -> 40 C, in centi-kelvin (TLinear raw)
    return np.where(img > 100, 27315 + 4000, 27315 + 2000).astype(np.uint16)


@pytest.mark.parametrize("u16", [False, True])
def test_synthetic_car_kept_lamp_pole_rejected(vdlib, u16):
    dets, st = vdet.detect(synthetic_scene(u16))
    assert st["components"] == 3 and st["kept"] == 1
    assert [d["box"] for d in dets] == [[20, 30, 30, 20]]


def test_capacity_reported(vdlib):
    img = np.full((120, 160), 40, np.uint8)
    for x in (5, 60, 110):
        img[5:25, x:x + 30] = 200
    det = vdet.Detector(max_width=160, max_height=120, max_detections=2, max_candidates=8)
    dets, st = det.run(img)
    assert st["status"] == "VD_ERR_CAPACITY" and len(dets) == 2 and st["overflow_detections"] == 1


def test_run_budget_reported(vdlib):
    img = np.full((120, 160), 40, np.uint8)
    img[0:20, ::2] = 220                  # 80 runs per row
    img[70:90, 60:90] = 200               # a car below the noise
    dets, st = vdet.Detector(max_width=160, max_height=120).run(img)
    assert st["status"] == "VD_OK" and st["runs"] == 20 * 80 + 20 and len(dets) == 1
    dets, st = vdet.Detector(max_width=160, max_height=120, max_runs=1500).run(img)
    assert st["status"] == "VD_ERR_CAPACITY" and st["overflow_runs"] == 120 - 18 and dets == []


def test_default_workspace_within_goal(vdlib):
    assert 228096 <= vdet.workspace_size(640, 512) <= 228496 <= 256 * 1024
    # windows share the overlay; contrast brings its own whole-frame workspace
    assert vdet.workspace_size(640, 512, sources="hotspot,window") == vdet.workspace_size(640, 512)


def test_bad_config_rejected(vdlib):
    with pytest.raises(vdet.clib.VdError):
        vdet.Detector(max_width=160, max_height=120, window=4)


def test_temporal_states(vdlib):
    det = vdet.Detector(max_width=160, max_height=120, temporal=True)
    states = []
    for t in range(4):
        img = np.full((120, 160), 40, np.uint8)
        img[30:50, 20 + 2 * t:50 + 2 * t] = 180
        dets, _ = det.run(img)
        states.append(dets[0]["state"])
    assert states == ["new", "new", "confirmed", "confirmed"]


# ---------------------------------------------------------------- candidate sources (issue 7)

def cell_levels(img, boxes, cell=4):
    """numpy oracle of the window pre-filter: floor(std) of the rounded 4x4-cell means inside each box."""
    h, w = img.shape
    gh, gw = h // cell, w // cell
    g = (img[:gh * cell, :gw * cell].reshape(gh, cell, gw, cell).astype(np.int64).sum(axis=(1, 3)) + 8) // 16
    out = []
    for x, y, bw, bh in boxes:
        x0, x1 = (x + cell - 1) // cell, min((x + bw) // cell, gw)
        y0, y1 = (y + cell - 1) // cell, min((y + bh) // cell, gh)
        x0 = x0 if x0 < x1 else max(x1 - 1, 0)
        y0 = y0 if y0 < y1 else max(y1 - 1, 0)
        x1, y1 = max(x1, x0 + 1), max(y1, y0 + 1)
        v = g[y0:y1, x0:x1]
        n = v.size
        var = (n * int((v * v).sum()) - int(v.sum()) ** 2) // (n * n)
        out.append(min(255, int(np.floor(np.sqrt(var)))))   # float sqrt is exact enough for var < 2^24
    return np.array(out)


def test_window_source_matches_generator_and_prefilter_oracle(vdlib, data_dir):
    from vdtools.bindings import sources as S
    files = sorted(glob.glob(str(data_dir / "msrs" / "images" / "*N.png")))[:2]
    files += sorted(glob.glob(str(data_dir / "hit-uav" / "frames" / "images" / "*.jpg")))[:1]
    if not files:
        pytest.skip(f"no frames found under {data_dir}")
    for f in files:
        img = cv2.imread(f, cv2.IMREAD_GRAYSCALE)
        preset = "msrs" if "msrs" in f else "hit"
        wins = S.windows(img.shape[1], img.shape[0], preset=preset)
        lv = cell_levels(img, wins)
        budget = 300
        det = vdet.Detector(max_width=640, max_height=512, sources="window", max_candidates=budget,
                            max_detections=budget, nms_iou_q15=32768, dedup_iou_q15=32768, win_min_std_u8=6,
                            windows=dict(preset_name=preset, frame_h=img.shape[0]))
        dets, st = det.run(img)
        assert st["windows"] == len(wins) and st["windows_passed"] == int((lv >= 6).sum()), f
        # reference: the `budget` highest levels, ties in generator order (stable sort)
        order = np.argsort(-np.where(lv >= 6, lv, -1), kind="stable")[:min(budget, int((lv >= 6).sum()))]
        want = sorted(map(tuple, wins[np.sort(order)]))
        got = sorted(tuple(d["box"]) for d in dets)
        assert got == want, f
        assert all(d["source"] == "window" for d in dets)


def test_contrast_source_matches_contrast_candidates(vdlib, data_dir):
    from vdtools.bindings import sources as S
    files = sorted(glob.glob(str(data_dir / "hit-uav" / "frames" / "images" / "*.jpg")))[:3]
    if not files:
        pytest.skip(f"no frames found under {data_dir}")
    for f in files:
        img = cv2.imread(f, cv2.IMREAD_GRAYSCALE)
        ref = S.contrast_candidates(img, cap=256)
        det = vdet.Detector(max_width=640, max_height=512, sources="contrast", max_candidates=256,
                            max_detections=256, nms_iou_q15=32768, dedup_iou_q15=32768)
        dets, st = det.run(img)
        assert st["cand_contrast"] == len(ref) == len(dets), f
        assert [d["box"] for d in dets] == [[int(c["x"]), int(c["y"]), int(c["w"]), int(c["h"])] for c in ref]
        assert all(d["source"] == "contrast" for d in dets)


def test_sources_merge_dedup(vdlib):
    img = np.full((120, 160), 60, np.uint8)
    img[30:50, 20:50] = 200     # hot car
    img[60:76, 100:124] = 10    # cold car
    det = vdet.Detector(max_width=160, max_height=120, sources="all", max_candidates=200, max_detections=200,
                        nms_iou_q15=32768, dedup_iou_q15=16384)
    dets, st = det.run(img)
    assert st["cand_hotspot"] == 1 and st["cand_contrast"] >= 1 and st["cand_window"] >= 1
    assert len(dets) == st["cand_hotspot"] + st["cand_contrast"] + st["cand_window"]
    from vdtools.evaluation.recall import iou_matrix
    m = iou_matrix([d["box"] for d in dets], [d["box"] for d in dets])
    np.fill_diagonal(m, 0)
    assert m.max() <= 0.5 + 1e-6
    assert {d["source"] for d in dets} == {"hotspot", "contrast", "window"}


def test_exp_tables_match_c_source():
    from vdtools.bindings.clib import REPO
    src = (REPO / "lib" / "src" / "detector" / "temporal.c").read_text()
    frac, ints = vdet.exp_tables()
    for v in frac + ints:
        assert f"{v}u" in src


def _demo_exe():
    import os
    from pathlib import Path
    b = os.environ.get("VD_BUILD_DIR") or (str(Path(os.environ["VD_LIB"]).parent) if os.environ.get("VD_LIB") else None)
    exe = Path(b or vdet.clib.REPO / "build") / "tools" / "vd_fir_demo"
    if not exe.is_file():
        pytest.skip(f"vd_fir_demo not built at {exe}")
    return exe


def test_demo_sources_flags_and_config(vdlib, tmp_path):
    import json
    import subprocess
    img = np.full((120, 160), 60, np.uint8)
    img[30:50, 20:50] = 200
    img[60:76, 100:124] = 10
    (tmp_path / "f.pgm").write_bytes(b"P5\n160 120\n255\n" + img.tobytes())
    exe = _demo_exe()
    base = [str(exe), "--input", str(tmp_path / "f.pgm"), "--model", "none", "--temporal", "off", "--quiet"]

    def sources(*args):
        out = tmp_path / "d.jsonl"
        p = subprocess.run(base + ["--json", str(out), *args], capture_output=True, text=True, timeout=60)
        assert p.returncode == 0, p.stderr
        return {d["source"] for line in out.read_text().splitlines() for d in json.loads(line)["detections"]}

    assert sources() == {"hotspot"}
    assert sources("--sources", "hotspot,contrast", "--nms-iou", "1") == {"hotspot", "contrast"}
    assert sources("--sources", "all", "--window-bands", "0:119:12:40", "--window-stride", "0.5",
                   "--max-candidates", "100", "--max-detections", "100", "--nms-iou", "1") == \
        {"hotspot", "contrast", "window"}
    cfg = tmp_path / "c.json"
    cfg.write_text(json.dumps({"sources": "window", "window-preset": "table1", "window-min-std": 2,
                               "max-candidates": 50, "max-detections": 50}))
    assert sources("--config", str(cfg)) == {"window"}
    for bad in (["--sources", "lidar"], ["--window-bands", "10:5:1:2"], ["--window-preset", "x"]):
        p = subprocess.run(base + bad, capture_output=True, text=True, timeout=60)
        assert p.returncode == 2 and p.stderr.count("\n") == 1, (bad, p.stderr)
