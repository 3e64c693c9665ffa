# SPDX-License-Identifier: MIT
"""The per-frame grey window of 16-bit frames (cfg.grey_mode = VD_DETECTOR_GREY_PERCENTILE): the percentiles of
vd_histogram_percentiles_u16 against numpy on real frames written as a camera's raw counts, the detector's window
(stats) against the same oracle, and the shipped pair on raw counts bit-exact with the Python reference fed the
8-bit plane that vdtools.data.dataset (grey_window_ck, grey_of_ck) derives from the window."""
import numpy as np
import pytest

cv2 = pytest.importorskip("cv2")

from vdtools.bindings import detector as vdet  # noqa: E402
from vdtools.bindings import pixel  # noqa: E402
from vdtools.bindings.clib import REPO  # noqa: E402
from vdtools.data import dataset as D  # noqa: E402
from vdtools.evaluation import cnn_detector as CDet  # noqa: E402
from vdtools.formats import cnn_vdm as V  # noqa: E402

from realdata import frame_paths  # noqa: E402

MODEL = REPO / "models" / "vd_cnn.vdm"
MODEL2 = REPO / "models" / "vd_cnn2.vdm"
def oracle(a, permille):
    """The sample at rank floor(n * permille / 1000) of the sorted plane; 65535 when that rank is n."""
    s = np.sort(a, axis=None)
    k = a.size * permille // 1000
    return int(s[k]) if k < a.size else 65535


# The Python reference of the window and the map (what vd-adapt and the fleet use): the detector must equal it.
window_ck, grey_map = D.grey_window_ck, D.grey_of_ck


def raw_counts(grey, rng, kind):
    """A real 8-bit frame as a 16-bit camera's raw counts: scaled and offset, or a gamma (not linear) plus noise."""
    g = grey.astype(np.float64)
    if kind == "linear":
        out = g * 64 + 1000
    elif kind == "x257":
        out = g * 257
    else:   # a different tone curve and sensor noise: what a camera's own counts look like against its AGC output
        out = 6000 + 9000 * (g / 255.0) ** 1.6 + rng.normal(0, 12, g.shape)
    return np.clip(np.rint(out), 0, 65535).astype(np.uint16)


def _frames(data_dir, n):
    msrs, uav = frame_paths(data_dir)
    paths = sorted(msrs)[::max(1, len(msrs) // n)][:n] + sorted(uav)[::max(1, len(uav) // n)][:n]
    if not paths:
        pytest.skip(f"no MSRS / HIT-UAV frames under {data_dir} (../shared/data; see its README)")
    return paths


def test_percentiles_equal_numpy_on_raw_counts_of_real_frames(vdlib, data_dir):
    rng = np.random.default_rng(5)
    n = 0
    for p in _frames(data_dir, 20):
        grey = cv2.imread(str(p), cv2.IMREAD_GRAYSCALE)
        for kind in ("linear", "x257", "curve"):
            a = raw_counts(grey, rng, kind)
            for lo, hi in ((1, 999), (0, 1000), (10, 995), (int(rng.integers(0, 500)), int(rng.integers(500, 1001)))):
                assert pixel.percentiles_u16(a, lo, hi) == (oracle(a, lo), oracle(a, hi)), (p.name, kind, lo, hi)
            sub = a[7:301, 3:517]   # a strided view
            assert pixel.percentiles_u16(sub, 2, 998) == (oracle(sub, 2), oracle(sub, 998)), p.name
            n += 1
    assert n >= 60


def test_percentiles_generated_edges(vdlib):
    rng = np.random.default_rng(8)
    flat = np.full((48, 64), 4242, np.uint16)
    assert pixel.percentiles_u16(flat, 0, 1000) == (4242, 65535)
    assert pixel.percentiles_u16(flat, 1, 999) == (4242, 4242)
    for _ in range(200):
        h, w = int(rng.integers(1, 60)), int(rng.integers(1, 60))
        base, rng_w = int(rng.integers(0, 65000)), int(rng.choice([1, 40, 256, 3000, 65536]))
        a = np.clip(base + rng.integers(0, rng_w, (h, w)), 0, 65535).astype(np.uint16)
        lo, hi = sorted(int(v) for v in rng.integers(0, 1001, 2))
        assert pixel.percentiles_u16(a, lo, hi) == (oracle(a, lo), oracle(a, hi)), (h, w, base, rng_w, lo, hi)
    with pytest.raises(Exception):
        pixel.percentiles_u16(flat, 600, 500)


@pytest.mark.parametrize("tail", [1, 25])
def test_detector_window_equals_numpy(vdlib, data_dir, tail):
    rng = np.random.default_rng(tail)
    det = vdet.Detector(max_width=640, max_height=512, grey_mode=1, grey_tail_permille=tail)
    for p in _frames(data_dir, 6):
        a = raw_counts(cv2.imread(str(p), cv2.IMREAD_GRAYSCALE), rng, "curve")
        _, st = det.run(a)
        assert (st["grey_lo_raw"], st["grey_hi_raw"]) == (oracle(a, tail), oracle(a, 1000 - tail)), p.name
    _, st = det.run(np.full((64, 80), 30000, np.uint16))   # flat: reported as found; the map is widened
    assert (st["grey_lo_raw"], st["grey_hi_raw"]) == (30000, 30000)
    _, st = vdet.Detector(max_width=640, max_height=512).run(a)
    assert (st["grey_lo_raw"], st["grey_hi_raw"]) == (0, 0)   # fixed window: none reported


@pytest.mark.parametrize("thr_mode", ["constant", "adaptive"])
def test_hot_spots_of_raw_counts_are_those_of_the_grey_view(vdlib, data_dir, thr_mode):
    """A 16-bit frame in its own window (raw counts: no temperature) is thresholded as its 8-bit view: the hot
    pixels are those whose grey level (numpy's map of the window) is at or above the 8-bit threshold (150, or
    max(96, the p99 grey level) in adaptive mode), the raw threshold is the first raw value at that level, and
    the detector run on the 8-bit view itself labels as many pixels in constant mode."""
    rng = np.random.default_rng(17)
    det = vdet.Detector(max_width=640, max_height=512, grey_mode=1, thr_mode=thr_mode)
    det8 = vdet.Detector(max_width=640, max_height=512, thr_mode=thr_mode)
    levels = np.arange(65536, dtype=np.uint16)
    n = 0
    for p in _frames(data_dir, 6):
        grey = cv2.imread(str(p), cv2.IMREAD_GRAYSCALE)
        for kind in ("linear", "x257", "curve"):
            a = raw_counts(grey, rng, kind)
            _, st = det.run(a)
            lo, hi = window_ck(a, 1)
            view = grey_map(a, lo, hi)
            t = 150 if thr_mode == "constant" else max(96, int(np.sort(view, axis=None)[a.size * 990 // 1000]))
            assert st["hot_thr_u8"] == t, (p.name, kind)
            reach = np.flatnonzero(grey_map(levels, lo, hi) >= t)
            assert st["hot_thr_raw"] == (int(reach[0]) if reach.size else 65536), (p.name, kind)
            hot = int(np.count_nonzero(view >= t))
            if st["overflow_runs"] == 0:
                assert st["hot_pixels"] == hot, (p.name, kind)
            if thr_mode == "constant":
                assert det8.run(view)[1]["hot_pixels"] == st["hot_pixels"], (p.name, kind)
            n += 1
    assert n >= 30


def half_plane_as_frame(a, lo, hi):
    """The detector's half-resolution input of a 16-bit frame (2 x 2 raw means rounded half up, then the grey map)
    as an 8-bit frame of 2 x 2 equal blocks, whose own half-resolution plane (8-bit: (sum + 2) >> 2) is that
    input again: what the 8-bit Python reference must be fed to see what the C sees."""
    h, w = a.shape[0] // 2 * 2, a.shape[1] // 2 * 2
    s = a[:h, :w].astype(np.int64).reshape(h // 2, 2, w // 2, 2).sum(axis=(1, 3))
    return np.repeat(np.repeat(grey_map((s + 2) // 4, lo, hi), 2, axis=0), 2, axis=1)


@pytest.mark.parametrize("full_res", [False, True], ids=["half_res", "full_res"])
def test_pair_on_raw_counts_equals_python_reference(vdlib, full_res):
    """The shipped pair with flip passes on frames of the bundled clip written as raw counts: the C detector in
    percentile mode == cnn_detector.detect on the 8-bit plane numpy makes from the same window (at full
    resolution each sample through the grey map, on odd-sized crops; at half resolution the 2 x 2 raw means);
    and the fixed window finds nothing on them."""
    if not (MODEL.is_file() and MODEL2.is_file()):
        pytest.skip("the shipped pair (models/vd_cnn.vdm, models/vd_cnn2.vdm) is not committed")
    desc, desc2 = V.unpack(MODEL.read_bytes()), V.unpack(MODEL2.read_bytes())
    peaks = max(int(desc["max_peaks"]), int(desc2["max_peaks"]))
    rng = np.random.default_rng(3)
    total = 0
    clip = sorted((REPO / "tools" / "demo" / "hit-uav-clip" / "images").glob("*.jpg"))   # vehicles in every frame
    for i, p in enumerate(clip[::13]):
        grey = cv2.imread(str(p), cv2.IMREAD_GRAYSCALE)
        if full_res:
            grey = grey[101:342, 157:478]   # 321 x 241
        a = raw_counts(grey, rng, ("linear", "curve")[i % 2])
        h, w = a.shape
        kw = dict(max_width=w, max_height=h, sources=vdet.source_bits(["cnn"]), cnn_model=MODEL, cnn_model2=MODEL2,
                  cnn_flip=1, cnn_res=int(full_res), max_candidates=peaks, max_detections=32)
        dets, _ = vdet.Detector(grey_mode=1, **kw).run(a)
        got = [(tuple(d["box"]), d["score_q8"]) for d in dets]
        lo, hi = window_ck(a, 1)
        plane = grey_map(a, lo, hi) if full_res else half_plane_as_frame(a, lo, hi)
        want = CDet.detect(desc, plane, max_candidates=peaks, max_detections=32, flip=True, desc2=desc2,
                           full_res=full_res)
        assert got == [(tuple(int(v) for v in b), s) for b, s in want], p.name
        assert vdet.Detector(**kw).run(a)[0] == [], p.name
        total += len(got)
    assert total >= (2 if full_res else 20), total
