# SPDX-License-Identifier: MIT
"""End-to-end tests of vd_fir_demo (tools/demo): the generated clip in, detections,
JSON Lines per DESIGN.md, annotated PNGs and Table-2 figures out; bad inputs give one
error line, a non-zero exit and no output.

The demo comes from $VD_BUILD_DIR/tools/vd_fir_demo (else the directory of $VD_LIB,
else <repo>/build). Model: the first models/*.vdm if present, else none (the detector
then keeps every refined candidate with score 1.0)."""
import json
import os
from pathlib import Path

import numpy as np
import pytest

from vdtools.data import clip
from vdtools.metrics import evaluate
from vdtools.bindings.clib import REPO
from buildpaths import build_dir, run_demo as run

# Floors measured on the 120-frame clip (seed 1), docs/demo.md. Without a model:
# 16-bit 83.8 % TP / 21.1 % FP, 8-bit 82.1 % TP / 22.4 % FP.
TP_FLOOR_NO_MODEL = 0.78
FP_CEIL_NO_MODEL = 0.30
# With the default model (models/vd_dbn_grey.vdm, crc32 0x16A52326: real frames + synthetic clips of
# seeds 101/102) measured 24.49 % TP on u16 and 54.55 % on u8 (the u16 case is the binding one), so the
# floor is the measured minimum minus a 5-point margin; the 50 % target is not reached (docs/demo.md).
TP_FLOOR_MODEL = 0.19

STATES = {"new", "confirmed", "recovered"}
SOURCES = {"hotspot", "window", "contrast", "cnn"}


@pytest.fixture(scope="session")
def model_args():
    # the demo's own DBN default: models/vd_dbn_grey.vdm, else the first DBN models/*.vdm (format
    # versions 1-2; docs/demo.md). Naming it keeps the paper pipeline even when models/vd_cnn.vdm exists.
    models = [REPO / "models" / "vd_dbn_grey.vdm"]
    models = [m for m in models if m.is_file()] or [
        m for m in sorted((REPO / "models").glob("*.vdm")) if int.from_bytes(m.read_bytes()[4:6], "little") in (1, 2)]
    return (["--model", str(models[0])], True) if models else (["--model", "none"], False)


@pytest.fixture(scope="session")
def clip_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("clip")
    clip.generate(out, frames=120, seed=1)
    return out


def check_jsonl(path, frame_names, width=640, height=512):
    """Validates every line against the DESIGN.md schema; returns the records."""
    recs = [json.loads(line) for line in Path(path).read_text().splitlines()]
    assert [r["frame"] for r in recs] == frame_names
    for i, r in enumerate(recs):
        assert set(r) == {"frame", "seq", "width", "height", "detections"}
        assert r["seq"] == i and r["width"] == width and r["height"] == height
        assert isinstance(r["detections"], list)
        for d in r["detections"]:
            assert set(d) == {"box", "score", "track", "source", "state"}
            x, y, w, h = d["box"]
            assert all(isinstance(v, int) for v in d["box"])
            assert w > 0 and h > 0 and x >= 0 and y >= 0 and x + w <= width and y + h <= height
            assert isinstance(d["score"], float) and 0.0 <= d["score"] <= 1.0
            assert d["track"] is None or (isinstance(d["track"], int) and d["track"] > 0)
            assert d["source"] in SOURCES and d["state"] in STATES
    return recs


@pytest.mark.parametrize("depth", ["u16", "u8"])
def test_clip_detections_and_eval(demo, clip_dir, model_args, tmp_path, depth):
    margs, has_model = model_args
    jl, ev = tmp_path / "det.jsonl", tmp_path / "eval.json"
    p = run(demo, "--input", clip_dir / depth, *margs, "--json", jl, "--eval", clip_dir / "annotations.json",
            "--eval-out", ev, "--quiet")
    names = [f"frame_{t:04d}.pgm" for t in range(120)]
    recs = check_jsonl(jl, names)
    e = json.loads(ev.read_text())
    assert e["frames"] == 120 and e["classes"] == [1, 3] and e["vehicles"] > 300
    floor = TP_FLOOR_MODEL if has_model else TP_FLOOR_NO_MODEL
    assert e["tp_rate"] >= floor, e
    # candidate recall (before verification) is the ceiling of the TP rate
    assert e["vehicles_hot"] + e["vehicles_cold"] == e["vehicles"], e
    assert e["tp_rate"] <= e["candidate_recall"] <= 1.0, e
    assert 0.0 <= e["candidate_recall_hot"] <= 1.0 and 0.0 <= e["candidate_recall_cold"] <= 1.0, e
    assert "candidate recall (ceiling of the TP rate)" in p.stdout
    if not has_model:
        assert e["fp_rate"] <= FP_CEIL_NO_MODEL, e
        # unverified candidates score 1.0; recovered targets (temporal analysis) 0.0
        assert all(d["score"] == (0.0 if d["state"] == "recovered" else 1.0) for r in recs for d in r["detections"])
    # temporal analysis confirms the cars that stay in view
    states = [d["state"] for r in recs for d in r["detections"]]
    assert states.count("confirmed") > len(states) // 2
    # Table 2 figures printed, and equal to the Python evaluation of the JSON Lines
    assert "TP rate" in p.stdout and "FP rate" in p.stdout and "FPPI" in p.stdout
    assert "median time per frame" in p.stdout and "fps" in p.stdout
    py = evaluate.evaluate_jsonl(jl, clip_dir / "annotations.json")
    for k in ("frames", "vehicles", "detections", "ignored_detections", "tp", "fp", "fn"):
        assert py[k] == e[k], k
    for k in ("tp_rate", "fp_rate", "precision", "recall", "fppi"):
        assert py[k] == pytest.approx(e[k], abs=1e-6), k


def test_png_output(demo, clip_dir, model_args, tmp_path):
    out = tmp_path / "out"
    run(demo, "--input", clip_dir / "u16", *model_args[0], "--out", out, "--json", out / "d.jsonl",
        "--frames", 6, "--quiet")
    pngs = sorted(p.name for p in out.glob("*.png"))
    assert pngs == [f"frame_{t:04d}.png" for t in range(6)]
    assert sorted(p.name for p in out.iterdir()) == sorted(pngs + ["d.jsonl"])   # no temporaries left
    cv2 = pytest.importorskip("cv2")
    img = cv2.imread(str(out / "frame_0005.png"), cv2.IMREAD_COLOR)
    assert img.shape == (512, 640, 3)
    # boxes are drawn in colour on a grey frame: yellow (new), green (confirmed) or magenta (recovered)
    b, g, r = img[..., 0].astype(int), img[..., 1].astype(int), img[..., 2].astype(int)
    assert (((g == 255) & (b == 0)) | ((r == 255) & (g == 0) & (b == 255))).sum() > 100
    recs = check_jsonl(out / "d.jsonl", [f"frame_{t:04d}.pgm" for t in range(6)])
    assert any(r["detections"] for r in recs)


def test_yolo_eval_and_classes(demo, clip_dir, tmp_path):
    # the same ground truth as a YOLO folder with MSRS-style class names (2 car)
    doc = json.loads((clip_dir / "annotations.json").read_text())
    lab = tmp_path / "labels"
    lab.mkdir()
    (tmp_path / "classes.txt").write_text("0 person\n1 bicycle\n2 car\n")
    per = {}
    for a in doc["annotation"]:
        if a["category_id"] == 1:
            x, y, w, h = a["bbox"]
            per.setdefault(a["image_id"], []).append(f"2 {(x + w / 2) / 640:.6f} {(y + h / 2) / 512:.6f} "
                                                     f"{w / 640:.6f} {h / 512:.6f}")
    for im in doc["images"][:20]:
        (lab / (Path(im["filename"]).stem + ".txt")).write_text("\n".join(per.get(im["id"], [])) + "\n")
    ev = tmp_path / "e.json"
    p = run(demo, "--input", clip_dir / "u8", "--model", "none", "--eval", lab, "--eval-out", ev, "--frames", 20,
            "--quiet")
    e = json.loads(ev.read_text())
    assert e["classes"] == [2] and e["frames"] == 20 and e["tp_rate"] > 0.6
    assert "classes 2 car" in p.stdout
    # --classes by name and by id on the COCO-like file: Person only -> no car matches
    e2 = tmp_path / "e2.json"
    run(demo, "--input", clip_dir / "u8", "--model", "none", "--eval", clip_dir / "annotations.json",
        "--classes", "Person", "--eval-out", e2, "--frames", 10, "--quiet")
    assert json.loads(e2.read_text())["classes"] == [0]


def test_config_file_and_flags(demo, clip_dir, tmp_path):
    cfg = tmp_path / "cfg.json"
    cfg.write_text(json.dumps({"hot-thr": 250, "min_area": 120, "temporal": False}))
    jl = tmp_path / "d.jsonl"
    run(demo, "--input", clip_dir / "u8", "--model", "none", "--config", cfg, "--json", jl, "--frames", 5, "--quiet")
    recs = check_jsonl(jl, [f"frame_{t:04d}.pgm" for t in range(5)])
    hot = sum(len(r["detections"]) for r in recs)
    # a flag overrides the file: back to the paper's 150 finds the cars again, untracked
    run(demo, "--input", clip_dir / "u8", "--model", "none", "--config", cfg, "--hot-thr", 150, "--json", jl,
        "--frames", 5, "--quiet")
    recs = check_jsonl(jl, [f"frame_{t:04d}.pgm" for t in range(5)])
    assert sum(len(r["detections"]) for r in recs) > hot
    assert all(d["track"] is None and d["state"] == "new" for r in recs for d in r["detections"])


def test_help_lists_options(demo):
    p = run(demo, "--help")
    for opt in ("--input", "--model", "--out", "--json", "--eval", "--classes", "--eval-out", "--config",
                "--raw-size", "--hot-thr", "--thr-mode", "--adaptive-percentile", "--score-thr", "--temporal"):
        assert opt in p.stdout, opt


def raw_and_list_inputs(clip_dir, tmp_path):
    a = np.stack([clip.read_pgm(clip_dir / "u16" / f"frame_{t:04d}.pgm") for t in range(3)])
    raw = tmp_path / "three.y16"
    a.astype("<u2").tofile(raw)
    lst = tmp_path / "frames.txt"
    lst.write_text("# three frames\n" + "".join(f"{clip_dir}/u8/frame_{t:04d}.pgm\n" for t in range(3)))
    return raw, lst


def test_raw_and_list_inputs(demo, clip_dir, tmp_path):
    raw, lst = raw_and_list_inputs(clip_dir, tmp_path)
    jl = tmp_path / "raw.jsonl"
    run(demo, "--input", raw, "--raw-size", "640x512", "--model", "none", "--json", jl, "--quiet")
    recs = [json.loads(x) for x in jl.read_text().splitlines()]
    assert [r["frame"] for r in recs] == ["three.y16#0", "three.y16#1", "three.y16#2"]
    assert sum(len(r["detections"]) for r in recs) > 0
    run(demo, "--input", lst, "--model", "none", "--json", jl, "--quiet")
    check_jsonl(jl, [f"frame_{t:04d}.pgm" for t in range(3)])



def test_16bit_raw_counts_get_each_frames_grey_window(demo, clip_dir, tmp_path):
    """16-bit samples of a camera that is not radiometric land outside the fixed grey window (default TLinear
    0.01 K, 0-51 C): --grey-window auto (the default) maps such frames by their own percentiles and says so, and
    the networks find the vehicles of the 8-bit frame again; --grey-window fixed keeps the black plane (no box)
    with a note naming the options; radiometric frames (the generated u16 clip) and a --calib that maps the
    samples into the window keep the fixed window without a note."""
    import cv2
    outside = "16-bit frame's samples lie outside the fixed grey window"
    src = REPO / "tools" / "demo" / "hit-uav-clip" / "images" / "0_100_50_0_08162.jpg"
    grey = cv2.imread(str(src), cv2.IMREAD_GRAYSCALE)
    counts = grey.astype("<u2") * 64 + 1000            # raw counts 1000..17320 (10..173 K as TLinear)
    raw = tmp_path / "counts.y16"
    raw.write_bytes(counts.tobytes() * 2)
    (tmp_path / "g").mkdir()
    cv2.imwrite(str(tmp_path / "g" / "a.png"), grey)

    def boxes(*args):
        js = tmp_path / "d.jsonl"
        out = run(demo, *args, "--quiet", "--out", tmp_path / "o", "--cnn-full-res", "off", "--json", js).stdout
        return out, [len(json.loads(line)["detections"]) for line in js.read_text().splitlines()]

    base = ["--input", raw, "--raw-size", "640x512"]
    _, eight = boxes("--input", tmp_path / "g")
    out, n = boxes(*base)
    assert "note: 100.0 % of the first " + outside + " (raw 27315..32415): not radiometric" in out
    assert "0.1..99.9 % percentiles (--grey-window auto" in out
    assert eight[0] >= 5 and min(n) >= 0.8 * eight[0], (eight, n)
    out, n = boxes(*base, "--grey-window", "fixed")
    assert "the networks see them as black or white" in out and "--grey-window frame" in out and "--calib" in out
    assert n == [0, 0]
    # gain 5100 / 16320 = 0.3125, offset 27315 - 1000 x 0.3125: the counts fill 0..51 C, the fixed window
    out, n = boxes(*base, "--calib", "0.3125,27002")
    assert outside not in out and min(n) >= 0.8 * eight[0]
    out = run(demo, "--input", clip_dir / "u16", "--frames", "2", "--model", "none", "--quiet", "--out",
              tmp_path / "o2").stdout
    assert outside not in out
    bad = run(demo, *base, "--grey-tail", "50", "--quiet", "--out", tmp_path / "o3", check=False)
    assert bad.returncode != 0 and "grey-tail" in bad.stderr


def test_hotspot_pipeline_on_raw_counts_equals_its_grey_view(demo, tmp_path):
    """The paper pipeline (--sources hotspot) on a camera's raw counts in their own window finds what it finds on
    that window's 8-bit view (numpy's map, vdtools.data.dataset): the same boxes and scores. Until 2026-11-30 the
    hot-spot threshold stayed 30 C's raw value, which raw counts 1000..17320 never reach: no box."""
    import cv2
    from vdtools.data import dataset as D
    grey = cv2.imread(str(REPO / "tools" / "demo" / "hit-uav-clip" / "images" / "0_100_50_0_08162.jpg"),
                      cv2.IMREAD_GRAYSCALE)
    counts = grey.astype("<u2") * 64 + 1000
    raw = tmp_path / "counts.y16"
    raw.write_bytes(counts.tobytes())
    (tmp_path / "v").mkdir()
    cv2.imwrite(str(tmp_path / "v" / "a.png"), D.grey_of_ck(counts, *D.grey_window_ck(counts, 1)))

    def dets(*args):
        js = tmp_path / "d.jsonl"
        run(demo, *args, "--sources", "hotspot", "--temporal", "off", "--quiet", "--out", tmp_path / "o", "--json", js)
        return [(d["box"], d["score"]) for line in js.read_text().splitlines() for d in json.loads(line)["detections"]]

    from_counts = dets("--input", raw, "--raw-size", "640x512")
    assert from_counts and from_counts == dets("--input", tmp_path / "v"), from_counts


def bad_cases(clip_dir, tmp):
    """(name, args) of inputs that must fail cleanly."""
    src = clip_dir / "u8"
    (tmp / "empty").mkdir()
    trunc = tmp / "trunc"
    trunc.mkdir()
    for t in range(3):
        (trunc / f"f{t}.pgm").write_bytes((src / f"frame_{t:04d}.pgm").read_bytes())
    (trunc / "f3.pgm").write_bytes((src / "frame_0003.pgm").read_bytes()[:5000])
    mixed = tmp / "mixed"
    mixed.mkdir()
    (mixed / "a.pgm").write_bytes((src / "frame_0000.pgm").read_bytes())
    (mixed / "b.pgm").write_bytes(b"P5\n64 48\n255\n" + bytes(64 * 48))
    depth = tmp / "depth"
    depth.mkdir()
    (depth / "a.pgm").write_bytes((src / "frame_0000.pgm").read_bytes())
    (depth / "b.pgm").write_bytes((clip_dir / "u16" / "frame_0001.pgm").read_bytes())
    garbage = tmp / "garbage"
    garbage.mkdir()
    (garbage / "x.pgm").write_bytes(b"this is not an image\n")
    (garbage / "y.png").write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(40))
    (tmp / "model.vdm").write_bytes(b"VDMF" + bytes(200))
    (tmp / "bad.json").write_text('{"images": [1, 2,]}')
    (tmp / "notcoco.json").write_text('{"images": []}')
    (tmp / "cfg.json").write_text('{"hot-thr": 999}')
    (tmp / "cfg2.json").write_text('{"no-such-setting": 1}')
    (tmp / "odd.y16").write_bytes(bytes(1001))
    ok = ["--input", src, "--frames", "3"]
    return [
        ("missing input", ["--input", tmp / "nope"]),
        ("empty directory", ["--input", tmp / "empty"]),
        ("truncated image", ["--input", trunc]),
        ("mixed sizes", ["--input", mixed]),
        ("mixed bit depths", ["--input", depth]),
        ("not an image", ["--input", garbage]),
        ("raw without size", ["--input", tmp / "odd.y16"]),
        ("raw of the wrong size", ["--input", tmp / "odd.y16", "--raw-size", "640x512"]),
        ("bad model", ok + ["--model", tmp / "model.vdm"]),
        ("missing model", ok + ["--model", tmp / "nope.vdm"]),
        ("no device", ["--input", "/dev/video99"]),
        ("bad annotations", ok + ["--eval", tmp / "bad.json"]),
        ("annotations without boxes", ok + ["--eval", tmp / "notcoco.json"]),
        ("missing annotations", ok + ["--eval", tmp / "nope.json"]),
        ("bad config value", ok + ["--config", tmp / "cfg.json"]),
        ("unknown config key", ok + ["--config", tmp / "cfg2.json"]),
        ("bad flag value", ok + ["--score-thr", "2"]),
        ("confirm band upside down", ok + ["--track-confirm", "0.3,0.4"]),
        ("confirm above 1", ok + ["--track-confirm", "1.2"]),
        ("unknown flag", ok + ["--frobnicate", "1"]),
    ]


def test_bad_inputs_one_line_no_output(demo, clip_dir, tmp_path):
    for name, args in bad_cases(clip_dir, tmp_path):
        out = tmp_path / ("out-" + name.replace(" ", "_"))
        jl = out / "d.jsonl"
        p = run(demo, *args, "--out", out, "--json", jl, "--eval-out", out / "e.json", check=False)
        lines = [x for x in p.stderr.splitlines() if x.startswith("vd_fir_demo: error:")]
        assert p.returncode != 0, name
        assert len(lines) == 1, (name, p.stderr)
        assert lines[0].rstrip().endswith(")"), (name, lines)    # "(<vd_status_str text>)"
        assert not out.exists(), (name, list(out.iterdir()))    # nothing written half way
        q = run(demo, *args, "--quiet", check=False)
        assert q.returncode != 0 and len(q.stderr.strip().splitlines()) == 1, (name, q.stderr)


def test_unreadable_file(demo, clip_dir, tmp_path):
    if os.geteuid() == 0:
        pytest.skip("running as root: permissions do not stop reads")
    d = tmp_path / "locked"
    d.mkdir()
    f = d / "a.pgm"
    f.write_bytes((clip_dir / "u8" / "frame_0000.pgm").read_bytes())
    f.chmod(0)
    p = run(demo, "--input", d, "--quiet", check=False)
    assert p.returncode != 0 and len(p.stderr.strip().splitlines()) == 1


def test_json_readers_survive_hostile_files(demo, clip_dir, tmp_path):
    """--eval and --config parse outside files: truncated, bit-flipped, deeply nested
    or huge-number JSON gives a clean status (exit 0, 1 or 2, one line), never a crash."""
    base = (clip_dir / "annotations.json").read_bytes()[:6000]
    # a small but complete COCO-like file to mutate
    doc = json.loads((clip_dir / "annotations.json").read_text())
    small = json.dumps({"categories": doc["categories"], "images": doc["images"][:2],
                        "annotation": [a for a in doc["annotation"] if a["image_id"] < 2]}).encode()
    rng = np.random.default_rng(7)
    cases = [small[:n] for n in rng.integers(0, len(small), 12)] + [base]
    for _ in range(20):
        b = bytearray(small)
        for k in rng.integers(0, len(b), 3):
            b[k] = int(rng.integers(0, 256))
        cases.append(bytes(b))
    cases += [b"[" * 100000, b'{"a":' * 5000, b'{"images": [], "annotation": [{"bbox": [1e999, 0, 1, 1]}]}',
              b'"\\ud800"', b'{"images": [{"filename": "x", "id": 1e300}], "annotation": []}', b"\xff\xfe{}", b""]
    f = tmp_path / "a.json"
    for i, c in enumerate(cases):
        f.write_bytes(c)
        for args in (["--eval", f], ["--config", f]):
            p = run(demo, "--input", clip_dir / "u8", "--model", "none", "--frames", 2, "--quiet", *args, check=False)
            assert p.returncode in (0, 1, 2), (i, args, p.returncode, p.stderr[-500:])
            assert len(p.stderr.strip().splitlines()) <= 1, (i, p.stderr[-500:])


def test_help_options_in_demo_doc(demo):
    """Every option `vd_fir_demo --help` lists has a place in docs/demo.md (the DESIGN.md contract: `--help`
    lists all; the doc's option tables follow it, e.g. issue 38's --track-scores and --track-coast)."""
    import re
    import subprocess
    out = subprocess.run([str(demo), "--help"], capture_output=True, text=True, check=True).stdout
    opts = sorted(set(re.findall(r"^\s+--([a-z0-9][a-z0-9-]*)", out, flags=re.M)))
    assert "track-scores" in opts and "track-coast" in opts
    doc = (REPO / "docs" / "demo.md").read_text()
    missing = [o for o in opts if not re.search(r"(--|`)" + re.escape(o) + r"\b", doc)]
    assert not missing, f"options of --help missing in docs/demo.md: {missing}"
