# SPDX-License-Identifier: MIT
"""The detector's CNN source end to end: `vd_fir_demo --sources cnn` against the Python mirror of the
detector (vdtools.evaluation.cnn_detector: cnn_eval's network input, the numpy integer reference, cnn_eval.Int8's
clipping, the C suppression rule), box for box and Q8 score for Q8 score -- on random networks over the
bundled clip's frames and odd crops of them (no data needed), and on real test-split frames with
models/vd_cnn.vdm (skipped without ../shared/data or that model). Also: the demo's CNN options and
defaults, and the ctypes mirror of vd_detector_cfg_t / vd_detector_stats_t / vd_detection_t
(vdtools.bindings.detector) against the C layout.

Frames are handed to the demo as PGM files written from the very arrays Python uses, so JPEG decoders
(stb_image in the demo, libjpeg in OpenCV) cannot make the two sides differ."""
import ctypes as C
import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from vdtools.data import clip
from vdtools.evaluation import cnn_detector as CDet
from vdtools.formats import cnn_ref as R
from vdtools.formats import cnn_vdm as V
from vdtools.bindings import detector as vdet
from vdtools.bindings.clib import REPO

from realdata import frames_in_test_split
from buildpaths import build_dir, run_demo as run

MODEL = REPO / "models" / "vd_cnn.vdm"
MODEL2 = REPO / "models" / "vd_cnn2.vdm"   # the second network of the shipped pair (cfg.cnn_model2)


def demo_dets(jsonl):
    """{frame name: [((x, y, w, h), score_q8)]} of a JSON Lines file (the demo prints score_q8 / 255
    with 3 decimals: round(score * 255) is exact)."""
    out = {}
    for line in Path(jsonl).read_text().splitlines():
        r = json.loads(line)
        dets = []
        for d in r["detections"]:
            assert d["source"] == "cnn" and d["track"] is None and d["state"] == "new", d
            dets.append((tuple(d["box"]), int(round(d["score"] * 255))))
        out[r["frame"]] = dets
    return out


def write_frames(directory, frames):
    """{name: image} as 8-bit PGMs in directory (created)."""
    directory.mkdir(parents=True, exist_ok=True)
    for name, img in frames.items():
        clip.write_pgm(directory / name, np.ascontiguousarray(img))
    return directory


def compare(dets, frames, desc, first_diff_msg="", **kw):
    """Asserts demo detections == vdtools.evaluation.cnn_detector.detect for every frame; returns the count."""
    n = 0
    for name, img in frames.items():
        want = CDet.detect(desc, img, **kw)
        assert dets[name] == want, f"{first_diff_msg}{name} ({img.shape[1]}x{img.shape[0]}): demo {dets[name]} " \
                                   f"vs Python {want}"
        n += len(want)
    return n


def demo_on_clip_sets(demo, clip_frames, net, tmp_path, flip):
    """vd_fir_demo (cnn source, temporal off, --cnn-flip flip) on every frame set of clip_frames, at the
    network header's threshold and at --cnn-thr 0.62: yields (frames, thr, demo detections, cfg Q15 threshold)."""
    for tag, frames in clip_frames.items():
        src = write_frames(tmp_path / f"{tag}_{flip}", frames)
        for thr in (None, 0.62):
            jl = tmp_path / f"{tag}_{flip}_{thr}.jsonl"
            extra = [] if thr is None else ["--cnn-thr", thr]
            run(demo, "--input", src, "--sources", "cnn", "--cnn-model", net, "--model", "none", "--temporal", "off",
                "--cnn-flip", flip, "--json", jl, "--quiet", *extra)
            yield frames, thr, demo_dets(jl), 0 if thr is None else int(round(thr * 32768))


# ------------------------------------------------------------------ random networks, the bundled clip
@pytest.fixture(scope="module")
def clip_frames(tmp_path_factory):
    """Three 640x512 8-bit clip frames and odd crops of them: {size tag: {name: image}}."""
    out = tmp_path_factory.mktemp("cnnclip")
    clip.generate(out, frames=3, seed=4)
    full = {p.name: clip.read_pgm(p) for p in sorted((out / "u8").glob("*.pgm"))}
    sets = {"640x512": full}
    for w, h, x0, y0 in ((203, 157, 101, 77), (97, 61, 300, 200), (34, 18, 5, 9)):
        sets[f"{w}x{h}"] = {k: v[y0:y0 + h, x0:x0 + w] for k, v in full.items()}
    return sets


@pytest.fixture(scope="module")
def random_net(tmp_path_factory):
    rng = np.random.default_rng(2024)
    d = R.random_model(rng, out_channels=5, width=(6, 8, 8, 6), name="det_random")
    d["score_threshold_q"] = 20
    path = tmp_path_factory.mktemp("cnnnet") / "net.vdm"
    path.write_bytes(V.pack(d))
    return d, path


def test_random_network_on_clip_frames(demo, clip_frames, random_net, tmp_path):
    """Half resolution, edge padding to A = 8 (real convolutions see the padding), decoding, clipping,
    the candidate budget and suppression: demo == Python on full and odd-sized frames, at the header's
    threshold and at --cnn-thr."""
    d, net = random_net
    mp = int(d["max_peaks"])
    total = 0
    for frames, thr, dets, q15 in demo_on_clip_sets(demo, clip_frames, net, tmp_path, "off"):
        total += compare(dets, frames, d, f"thr {thr}: ", score_thr_q15=q15, max_candidates=mp, max_detections=mp)
    assert total > 20, "the random network should find peaks on the clip"
    # A version-3 --model is the CNN model, and without --sources it selects the cnn source.
    frames = clip_frames["203x157"]
    jl = tmp_path / "convenience.jsonl"
    p = run(demo, "--input", tmp_path / "203x157_off", "--model", net, "--temporal", "off", "--json", jl)
    assert "sources cnn" in p.stderr and "CNN model" in p.stderr, p.stderr
    # ... with the demo's default fused flip pass and room for both passes' boxes
    compare(demo_dets(jl), frames, d, "--model: ", max_candidates=2 * mp, max_detections=2 * mp, flip=True)


def test_budgets_and_suppression_rule(demo, clip_frames, random_net, tmp_path):
    """Explicit budgets and overlap threshold: the detector keeps the best max_candidates boxes and
    suppresses with the Q15 rule (vdtools.evaluation.cnn_detector.nms_q15)."""
    d, net = random_net
    frames = clip_frames["640x512"]
    src = write_frames(tmp_path / "f", frames)
    jl = tmp_path / "b.jsonl"
    p = run(demo, "--input", src, "--sources", "cnn", "--cnn-model", net, "--model", "none", "--temporal", "off",
            "--max-candidates", 7, "--max-detections", 5, "--nms-iou", 0.2, "--cnn-thr", 0.001, "--cnn-flip", "off",
            "--json", jl,
            "--quiet")
    assert "budget" in p.stdout   # more peaks than 7: VD_ERR_CAPACITY noted, results valid
    compare(demo_dets(jl), frames, d, score_thr_q15=int(round(0.001 * 32768)), max_candidates=7, max_detections=5,
            nms_iou_q15=int(round(0.2 * 32768)))


def _flip_changes_something(frames, d, **kw):
    """Frames whose detections the flip pass changes (the test must not be vacuous)."""
    return sum(CDet.detect(d, img, flip=True, **kw) != CDet.detect(d, img, **kw) for img in frames.values())


def test_flip_random_network_on_clip_frames(demo, clip_frames, random_net, tmp_path):
    """--cnn-flip on, the fused flip pass: a second pass on the mirrored half-resolution plane (mirrored before
    the padding; odd widths leave the last frame column out of it), both passes decoded at the lower
    threshold, boxes mirrored back, the two sets fused (pairs averaged, the rest at half score, fused scores
    below the threshold dropped), then suppression: demo == Python (cnn_detector.detect(flip=True)) on full
    and odd-sized frames, at the header's threshold and at --cnn-thr, with the demo's default budgets (twice
    the top-K with the flip pass); a bare --cnn-flip and the config key do the same."""
    d, net = random_net
    mp = int(d["max_peaks"])
    total = changed = 0
    for frames, thr, dets, q15 in demo_on_clip_sets(demo, clip_frames, net, tmp_path, "on"):
        kw = dict(score_thr_q15=q15, max_candidates=2 * mp, max_detections=2 * mp)
        total += compare(dets, frames, d, f"flip, thr {thr}: ", flip=True, **kw)
        changed += _flip_changes_something(frames, d, **kw)
    assert total > 20 and changed >= 4, (total, changed)
    frames = clip_frames["203x157"]
    cfg = tmp_path / "flip.json"
    cfg.write_text(json.dumps({"cnn_flip": True}))
    for args in (["--cnn-flip"], ["--config", cfg]):
        jl = tmp_path / "bare.jsonl"
        p = run(demo, "--input", tmp_path / "203x157_on", "--sources", "cnn", "--cnn-model", net, "--model", "none",
                "--temporal", "off", "--json", jl, *args)
        assert "(+ flip pass)" in p.stderr, p.stderr
        compare(demo_dets(jl), frames, d, f"{args}: ", flip=True, max_candidates=2 * mp, max_detections=2 * mp)
    # the last --cnn-flip wins: off gives one pass (the demo default is on)
    jl = tmp_path / "off.jsonl"
    p = run(demo, "--input", tmp_path / "203x157_on", "--sources", "cnn", "--cnn-model", net, "--model", "none",
            "--temporal", "off", "--json", jl, "--cnn-flip", "on", "--cnn-flip", "off")
    assert "(+ flip pass)" not in p.stderr, p.stderr
    compare(demo_dets(jl), frames, d, "off: ", max_candidates=mp, max_detections=mp)


def test_flip_budgets(demo, clip_frames, random_net, tmp_path):
    """With explicit budgets the fused boxes keep their order (those of the first pass's boxes first, then the
    mirrored pass's leftovers) until the budget is full."""
    d, net = random_net
    frames = clip_frames["640x512"]
    src = write_frames(tmp_path / "f", frames)
    for mc in (7, 150):
        jl = tmp_path / f"b{mc}.jsonl"
        p = run(demo, "--input", src, "--sources", "cnn", "--cnn-model", net, "--model", "none", "--temporal", "off",
                "--max-candidates", mc, "--max-detections", 5, "--nms-iou", 0.2, "--cnn-thr", 0.001,
                "--cnn-flip", "on", "--json", jl, "--quiet")
        assert "budget" in p.stdout, p.stdout   # VD_ERR_CAPACITY noted (candidates at 7, detections at 5)
        compare(demo_dets(jl), frames, d, f"max-candidates {mc}: ", score_thr_q15=int(round(0.001 * 32768)),
                max_candidates=mc, max_detections=5, nms_iou_q15=int(round(0.2 * 32768)), flip=True)


def test_nms_rule_is_q15():
    """The C rule differs from a float IoU > 0.5 just above 0.5 (unions above 16384 px)."""
    a, b = (0, 0, 200, 100), (0, 0, 200, 201)   # IoU = 20000 / 40200 = 0.4975 -> below
    assert CDet.iou_q15(a, b) == (20000 << 15) // 40200
    # inter 16385 px, union 32769 px: IoU 0.500015 > 0.5 in float, Q15 floor 16384 -> not > 16384
    a, b = (0, 0, 16385, 1), (0, 0, 32769, 1)
    assert 16385 / 32769 > 0.5 and CDet.iou_q15(a, b) == 16384
    assert len(CDet.nms_q15([(a, 200), (b, 100)])) == 2
    assert CDet.score_q8(32768) == 255 and CDet.score_q8(64) == 1 and CDet.score_q8(63) == 0


# ------------------------------------------------------------------ cfg.cnn_model2, the pair of networks
def test_pair_random_networks_on_clip_frames(demo, clip_frames, random_net, tmp_path):
    """--cnn-model2: each network decodes at the lower score of P = 2 (4 with --cnn-flip) passes, its flip
    passes fused without a threshold, then the two networks' boxes fused at T: demo == Python
    (cnn_detector.detect(desc2=...)) on full and odd-sized frames, at the header's threshold and at --cnn-thr,
    with the demo's default budgets for a pair (the larger top-K, 32 detections); the pair changes the
    detections (not vacuous); --cnn-model2 none is one network."""
    d, net = random_net
    d2 = R.random_model(np.random.default_rng(77), out_channels=5, width=(6, 8, 8, 6), name="det_random2")
    d2["score_threshold_q"] = 10
    d2["max_peaks"] = 40
    net2 = tmp_path / "net2.vdm"
    net2.write_bytes(V.pack(d2))
    k1 = int(d["max_peaks"])   # > 40: the demo's pair budgets are the larger top-K and 32 detections
    total = changed = 0
    for flip in ("off", "on"):
        for tag, frames in clip_frames.items():
            src = write_frames(tmp_path / f"pair_{tag}_{flip}", frames)
            for thr in (None, 0.62):
                jl = tmp_path / f"pair_{tag}_{flip}_{thr}.jsonl"
                extra = [] if thr is None else ["--cnn-thr", thr]
                p = run(demo, "--input", src, "--sources", "cnn", "--cnn-model", net, "--cnn-model2", net2, "--model",
                        "none", "--temporal", "off", "--cnn-flip", flip, "--json", jl, *extra)
                assert f"{net} + {net2}" in p.stderr, p.stderr
                kw = dict(score_thr_q15=0 if thr is None else int(round(thr * 32768)), max_candidates=k1,
                          max_detections=32, flip=flip == "on")
                total += compare(demo_dets(jl), frames, d, f"pair, flip {flip}, thr {thr}: ", desc2=d2, **kw)
                changed += sum(CDet.detect(d, img, desc2=d2, **kw) != CDet.detect(d, img, **kw)
                               for img in frames.values())
    assert total > 20 and changed >= 4, (total, changed)
    frames = clip_frames["203x157"]
    jl = tmp_path / "pair_none.jsonl"
    p = run(demo, "--input", tmp_path / "pair_203x157_off", "--sources", "cnn", "--cnn-model", net, "--cnn-model2",
            "none", "--model", "none", "--temporal", "off", "--cnn-flip", "off", "--json", jl)
    assert " + " not in p.stderr.split("CNN model")[1].split(";")[0], p.stderr
    compare(demo_dets(jl), frames, d, "none: ", max_candidates=k1, max_detections=k1)
    q = run(demo, "--input", tmp_path / "pair_203x157_off", "--quiet", "--cnn-model", net, "--cnn-model2",
            tmp_path / "nope.vdm", "--model", "none", check=False)
    assert q.returncode != 0 and "--cnn-model2" in q.stderr, q.stderr
    # the config file takes the same key
    cfg = tmp_path / "pair.json"
    cfg.write_text(json.dumps({"cnn_model2": str(net2), "cnn-flip": False}))
    jl = tmp_path / "pair_cfg.jsonl"
    p = run(demo, "--input", tmp_path / "pair_203x157_off", "--sources", "cnn", "--cnn-model", net, "--model", "none",
            "--temporal", "off", "--config", cfg, "--json", jl)
    assert f"{net} + {net2}" in p.stderr, p.stderr
    compare(demo_dets(jl), frames, d, "config: ", desc2=d2, max_candidates=k1, max_detections=32)


@pytest.mark.parametrize("flip", [False, True], ids=["one_pass", "flip"])
def test_pair_real_frames_equal_python(demo, data_dir, tmp_path, flip):
    """The shipped pair (models/vd_cnn.vdm + models/vd_cnn2.vdm, the demo's default) on real test-split
    frames: demo == cnn_detector.detect(desc2=...), and cnn_eval.Pair (numpy reference) == cnn_detector.pair_boxes."""
    if not (MODEL.is_file() and MODEL2.is_file()):
        pytest.skip("the shipped pair (models/vd_cnn.vdm, models/vd_cnn2.vdm) is not committed")
    from vdtools.evaluation import cnn_eval
    desc, desc2 = V.unpack(MODEL.read_bytes()), V.unpack(MODEL2.read_bytes())
    kw = dict(max_candidates=max(int(desc["max_peaks"]), int(desc2["max_peaks"])), max_detections=32, flip=flip)
    pair = cnn_eval.Pair(cnn_eval.Int8(MODEL, backend="ref", flip=flip), cnn_eval.Int8(MODEL2, backend="ref", flip=flip))
    total = 0
    for tag, frames in _real_frames(data_dir, per_family=3).items():
        src = write_frames(tmp_path / tag, frames)
        jl = tmp_path / f"{tag}.jsonl"
        # the demo's defaults choose the pair: only the flip setting is named
        run(demo, "--input", src, "--temporal", "off", "--json", jl, "--quiet", "--cnn-flip", "on" if flip else "off")
        total += compare(demo_dets(jl), frames, desc, f"pair flip {flip}: ", desc2=desc2, **kw)
        for name, img in list(frames.items())[:2]:
            h, w = img.shape
            got = [(b, int(round(s * 32768))) for b, s in pair(img, w, h, score_thr_q15=11469)]
            assert got == CDet.pair_boxes(desc, desc2, img, score_thr_q15=11469, flip=flip), name
    assert total > 0


def _pair_at_res(demo, tmp_path, frames, res, demo_args, label):
    """The shipped pair with flip passes at cfg.cnn_res = res (1 full, 2 quarter) on frames {name: image}: the
    demo's detections (demo_args set the resolution) == cnn_detector.detect, and cnn_eval.Pair ==
    cnn_detector.pair_boxes, which differ from half resolution's on the first two frames. Returns the demo's box
    count."""
    from vdtools.evaluation import cnn_eval
    desc, desc2 = V.unpack(MODEL.read_bytes()), V.unpack(MODEL2.read_bytes())
    kw = dict(max_candidates=max(int(desc["max_peaks"]), int(desc2["max_peaks"])), max_detections=32, flip=True,
              full_res=res)
    pair = cnn_eval.Pair(cnn_eval.Int8(MODEL, backend="ref", flip=True, full_res=res),
                         cnn_eval.Int8(MODEL2, backend="ref", flip=True, full_res=res))
    src = write_frames(tmp_path / f"res{res}", frames)
    jl = tmp_path / f"res{res}.jsonl"
    run(demo, "--input", src, "--temporal", "off", "--json", jl, "--quiet", *demo_args)
    total = compare(demo_dets(jl), frames, desc, label, desc2=desc2, **kw)
    for name, img in list(frames.items())[:2]:
        h, w = img.shape
        got = [(b, int(round(s * 32768))) for b, s in pair(img, w, h, score_thr_q15=11469)]
        assert got == CDet.pair_boxes(desc, desc2, img, score_thr_q15=11469, flip=True, full_res=res), name
        assert got != CDet.pair_boxes(desc, desc2, img, score_thr_q15=11469, flip=True) or not got, name
    return total


def test_pair_full_res_real_frames_equal_python(demo, data_dir, tmp_path):
    """--cnn-full-res (cfg.cnn_res FULL): the shipped pair with flip passes reads the frame itself instead of its
    half-resolution plane. Odd-sized crops of real test-split frames (321 x 241: the mirror spans every column
    at full resolution): demo == cnn_detector.detect(full_res=True), cnn_eval.Pair == cnn_detector.pair_boxes,
    and the workspace the library asks for grows with the plane."""
    if not (MODEL.is_file() and MODEL2.is_file()):
        pytest.skip("the shipped pair (models/vd_cnn.vdm, models/vd_cnn2.vdm) is not committed")
    frames = {f"crop_{k}": v[101:342, 157:478] for fr in _real_frames(data_dir, per_family=2).values()
              for k, v in fr.items()}
    assert _pair_at_res(demo, tmp_path, frames, True, ["--cnn-full-res", "on"], "pair full res: ") > 0
    from vdtools.bindings import detector as D
    ws = {fr: D.workspace_size(640, 480, sources=D.source_bits(["cnn"]), cnn_model=MODEL, cnn_model2=MODEL2,
                               cnn_flip=1, cnn_res=fr) for fr in (0, 1)}
    assert ws[1] > ws[0], ws


def test_pair_quarter_res_real_frames_equal_python(demo, data_dir, tmp_path):
    """--cnn-res quarter (cfg.cnn_res QUARTER): the shipped pair with flip passes reads the frame's 4x4 box
    averages. Real test-split frames scaled up 2x (cars twice the training size, as a 1280x1024 camera shows
    them) and cut to 1279 x 959 (not multiples of 4: the last partial block is dropped, and the mirror spans
    1276 columns): demo == cnn_detector.detect(full_res=2), cnn_eval.Pair == cnn_detector.pair_boxes, and the
    workspace the library asks for does not grow."""
    import cv2
    if not (MODEL.is_file() and MODEL2.is_file()):
        pytest.skip("the shipped pair (models/vd_cnn.vdm, models/vd_cnn2.vdm) is not committed")
    frames = {f"up_{k}": cv2.resize(v, (v.shape[1] * 2, v.shape[0] * 2), interpolation=cv2.INTER_LINEAR)[:959, :1279]
              for fr in _real_frames(data_dir, per_family=2).values() for k, v in fr.items()}
    assert _pair_at_res(demo, tmp_path, frames, 2, ["--cnn-res", "quarter"], "pair quarter res: ") > 0
    from vdtools.bindings import detector as D
    ws = {r: D.workspace_size(1279, 959, sources=D.source_bits(["cnn"]), cnn_model=MODEL, cnn_model2=MODEL2,
                              cnn_flip=1, cnn_res=r) for r in (0, 2)}
    assert ws[2] <= ws[0], ws


# ------------------------------------------------------------------ real frames, the shipped model
def _real_frames(data_dir, per_family=6):
    """A few test-split frames per family (MSRS 640x480, HIT-UAV and its flight 640x512), read as
    OpenCV reads them for the Python evaluation: {size tag: {name: image}}."""
    import cv2
    frames = frames_in_test_split(data_dir)
    fams = {}
    for f in frames:
        fams.setdefault(f.dataset, []).append(f)
    out = {}
    for fam, fs in sorted(fams.items()):
        for f in fs[::max(1, len(fs) // per_family)][:per_family]:
            img = cv2.imread(str(f.path), cv2.IMREAD_GRAYSCALE)
            assert img is not None, f.path
            name = Path(f.name).stem + ".pgm"
            out.setdefault(f"{img.shape[1]}x{img.shape[0]}", {})[name] = img
    return out


@pytest.mark.parametrize("flip", [False, True], ids=["one_pass", "flip"])
def test_real_frames_equal_python(demo, data_dir, tmp_path, flip):
    """The shipped model on real test-split frames and odd-sized crops of them (601 x 449: the last column
    is outside the half-resolution plane), with and without --cnn-flip."""
    if not MODEL.is_file():
        pytest.skip(f"no CNN model at {MODEL} (the trained network is committed there)")
    from vdtools.evaluation import cnn_eval
    desc = V.unpack(MODEL.read_bytes())
    mp = int(desc["max_peaks"]) * (2 if flip else 1)
    ref = cnn_eval.Int8(MODEL, backend="ref", flip=flip)
    total = 0
    sets = _real_frames(data_dir)
    if flip:   # odd crops (the flip pass mirrors the plane, not the frame)
        sets["601x449"] = {f"odd_{k}": v[7:456, 13:614] for fr in sets.values() for k, v in list(fr.items())[:2]}
    for tag, frames in sets.items():
        src = write_frames(tmp_path / tag, frames)
        jl = tmp_path / f"{tag}.jsonl"
        run(demo, "--input", src, "--sources", "cnn", "--model", MODEL, "--temporal", "off", "--json", jl, "--quiet",
            "--cnn-flip", "on" if flip else "off")
        dets = demo_dets(jl)
        total += compare(dets, frames, desc, max_candidates=mp, max_detections=mp, flip=flip)
        if flip:   # a threshold above 0.5: both passes decode at 2 T - 1 = 0.2, fused boxes below 0.6 dropped
            jl = tmp_path / f"{tag}_0.6.jsonl"
            run(demo, "--input", src, "--sources", "cnn", "--model", MODEL, "--temporal", "off", "--json", jl,
                "--quiet", "--cnn-flip", "on", "--cnn-thr", 0.6)
            total += compare(demo_dets(jl), frames, desc, score_thr_q15=int(round(0.6 * 32768)), max_candidates=mp,
                             max_detections=mp, flip=True)
        if int(desc["max_peaks"]) == 100:   # cnn_eval.Int8 decodes the top 100: exactly cnn_eval's candidates
            thr = int(desc["score_threshold_q"])
            for name, img in frames.items():
                h, w = img.shape
                got = [(b, int(round(s * 32768))) for b, s in ref(img, w, h, thr_q=thr)]
                assert got == CDet.boxes(desc, img, flip=flip), name
                got = [(b, int(round(s * 32768))) for b, s in ref(img, w, h, score_thr_q15=11469)]
                assert got == CDet.boxes(desc, img, score_thr_q15=11469, flip=flip), name
    assert total > 0


# ------------------------------------------------------------------ demo options
def test_demo_cnn_options(demo, clip_frames, random_net, tmp_path):
    d, net = random_net
    mp = int(d["max_peaks"])
    p = run(demo, "--help")
    for opt in ("--cnn-model", "--cnn-thr", "--cnn-rescore", "--cnn-flip", "cnn"):
        assert opt in p.stdout, opt
    frames = clip_frames["97x61"]
    src = write_frames(tmp_path / "f", frames)
    # The config file takes the same keys as the flags.
    cfg = tmp_path / "cfg.json"
    cfg.write_text(json.dumps({"sources": "cnn", "cnn-model": str(net), "cnn_thr": 0.55, "temporal": False}))
    jl = tmp_path / "cfg.jsonl"
    run(demo, "--input", src, "--model", "none", "--config", cfg, "--json", jl, "--quiet")
    compare(demo_dets(jl), frames, d, score_thr_q15=int(round(0.55 * 32768)), max_candidates=2 * mp,
            max_detections=2 * mp, flip=True)      # the demo's default: the fused flip pass
    # cnn with hot spots: both sources may appear; nothing else.
    jl2 = tmp_path / "both.jsonl"
    run(demo, "--input", src, "--model", "none", "--sources", "hotspot,cnn", "--cnn-model", net, "--json", jl2,
        "--quiet")
    srcs = {x["source"] for line in jl2.read_text().splitlines() for x in json.loads(line)["detections"]}
    assert srcs <= {"hotspot", "cnn"} and "cnn" in srcs
    # Errors: one line, non-zero exit.
    bad_flip = tmp_path / "bad_flip.json"
    bad_flip.write_text(json.dumps({"cnn_flip": "maybe"}))
    bad = [(["--sources", "cnn", "--cnn-model", tmp_path / "nope.vdm"], "--cnn-model"),
           (["--sources", "cnn", "--cnn-model", cfg], "not a valid CNN"),
           (["--cnn-model", net, "--model", "none", "--cnn-rescore"], "--cnn-rescore needs a DBN model"),
           (["--cnn-thr", "1.5"], "cnn-thr"),
           (["--cnn-model", net, "--model", "none", "--cnn-flip", "maybe"], "unexpected argument 'maybe'"),
           (["--config", bad_flip], "bad value 'maybe' for cnn-flip")]
    for args, msg in bad:
        q = run(demo, "--input", src, "--quiet", *args, check=False)
        assert q.returncode != 0 and len(q.stderr.strip().splitlines()) == 1 and msg in q.stderr, (args, q.stderr)
    # --cnn-rescore takes an optional value; with a DBN every CNN box is scored by it.
    dbn = REPO / "models" / "vd_dbn_grey.vdm"
    if dbn.is_file():
        for args in (["--cnn-rescore"], ["--cnn-rescore", "on"]):
            q = run(demo, "--input", src, "--cnn-model", net, "--model", dbn, "--sources", "cnn", *args,
                    "--temporal", "off")
            assert f"DBN model {dbn}" in q.stderr, q.stderr
        q = run(demo, "--input", src, "--cnn-model", net, "--model", dbn, "--sources", "cnn", "--cnn-rescore", "off",
                "--temporal", "off")
        assert "DBN model none (not needed)" in q.stderr, q.stderr
    # Defaults: models/vd_cnn.vdm makes cnn the default source unless a DBN --model is named.
    q = run(demo, "--input", src, "--temporal", "off")
    assert ("sources cnn" in q.stderr) == MODEL.is_file(), q.stderr
    assert ("vd_cnn2.vdm" in q.stderr) == (MODEL.is_file() and MODEL2.is_file()), q.stderr
    if dbn.is_file():
        q = run(demo, "--input", src, "--model", dbn, "--temporal", "off")
        assert "sources hotspot" in q.stderr, q.stderr


# ------------------------------------------------------------------ ctypes mirror
def test_ctypes_mirror_matches_c_layout(tmp_path):
    """Every field offset and struct size of vdtools.bindings.detector's ctypes structs equals the C compiler's."""
    cc = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
    if cc is None:
        pytest.skip("no C compiler on PATH")
    structs = [("vd_detector_cfg_t", vdet.DetectorCfg), ("vd_detector_stats_t", vdet.Stats),
               ("vd_detection_t", vdet.Detection)]
    lines = ['#include <stddef.h>', '#include <stdio.h>', '#include "vd/detector.h"', "int main(void) {"]
    want = []
    for cname, cls in structs:
        lines.append(f'  printf("%zu\\n", sizeof({cname}));')
        want.append((cname, "sizeof", C.sizeof(cls)))
        for fname, _ in cls._fields_:
            lines.append(f'  printf("%zu\\n", offsetof({cname}, {fname}));')
            want.append((cname, fname, getattr(cls, fname).offset))
    lines.append('  printf("%zu\\n", sizeof(vd_detector_t));')
    lines.append('  printf("%d\\n", (int)VD_DETECTOR_STAGE_COUNT);')
    lines.append("  return 0; }")
    (tmp_path / "layout.c").write_text("\n".join(lines) + "\n")
    exe = tmp_path / "layout"
    subprocess.run([cc, "-std=c99", "-I", str(REPO / "lib" / "include"), str(tmp_path / "layout.c"), "-o", str(exe)],
                   check=True)
    got = subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout.split()
    for (cname, fname, v), g in zip(want, got):
        assert int(g) == v, f"{cname}.{fname}: C {g}, ctypes {v}"
    assert int(got[len(want)]) <= vdet._DET_BYTES, "vd_detector_t outgrew the ctypes buffer"
    assert int(got[len(want) + 1]) == len(vdet.STAGES)


# ------------------------------------------------------------------ cfg.cnn_invert, a black-hot camera
@pytest.mark.parametrize("full_res", [False, True], ids=["half_res", "full_res"])
def test_pair_black_hot_equals_python_reference(vdlib, full_res):
    """cfg.cnn_invert (vd_fir_demo --cnn-polarity black-hot): the shipped pair with flip passes on frames of the
    bundled clip shown black-hot (255 - v) == the Python reference on the plane the networks read: at full
    resolution the white-hot frame itself; at half resolution 255 minus the 2 x 2 means of the black-hot frame,
    fed as 2 x 2 equal blocks (the inversion follows the mean: (S + 2) >> 2 of 255 - v is not always 255 minus
    that of v). And as they are, the black-hot frames lose most of the white-hot boxes."""
    import cv2
    if not (MODEL.is_file() and MODEL2.is_file()):
        pytest.skip("the shipped pair (models/vd_cnn.vdm, models/vd_cnn2.vdm) is not committed")
    desc, desc2 = V.unpack(MODEL.read_bytes()), V.unpack(MODEL2.read_bytes())
    peaks = max(int(desc["max_peaks"]), int(desc2["max_peaks"]))
    clip_dir = REPO / "tools" / "demo" / "hit-uav-clip" / "images"
    total = plain = 0
    for p in sorted(clip_dir.glob("*.jpg"))[::13]:
        white = cv2.imread(str(p), cv2.IMREAD_GRAYSCALE)
        if full_res:
            white = white[101:342, 157:478]   # 321 x 241: odd sizes
        black = (255 - white).astype(np.uint8)
        h, w = black.shape
        kw = dict(max_width=w, max_height=h, sources=vdet.source_bits(["cnn"]), cnn_model=MODEL, cnn_model2=MODEL2,
                  cnn_flip=1, cnn_res=int(full_res), max_candidates=peaks, max_detections=32)
        got = [(tuple(d["box"]), d["score_q8"]) for d in vdet.Detector(cnn_invert=1, **kw).run(black)[0]]
        if full_res:
            plane = white
        else:
            hh, hw = h // 2 * 2, w // 2 * 2
            s = black[:hh, :hw].astype(np.int64).reshape(hh // 2, 2, hw // 2, 2).sum(axis=(1, 3))
            plane = np.repeat(np.repeat((255 - ((s + 2) >> 2)).astype(np.uint8), 2, axis=0), 2, axis=1)
        want = CDet.detect(desc, plane, max_candidates=peaks, max_detections=32, flip=True, desc2=desc2,
                           full_res=full_res)
        assert got == [(tuple(int(v) for v in b), sc) for b, sc in want], p.name
        total += len(got)
        plain += len(vdet.Detector(**kw).run(black)[0])
    assert total >= (2 if full_res else 20), total
    if not full_res:
        assert plain < total, (plain, total)
