# SPDX-License-Identifier: MIT
"""Benchmark of every vd stage against its OpenCV counterpart, same process, same pixels.

    VD_LIB=build-bench/libvd.so python3 -m vdtools.evaluation.bench [--frames 40] [--repeats 15] [--json out/bench.json]

A run writes out/bench.json (callgrind: out/callgrind.json) unless --json names the file: the committed
record docs/results/bench.json changes only when asked for, never as a side effect of a smoke run.

Release build of libvd.so required (cmake -DCMAKE_BUILD_TYPE=Release). cv2.setNumThreads(1).
Per stage and frame: median of `repeats` single-call timings (time.perf_counter_ns) after
two warm-up calls; then the median over frames (ROI stages: over candidates). vd is
called through ctypes with pre-built arguments; the cost of a no-op call is measured
and printed, and so is the cost of a trivial cv2 call. Stages below ~10 us are
dominated by that overhead: read tools/bench/vd_bench (C, no Python) for them.
Docs: docs/performance.md.
"""
import argparse
import ctypes as C
import json
import math
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

# Single-threaded BLAS for the numpy context figure (must precede the first numpy import).
for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import numpy as np  # noqa: E402

import cv2  # noqa: E402

from vdtools.bindings import clib
from vdtools.bindings import detector as vdet
from vdtools.bindings.raw import RawLib

P = C.POINTER
VD_ERR_CAPACITY = -3
DBN_SIZES = [1024, 576, 256, 64, 1]  # paper 001's network; 753 k multiply-adds


def addr(obj):
    return C.addressof(obj)


class View:
    """A ViewU8 (= ImageU8) on a 2-D uint8 array, kept alive with it."""

    def __init__(self, a):
        assert a.dtype == np.uint8 and a.ndim == 2 and a.strides[1] == 1
        self.a = a
        self.v = clib.view_u8(a)
        self.p = addr(self.v)


def rect(x, y, w, h):
    r = clib.Rect(int(x), int(y), int(w), int(h))
    return r, addr(r)


# ---------------------------------------------------------------- timing
def tmed(fn, repeats):
    """Median ns of single calls of fn() after two warm-up calls."""
    fn()
    fn()
    pc = time.perf_counter_ns
    ts = []
    for _ in range(repeats):
        t0 = pc()
        fn()
        ts.append(pc() - t0)
    return statistics.median(ts)


def med(xs):
    return statistics.median(xs) if xs else float("nan")


# ---------------------------------------------------------------- data
def pick(paths, n):
    """n paths evenly spread over the sorted list (a fixed, reproducible sample)."""
    paths = sorted(paths)
    if len(paths) <= n:
        return paths
    return [paths[(i * len(paths)) // n] for i in range(n)]


def read_grey(path):
    if str(path).endswith(".pgm"):
        from vdtools.data.clip import read_pgm
        return read_pgm(path)
    a = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if a is None:
        raise OSError(f"cannot read {path}")
    if a.ndim == 3:
        a = a[:, :, 0]
    return np.ascontiguousarray(a)


def scratch(name):
    """A per-user scratch path in the system's temp directory (files the benchmark may reuse between runs)."""
    return Path(tempfile.gettempdir()) / f"vd_bench_{os.getuid()}_{name}"


def find_clip(arg):
    """The bundled clip: --clip, else <dir of libvd.so>/clip, else generated into /tmp."""
    cands = [Path(arg)] if arg else [clib.lib_path().parent / "clip", clib.REPO / "build" / "clip"]
    for c in cands:
        if (c / "u8").is_dir() and any((c / "u8").glob("*.pgm")):
            return c
    if arg:
        return None
    out = scratch("clip")
    if not (out / "u8").is_dir():
        from vdtools.data import clip
        clip.generate(out)
    return out


def frame_sets(args):
    """[(name, description, frames, thr_mode, paths)] of the real sets and the clip."""
    sets = []
    data = clib.DATA_DIR
    msrs = pick(list((data / "msrs").glob("**/*N.png")), args.frames)
    if msrs:
        sets.append(("msrs-night", "8-bit 640x480 road, adaptive threshold",
                     [read_grey(p) for p in msrs], "adaptive", msrs))
    hit = pick(list((data / "hit-uav" / "frames").glob("**/*.jpg")), args.frames)
    if hit:
        sets.append(("hit-uav", "8-bit 640x512 drone, adaptive threshold",
                     [read_grey(p) for p in hit], "adaptive", hit))
    clipdir = find_clip(args.clip)
    if clipdir is not None:
        u8 = pick(list((clipdir / "u8").glob("*.pgm")), args.frames)
        sets.append(("clip-u8", "synthetic 640x512 8-bit, constant 150", [read_grey(p) for p in u8], "constant", u8))
        u16 = pick(list((clipdir / "u16").glob("*.pgm")), args.frames)
        if u16:
            sets.append(("clip-u16", "synthetic 640x512 16-bit centi-kelvin, 30 C (detector only)",
                         [read_grey(p) for p in u16], "constant", u16))
    return sets


C_STAGE_MAP = {"detector (whole frame)": ["detector (whole frame)"], "threshold (frame)": ["threshold"],
               "components (frame)": ["components", "components (cv2 labels only)"],
               "median3 (frame)": ["median3 (frame)"], "median5 (frame)": ["median5 (frame)"],
               "otsu (frame)": ["otsu (frame, threshold only)"],
               "contours (hot mask, frame)": ["contours (hot mask, frame)"],
               "contrast map r16 (frame)": ["contrast map r16 (frame)"],
               "median3 (candidate ROI)": ["median3 (candidate ROI)"],
               "median5 (candidate ROI)": ["median5 (candidate ROI)"],
               "otsu (candidate ROI)": ["otsu (candidate ROI, threshold only)"],
               "refine (candidate ROI)": ["refine (candidate ROI)"],
               "contours (refined ROI)": ["contours (refined ROI mask)"],
               "resample 32x32 (cand.)": ["resample to 32x32 (candidate)"],
               "DBN (per sample)": ["DBN (per 32x32 sample)"]}


def vd_bench_exe(a):
    return Path(a.vd_bench) if a.vd_bench else clib.lib_path().parent / "tools" / "vd_bench"


def run_c_timing(a, name, paths, mode, model):
    """Median us per stage from the C program on the same frames (no Python in the loop)."""
    import subprocess
    exe = vd_bench_exe(a)
    if not exe.exists():
        return {}
    lst = scratch(f"{name}.lst")
    lst.write_text("\n".join(str(p) for p in paths) + "\n")
    txt = subprocess.run([str(exe), "--iters", str(a.repeats), "--model", str(model), "--thr-mode", mode,
                          "--max-cands", str(a.max_cands_per_frame), str(lst)],
                         capture_output=True, text=True, check=True).stdout
    out = {}
    for line in txt.splitlines():
        for stage in C_STAGE_MAP:
            if line.startswith(stage):
                parts = line[len(stage):].split()
                if len(parts) >= 2:
                    out[stage] = {"calls": int(parts[0]), "us": float(parts[1])}
    return out


def worst_frames(w=640, h=512, seed=5):
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:h, 0:w]
    out = [("all-hot", np.full((h, w), 255, np.uint8)),
           ("checkerboard-1px", np.where((xx + yy) % 2 == 0, 255, 0).astype(np.uint8)),
           ("dots-every-2nd", np.where((xx % 2 == 0) & (yy % 2 == 0), 255, 0).astype(np.uint8)),
           ("salt-pepper-50%", np.where(rng.random((h, w)) < 0.5, 255, 0).astype(np.uint8)),
           ("salt-pepper-5%", np.where(rng.random((h, w)) < 0.05, 255,
                                       rng.integers(0, 120, (h, w))).astype(np.uint8))]
    return out


# ---------------------------------------------------------------- the model
def paper_model(repo):
    """(blob, name): a trained models/*.vdm if one exists, else a random model of
    the paper's size (timing does not depend on the weights)."""
    vdms = sorted((repo / "models").glob("*.vdm")) if (repo / "models").is_dir() else []
    for p in vdms:
        b = p.read_bytes()
        if len(b) > 500_000 and int.from_bytes(b[4:6], "little") in (1, 2):   # a DBN (3 is the CNN)
            return b, p.name
    from vdtools.formats import quantise, vdm
    fm = quantise.load_float(quantise.random_float_model(DBN_SIZES, seed=1))
    return vdm.pack(quantise.quantise(fm, name="bench-random")), "random 1024-576-256-64-1 (grey)"


# ---------------------------------------------------------------- the benchmark
class Bench:
    def __init__(self, args):
        self.args = args
        self.L = RawLib()
        self.R = args.repeats
        self.results = {}
        self.model_blob, self.model_name = paper_model(clib.REPO)
        from vdtools.formats import vdm
        self.model_macs = sum(int(L["w"].shape[0]) * int(L["w"].shape[1]) for L in vdm.unpack(self.model_blob)["layers"])
        self.mpath = scratch("model.vdm")
        self.mpath.write_bytes(self.model_blob)
        # DBN model in our own instance
        self._mkeep = np.zeros((len(self.model_blob) + 15) // 8, np.uint64)
        C.memmove(self._mkeep.ctypes.data, self.model_blob, len(self.model_blob))
        self.model = (C.c_uint64 * 512)()
        clib.check(self.L.vd_dbn_load(addr(self.model), self._mkeep.ctypes.data, len(self.model_blob)), "dbn_load")
        n = C.c_size_t()
        clib.check(self.L.vd_dbn_workspace_size(addr(self.model), addr(n)), "dbn ws")
        self.dbn_ws, self.dbn_wsp = clib.workspace(n.value)
        self.dbn_wsn = n.value

    # -- overheads
    def overheads(self):
        L, R = self.L, max(self.R, 200)
        f = L.vd_status_str
        noop = med([tmed(lambda: f(0), R) for _ in range(5)])
        thr = L.vd_threshold_u8
        err4 = med([tmed(lambda: thr(None, None, 1, None), R) for _ in range(5)])
        one = np.zeros((1, 1), np.uint8)
        dst = np.zeros((1, 1), np.uint8)
        cvo = med([tmed(lambda: cv2.threshold(one, 1, 255, cv2.THRESH_BINARY, dst), R) for _ in range(5)])
        pc = time.perf_counter_ns
        timer = med([tmed(lambda: None, R) for _ in range(5)])
        self.results["overhead_ns"] = {"vd_status_str (ctypes no-op)": noop,
                                       "vd_threshold_u8(NULL...) (ctypes, 4 args, early return)": err4,
                                       "cv2.threshold on 1x1": cvo, "empty lambda + timer": timer}
        del pc
        return self.results["overhead_ns"]

    def candidates(self, img, mask, labeller):
        """Expanded candidate rects (paper rules) of one frame, as vd's detector finds them."""
        L = self.L
        comps, n = labeller(mask)
        rules = (C.c_uint8 * 12)()
        L.vd_components_rules_default(addr(rules))
        kept = C.c_size_t()
        L.vd_components_filter(comps.ctypes.data, n, addr(rules), addr(kept))
        out = []
        h, w = img.shape
        for i in range(kept.value):
            c = comps[i]
            x, y, bw, bh = int(c["x"]), int(c["y"]), int(c["w"]), int(c["h"])
            rin, pin = rect(x, y, bw, bh)
            rout, pout = rect(0, 0, 0, 0)
            if L.vd_rect_expand(pin, 384, 512, w, h, pout) == 0:
                out.append((rout.x, rout.y, rout.w, rout.h))
        return out

    def run_set(self, name, desc, frames, thr_mode):
        L, R, a = self.L, self.R, self.args
        res = {"description": desc, "frames": len(frames), "shape": list(frames[0].shape),
               "dtype": str(frames[0].dtype), "stages": {}}
        st = res["stages"]

        def add(stage, vd_ns, cv_ns, unit="frame", note=""):
            st.setdefault(stage, {"vd": [], "cv2": [], "unit": unit, "note": note})
            if vd_ns is not None:
                st[stage]["vd"].append(vd_ns)
            if cv_ns is not None:
                st[stage]["cv2"].append(cv_ns)

        # detector (also gives each 8-bit frame's threshold)
        det = vdet.Detector(model=self.mpath, thr_mode=thr_mode, max_width=max(f.shape[1] for f in frames),
                            max_height=max(f.shape[0] for f in frames))
        thrs, counts = [], []
        for f in frames:
            fa = np.ascontiguousarray(f)
            cf = clib.frame(fa)
            out = det._out
            cnt = C.c_size_t()
            run = vdet._lib().vd_detector_run
            detp, fp, cntp = C.byref(det._det), C.byref(cf), C.byref(cnt)
            status = [0]

            def go():
                status[0] = run(detp, fp, out, len(out), cntp)
            add("detector (whole frame)", tmed(go, R), None, note="vd_detector_run, model: " + self.model_name)
            s = det.stats(status[0])
            thrs.append(s["hot_thr_u8"])
            counts.append({k: s[k] for k in ("hot_pixels", "components", "kept", "refined", "verified",
                                              "detections", "decimated")} | {"status": s["status"]})
        # the same without a model: every refined candidate passes unscored (no DBN)
        det0 = vdet.Detector(model=None, thr_mode=thr_mode, max_width=max(f.shape[1] for f in frames),
                             max_height=max(f.shape[0] for f in frames))
        for f in frames:
            fa = np.ascontiguousarray(f)
            cf = clib.frame(fa)
            cnt = C.c_size_t()
            run = vdet._lib().vd_detector_run
            detp, fp, cntp, out = C.byref(det0._det), C.byref(cf), C.byref(cnt), det0._out
            add("detector without model (no DBN)", tmed(lambda: run(detp, fp, out, len(out), cntp), R), None,
                note="vd_detector_run, model NULL")
        # per-stage breakdown of the detector (its own clock_us, via a Python callback: ~1 us per stage)
        detc = vdet.Detector(model=self.mpath, thr_mode=thr_mode, clock=True,
                             max_width=max(f.shape[1] for f in frames), max_height=max(f.shape[0] for f in frames))
        per = {k: [] for k in vdet.STAGES}
        for f in frames:
            for _ in range(3):
                _, s = detc.run(np.ascontiguousarray(f))
            for k in per:
                per[k].append(s["time_us"][k])
        res["detector_stage_us_median"] = {k: med(v) for k, v in per.items()}
        res["detector_counts_median"] = {k: med([c[k] for c in counts]) for k in counts[0] if k != "status"}
        res["detector_status"] = {st: sum(1 for c in counts if c["status"] == st) for st in sorted({c["status"] for c in counts})}
        if frames[0].dtype != np.uint8:
            self.results[name] = res
            return res

        H = max(f.shape[0] for f in frames)
        W = max(f.shape[1] for f in frames)
        n = C.c_size_t()
        L.vd_components_workspace_size(W, H, addr(n))
        cc_ws, cc_wsp = clib.workspace(n.value)
        cc_wsn = n.value
        cap = ((W + 1) // 2) * ((H + 1) // 2)
        from vdtools.bindings.components import COMPONENT_DTYPE
        comps = np.zeros(cap, COMPONENT_DTYPE)
        L.vd_contour_workspace_size(W, H, addr(n))
        ct_ws, ct_wsp = clib.workspace(n.value)
        ct_wsn = n.value
        pts_cap = 4 * W * H
        pts = np.zeros(pts_cap, np.int32)   # vd_point_t = 2 x int16
        ncont_cap = cap
        conts = np.zeros(ncont_cap * 6, np.uint32)
        nc, npt = C.c_size_t(), C.c_size_t()
        refcfg = (C.c_uint8 * 3)(3, 5, 5)
        L.vd_refine_workspace_size(W, H, addr(n))
        rf_ws, rf_wsp = clib.workspace(n.value)
        rf_wsn = n.value

        cm_ws = None
        if hasattr(L.lib, "vd_contrast_map_u8"):
            L.vd_contrast_map_workspace_size(W, addr(n))
            cm_ws, cm_wsp = clib.workspace(n.value)
            cm_wsn = n.value

        def labeller(mask):
            mv = View(mask)
            cnt = C.c_size_t()
            s = L.vd_components_label(mv.p, None, cc_wsp, cc_wsn, comps.ctypes.data, cap, addr(cnt))
            assert s == 0, s
            return comps, cnt.value

        def contours_call(mv):
            return lambda: L.vd_contour_find_external(mv.p, ct_wsp, ct_wsn, pts.ctypes.data, None, pts_cap,
                                                       conts.ctypes.data, ncont_cap, addr(nc), addr(npt))

        n_cand = 0
        samples = []
        cands_all = []
        for f, thr in zip(frames, thrs):
            fv = View(f)
            dst = np.empty_like(f)
            dv = View(dst)
            # threshold
            t8 = int(thr)
            add("threshold", tmed(lambda: L.vd_threshold_u8(fv.p, None, t8, dv.p), R),
                tmed(lambda: cv2.threshold(f, t8 - 1, 255, cv2.THRESH_BINARY, dst), R))
            mask = dst.copy()
            mv = View(mask)
            assert np.array_equal(mask, cv2.threshold(f, t8 - 1, 255, cv2.THRESH_BINARY)[1])
            # components
            cnt = C.c_size_t()
            labels = np.empty(f.shape, np.int32)
            t_cc = tmed(lambda: L.vd_components_label(mv.p, None, cc_wsp, cc_wsn, comps.ctypes.data, cap, addr(cnt)), R)
            add("components", t_cc,
                tmed(lambda: cv2.connectedComponentsWithStats(mask, labels, connectivity=8, ltype=cv2.CV_32S), R),
                note="vs connectedComponentsWithStats(connectivity=8, CV_32S)")
            add("components (cv2 labels only)", t_cc,
                tmed(lambda: cv2.connectedComponents(mask, labels, connectivity=8, ltype=cv2.CV_32S), R),
                note="same vd call vs cv2.connectedComponents: labels, no stats (less work than vd)")
            # median (whole frame)
            add("median3 (frame)", tmed(lambda: L.vd_median3_u8(fv.p, None, dv.p), R),
                tmed(lambda: cv2.medianBlur(f, 3, dst), R))
            add("median5 (frame)", tmed(lambda: L.vd_median5_u8(fv.p, None, dv.p), R),
                tmed(lambda: cv2.medianBlur(f, 5, dst), R))
            # Otsu (whole frame): vd threshold value only, and value + binarisation (= cv2's work)
            t = C.c_uint8()
            add("otsu (frame, threshold only)", tmed(lambda: L.vd_otsu_u8(fv.p, None, addr(t)), R),
                tmed(lambda: cv2.threshold(f, 0, 255, cv2.THRESH_BINARY | cv2.THRESH_OTSU, dst), R),
                note="cv2 also binarises")

            def otsu_bin():
                L.vd_otsu_u8(fv.p, None, addr(t))
                if t.value < 255:
                    L.vd_threshold_u8(fv.p, None, t.value + 1, dv.p)
            add("otsu+binarise (frame)", tmed(otsu_bin, R),
                tmed(lambda: cv2.threshold(f, 0, 255, cv2.THRESH_BINARY | cv2.THRESH_OTSU, dst), R))
            # contours of the hot mask (whole frame)
            add("contours (hot mask, frame)", tmed(contours_call(mv), R),
                tmed(lambda: cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE), R))
            # local-contrast map (contrast.h), r = 16: cv2 composition box mean + absdiff
            if cm_ws is not None:
                mean = np.empty_like(f)
                add("contrast map r16 (frame)", tmed(lambda: L.vd_contrast_map_u8(fv.p, 16, 0, cm_wsp, cm_wsn, dv.p), R),
                    tmed(lambda: cv2.absdiff(f, cv2.boxFilter(f, -1, (33, 33), mean, normalize=True,
                                                              borderType=cv2.BORDER_CONSTANT), dst), R),
                    note="cv2 = boxFilter 33x33 + absdiff (divides by 33^2 at the border, vd by the in-frame count)")
            # candidates
            cands = self.candidates(f, mask, labeller)[:a.max_cands_per_frame]
            cands_all.append(len(cands))
            for (x, y, w, h) in cands:
                n_cand += 1
                if n_cand > a.max_cands:
                    break
                r, rp = rect(x, y, w, h)
                roi_out = np.empty((h, w), np.uint8)
                ov = View(roi_out)
                # context crop for cv2 so that medianBlur sees the same neighbours as vd
                x0, y0 = max(x - 2, 0), max(y - 2, 0)
                x1, y1 = min(x + w + 2, f.shape[1]), min(y + h + 2, f.shape[0])
                crop = f[y0:y1, x0:x1]
                cbuf = np.empty_like(crop)
                add("median3 (candidate ROI)", tmed(lambda: L.vd_median3_u8(fv.p, rp, ov.p), R),
                    tmed(lambda: cv2.medianBlur(crop, 3, cbuf), R), unit="candidate",
                    note="cv2 on the ROI + 2 px context")
                add("median5 (candidate ROI)", tmed(lambda: L.vd_median5_u8(fv.p, rp, ov.p), R),
                    tmed(lambda: cv2.medianBlur(crop, 5, cbuf), R), unit="candidate",
                    note="cv2 on the ROI + 2 px context")
                roi_view = f[y:y + h, x:x + w]
                rbuf = np.empty((h, w), np.uint8)
                add("otsu (candidate ROI, threshold only)", tmed(lambda: L.vd_otsu_u8(fv.p, rp, addr(t)), R),
                    tmed(lambda: cv2.threshold(roi_view, 0, 255, cv2.THRESH_BINARY | cv2.THRESH_OTSU, rbuf), R),
                    unit="candidate", note="cv2 also binarises")
                add("otsu+binarise (candidate ROI)",
                    tmed(lambda: (L.vd_otsu_u8(fv.p, rp, addr(t)), L.vd_threshold_u8(fv.p, rp, min(t.value + 1, 255), ov.p)), R),
                    tmed(lambda: cv2.threshold(roi_view, 0, 255, cv2.THRESH_BINARY | cv2.THRESH_OTSU, rbuf), R),
                    unit="candidate")
                # refine vs a cv2 composition (median + Otsu + flood-fill hole filling)
                add("refine (candidate ROI)",
                    tmed(lambda: L.vd_refine_region(fv.p, rp, addr(refcfg), rf_wsp, rf_wsn, ov.p, None), R),
                    tmed(lambda: cv_refine(crop, x - x0, y - y0, w, h), R), unit="candidate",
                    note="no cv2 peer: cv2 = medianBlur3 + Otsu + floodFill hole fill (vd also does edges + local windows)")
                refined = roi_out.copy()
                rv = View(refined)
                add("contours (refined ROI mask)", tmed(contours_call(rv), R),
                    tmed(lambda: cv2.findContours(refined, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE), R),
                    unit="candidate")
                s32 = np.empty((32, 32), np.uint8)
                add("resample to 32x32 (candidate)",
                    tmed(lambda: L.vd_resample_u8(fv.p, rp, s32.ctypes.data, 32, 32), R),
                    tmed(lambda: cv2.resize(roi_view, (32, 32), s32, interpolation=cv2.INTER_AREA), R),
                    unit="candidate", note="closest cv2 peer: resize INTER_AREA")
                samples.append(s32.copy())
        res["candidates_per_frame_median"] = med(cands_all)
        res["candidates_timed"] = min(n_cand, a.max_cands)

        # DBN per sample
        if samples:
            score = C.c_uint8()
            fn, mp = L.vd_dbn_classify, addr(self.model)
            for s in samples[:40]:
                add("DBN (per 32x32 sample)", tmed(lambda: fn(mp, s.ctypes.data, self.dbn_wsp, self.dbn_wsn,
                                                             addr(score)), R), None, unit="sample",
                    note=f"no cv2 peer; {self.model_macs / 1e3:.0f} k MAC")
            # float32 numpy forward as a context figure (not a peer)
            from vdtools.formats import quantise
            fm = quantise.load_float(quantise.random_float_model(DBN_SIZES, seed=1))
            Ws = [(w.astype(np.float32), b.astype(np.float32)) for w, b in fm["layers"]]
            x = samples[0].reshape(-1).astype(np.float32) / 255.0

            def npf():
                v = x
                for w, b in Ws:
                    v = 1.0 / (1.0 + np.exp(-(w @ v + b)))
                return v
            st["DBN (per 32x32 sample)"]["numpy_float32_ns"] = tmed(npf, R)
        self.results[name] = res
        return res

    def worst(self):
        """Worst-case frames through the detector (default caps) next to typical ones."""
        R = max(3, self.R // 3)
        out = {}
        for mode in ("constant",):
            det = vdet.Detector(model=self.mpath, thr_mode=mode)
            for name, f in worst_frames():
                out[name] = self._worst_one(det, f, R)
        if self.args.max_size:
            w = h = self.args.max_size
            det = vdet.Detector(model=self.mpath, thr_mode="constant", max_width=w, max_height=h)
            base = read_grey(sorted((clib.DATA_DIR / "msrs").glob("**/*N.png"))[0]) \
                if (clib.DATA_DIR / "msrs").is_dir() else worst_frames()[3][1]
            big = np.tile(base, (h // base.shape[0] + 1, w // base.shape[1] + 1))[:h, :w].copy()
            out[f"max-size {w}x{h} (tiled night frame, thr 150)"] = self._worst_one(det, big, 3)
            out[f"max-size {w}x{h} all-hot"] = self._worst_one(det, np.full((h, w), 255, np.uint8), 3)
            out[f"max-size {w}x{h} salt-pepper-50%"] = self._worst_one(
                det, np.where(np.random.default_rng(3).random((h, w)) < 0.5, 255, 0).astype(np.uint8), 3)
            out["max-size workspace bytes"] = det.workspace_bytes
        self.results["worst_cases"] = out
        return out

    def _worst_one(self, det, f, R):
        f = np.ascontiguousarray(f)
        cf = clib.frame(f)
        cnt = C.c_size_t()
        run = vdet._lib().vd_detector_run
        status = [0]

        def go():
            status[0] = run(C.byref(det._det), C.byref(cf), det._out, len(det._out), C.byref(cnt))
        t = tmed(go, R)
        s = det.stats(status[0])
        return {"shape": list(f.shape), "ms": t / 1e6, "status": s["status"], "detections": int(cnt.value),
                "counts": {k: s.get(k, -1) for k in ("hot_pixels", "runs", "components", "kept", "refined", "decimated",
                                                     "overflow_runs", "overflow_components", "overflow_candidates",
                                                     "overflow_contours", "overflow_detections")}}


def cv_refine(crop, ox, oy, w, h):
    """cv2 composition for the refine stage: medianBlur 3, Otsu, hole filling by floodFill."""
    m = cv2.medianBlur(crop, 3)[oy:oy + h, ox:ox + w]
    _, b = cv2.threshold(m, 0, 255, cv2.THRESH_BINARY | cv2.THRESH_OTSU)
    p = cv2.copyMakeBorder(b, 1, 1, 1, 1, cv2.BORDER_CONSTANT, value=0)
    cv2.floodFill(p, None, (0, 0), 255)
    return cv2.bitwise_or(b, cv2.bitwise_not(p[1:-1, 1:-1]))


# ---------------------------------------------------------------- callgrind (instructions, C program)
CG_STAGES = {"cg_detector": "detector (whole frame)", "cg_threshold": "threshold (frame)",
             "cg_components": "components (frame)", "cg_median3": "median3 (frame)", "cg_median5": "median5 (frame)",
             "cg_otsu": "otsu (frame)", "cg_contours": "contours (hot mask, frame)",
             "cg_contrast": "contrast map r16 (frame)",
             "cg_median3_roi": "median3 (candidate ROI)", "cg_median5_roi": "median5 (candidate ROI)",
             "cg_otsu_roi": "otsu (candidate ROI)", "cg_refine": "refine (candidate ROI)",
             "cg_contours_roi": "contours (refined ROI)", "cg_resample": "resample 32x32 (cand.)",
             "cg_dbn": "DBN (per sample)"}


def parse_callgrind(out_file, calls):
    """{stage: Ir per call} from callgrind_annotate --inclusive=yes of a vd_bench --iters 1 run;
    calls = {stage name: calls} from vd_bench's own table."""
    import re
    import subprocess
    txt = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--threshold=100", str(out_file)],
                         capture_output=True, text=True, check=True).stdout
    res = {}
    for line in txt.splitlines():
        m = re.match(r"\s*([\d,]+)\s+\([^)]*\)\s+\S*?:?(cg_\w+)\b", line)
        if m and m.group(2) in CG_STAGES and "[" in line:   # the file:function list (clones summed)
            stage = CG_STAGES[m.group(2)]
            res[stage] = res.get(stage, 0) + int(m.group(1).replace(",", ""))
    return {k: v / calls[k] for k, v in res.items() if calls.get(k)}


def vd_bench_calls(txt):
    calls = {}
    for line in Path(txt).read_text().splitlines():
        for stage in CG_STAGES.values():
            if line.startswith(stage):
                parts = line[len(stage):].split()
                if len(parts) >= 2:
                    calls[stage] = int(parts[0])
    return calls


def run_callgrind(a):
    """Runs build/tools/vd_bench --iters 1 under callgrind on each set's frame sample."""
    import subprocess
    exe = vd_bench_exe(a)
    tmp = scratch("cg")
    tmp.mkdir(exist_ok=True)
    model = scratch("model.vdm")
    blob, _ = paper_model(clib.REPO)
    model.write_bytes(blob)
    data = clib.DATA_DIR
    clipdir = find_clip(a.clip)
    sets = [("msrs-night", list((data / "msrs").glob("**/*N.png")), "adaptive"),
            ("hit-uav", list((data / "hit-uav" / "frames").glob("**/*.jpg")), "adaptive")]
    if clipdir is not None:
        sets.append(("clip-u8", list((clipdir / "u8").glob("*.pgm")), "constant"))
    out = {}
    for name, paths, mode in sets:
        if not paths or (a.sets and name not in a.sets.split(",")):
            continue
        lst = tmp / f"{name}.lst"
        lst.write_text("\n".join(str(p) for p in pick(paths, a.frames)) + "\n")
        cgf, txt = tmp / f"{name}.out", tmp / f"{name}.txt"
        with open(txt, "w") as f:
            subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={cgf}", str(exe), "--iters", "1",
                            "--model", str(model), "--thr-mode", mode, "--max-cands", str(a.max_cands_per_frame), str(lst)], stdout=f,
                           stderr=subprocess.DEVNULL, check=True)
        calls = vd_bench_calls(txt)
        out[name] = {"calls": calls, "ir_per_call": parse_callgrind(cgf, calls)}
        print(f"callgrind {name}: {len(paths and pick(paths, a.frames))} frames", file=sys.stderr)
    stages = list(CG_STAGES.values())
    print(f"{'stage (Ir per call)':30s}" + "".join(f"{n:>14s}" for n in out))
    for st in stages:
        print(f"{st:30s}" + "".join(f"{out[n]['ir_per_call'].get(st, float('nan')):14,.0f}" for n in out))
    return out


# ---------------------------------------------------------------- report
def summarise(results):
    """Per set and stage: median vd / cv2 ns and the ratio; with the C program's figure, also
    vd (C) against cv2 minus the cost of a trivial cv2 call (overhead_ns)."""
    table = []
    cv2_overhead = results.get("overhead_ns", {}).get("cv2.threshold on 1x1", 0.0)
    for name, res in results.items():
        if not isinstance(res, dict) or "stages" not in res:
            continue
        for stage, d in res["stages"].items():
            vd = med(d["vd"])
            cv = med(d["cv2"]) if d["cv2"] else None
            row = {"set": name, "stage": stage, "unit": d["unit"], "n": len(d["vd"]), "vd_us": vd / 1e3,
                   "cv2_us": None if cv is None else cv / 1e3,
                   "ratio": None if cv is None else vd / cv, "note": d.get("note", "")}
            if "c_us" in d:
                row["vd_c_us"] = d["c_us"]
                if cv is not None:
                    row["cv2_net_us"] = max(cv - cv2_overhead, 1.0) / 1e3
                    row["ratio_c"] = d["c_us"] / row["cv2_net_us"]
            if stage.startswith("detector"):
                row["frames_per_s"] = 1e9 / vd
                if "c_us" in d:
                    row["frames_per_s_c"] = 1e6 / d["c_us"]
            if stage.startswith("DBN"):
                row["mac_per_s"] = results.get("dbn_macs", 753_216) / (vd / 1e9)
                if "numpy_float32_ns" in d:
                    row["numpy_float32_us"] = d["numpy_float32_ns"] / 1e3
            table.append(row)
    return table


def fmt_table(table, overhead_us):
    lines = [f"{'set':11s} {'stage':32s} {'unit':9s} {'n':>4s} {'vd us':>9s} {'-call':>9s} {'cv2 us':>9s} "
             f"{'vd/cv2':>7s} {'vd C us':>9s} {'cv2 net':>9s} {'C/net':>6s}  extra"]
    for r in table:
        cv = "" if r["cv2_us"] is None else f"{r['cv2_us']:9.1f}"
        ratio = "" if r["ratio"] is None else f"{r['ratio']:7.2f}"
        extra = ""
        if "frames_per_s" in r:
            extra = f"{r['frames_per_s']:.0f} frames/s"
            if "frames_per_s_c" in r:
                extra += f" (C: {r['frames_per_s_c']:.0f})"
        if "mac_per_s" in r:
            extra = f"{r['mac_per_s'] / 1e9:.2f} GMAC/s"
            if "numpy_float32_us" in r:
                extra += f" (numpy f32 {r['numpy_float32_us']:.1f} us)"
        c = f"{r['vd_c_us']:9.1f}" if "vd_c_us" in r else " " * 9
        net = f"{r['cv2_net_us']:9.1f}" if "cv2_net_us" in r else " " * 9
        rc = f"{r['ratio_c']:6.2f}" if "ratio_c" in r else " " * 6
        lines.append(f"{r['set']:11s} {r['stage']:32s} {r['unit']:9s} {r['n']:4d} {r['vd_us']:9.1f} "
                     f"{r['vd_us'] - overhead_us:9.1f} {cv:>9s} {ratio:>7s} {c} {net} {rc}  {extra}")
    return "\n".join(lines)


def _status_text(st):
    """'VD_OK x38, VD_ERR_CAPACITY x2' from {status: frames} (or an old list of statuses)."""
    if isinstance(st, dict):
        return ", ".join(f"{k} x{v}" for k, v in st.items())
    return ", ".join(st or [])


def markdown(bench_json, cg_json=None):
    """Markdown tables for docs/results/performance-history.md from bench.json (and callgrind.json)."""
    d = json.loads(Path(bench_json).read_text())
    rows = d["table"]
    sets = [s for s in ("msrs-night", "hit-uav", "clip-u8", "clip-u16") if any(r["set"] == s for r in rows)]
    stages = []
    for r in rows:
        if r["stage"] not in stages:
            stages.append(r["stage"])
    out = []
    for sname in sets:
        raw = d["raw"][sname]
        out.append(f"**{sname}** ({raw['description']}; {raw['frames']} frames"
                   + (f", {raw.get('candidates_timed')} candidates" if raw.get("candidates_timed") else "") + ")")
        out.append("")
        out.append("| stage | unit | vd (py) us | vd (C) us | cv2 (py) us | cv2 net us | vd/cv2 (py) | vd C / cv2 net | note |")
        out.append("|---|---|---|---|---|---|---|---|---|")
        for r in rows:
            if r["set"] != sname:
                continue
            f = lambda v, fmt="{:.1f}": "" if v is None else fmt.format(v)
            note = r.get("note", "")
            if "frames_per_s" in r:
                c = f" (C: {r['frames_per_s_c']:.0f})" if "frames_per_s_c" in r else ""
                note = f"**{r['frames_per_s']:.0f} frames/s**{c}; " + note
            if "mac_per_s" in r:
                note = f"{r['mac_per_s'] / 1e9:.1f} GMAC/s (py); " + note
            rc = r.get("ratio_c")
            out.append(f"| {r['stage']} | {r['unit']} | {f(r['vd_us'])} | {f(r.get('vd_c_us'))} | {f(r['cv2_us'])} | "
                       f"{f(r.get('cv2_net_us'))} | {f(r['ratio'], '{:.2f}')} | "
                       f"{'' if rc is None else ('**%.2f**' % rc)} | {note} |")
        out.append("")
    out.append("")
    oh = d["raw"].get("overhead_ns", {})
    for k, v in oh.items():
        out.append(f"- {k}: {v / 1e3:.2f} us")
    out.append("")
    out.append("| set | detector stage medians (us, own clock) | counts (median per frame) | status |")
    out.append("|---|---|---|---|")
    for s in sets:
        raw = d["raw"][s]
        t = ", ".join(f"{k} {v:.0f}" for k, v in raw.get("detector_stage_us_median", {}).items() if v)
        c = ", ".join(f"{k} {v:g}" for k, v in raw.get("detector_counts_median", {}).items())
        out.append(f"| {s} | {t} | {c} | {_status_text(raw.get('detector_status'))} |")
    out.append("")
    out.append("| worst case | frame | detector ms | status | hot px | runs | comps | kept | refined | decimated | "
               "overflow runs/comp/cand/cont/det |")
    out.append("|---|---|---|---|---|---|---|---|---|---|---|")
    for k, v in d["raw"].get("worst_cases", {}).items():
        if not isinstance(v, dict):
            out.append(f"| {k} | {v} | | | | | | | | | |")
            continue
        c = v["counts"]
        out.append(f"| {k} | {v['shape'][1]}x{v['shape'][0]} | {v['ms']:.2f} | {v['status']} | {c['hot_pixels']} | "
                   f"{c.get('runs', '')} | {c['components']} | {c['kept']} | {c['refined']} | {c['decimated']} | "
                   f"{c.get('overflow_runs', '')}/{c['overflow_components']}/"
                   f"{c['overflow_candidates']}/{c['overflow_contours']}/{c['overflow_detections']} |")
    if cg_json and Path(cg_json).exists():
        cg = json.loads(Path(cg_json).read_text())["callgrind"]
        names = list(cg)
        out.append("")
        out.append("| stage (instructions per call, Ir) | " + " | ".join(names) + " |")
        out.append("|---|" + "---|" * len(names))
        for st in CG_STAGES.values():
            out.append(f"| {st} | " + " | ".join(f"{cg[n]['ir_per_call'].get(st, float('nan')):,.0f}" for n in names)
                       + " |")
    return "\n".join(out)


def machine():
    cpu = ""
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version(), "numpy": np.__version__,
            "cv2": cv2.__version__, "libvd": str(clib.lib_path()), "loadavg": os.getloadavg()}


RECORD = clib.REPO / "docs" / "results" / "bench.json"


def result_path(json_arg, markdown):
    """Where a run writes (or --markdown reads): --json if given; else the committed record for reading and
    out/bench.json for writing, so only an explicit --json replaces the record."""
    if json_arg is not None:
        return Path(json_arg)
    return RECORD if markdown else Path("out") / "bench.json"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=40, help="frames per real set (evenly spread sample)")
    ap.add_argument("--repeats", type=int, default=15, help="timed calls per frame and stage (median)")
    ap.add_argument("--max-cands", type=int, default=120, help="candidates timed per set")
    ap.add_argument("--max-cands-per-frame", type=int, default=6)
    ap.add_argument("--clip", default=None, help="clip directory (default: next to libvd.so, else generated)")
    ap.add_argument("--max-size", type=int, default=0, help="also time a max-size square frame (e.g. 8192)")
    ap.add_argument("--sets", default="", help="comma list to restrict (msrs-night,hit-uav,clip-u8,clip-u16)")
    ap.add_argument("--json", default=None,
                    help="result file (default: out/bench.json for a run; the committed docs/results/bench.json "
                         "for --markdown); give docs/results/bench.json to update the record")
    ap.add_argument("--callgrind", action="store_true",
                    help="instead: instructions per stage call from valgrind --tool=callgrind on tools/vd_bench")
    ap.add_argument("--vd-bench", default=None, help="vd_bench executable (default: <dir of libvd.so>/tools/vd_bench)")
    ap.add_argument("--markdown", action="store_true", help="instead: print the tables of --json (+ callgrind.json)")
    a = ap.parse_args(argv)
    a.json = str(result_path(a.json, a.markdown))
    if a.markdown:
        print(markdown(a.json, Path(a.json).with_name("callgrind.json")))
        return 0
    if a.callgrind:
        res = run_callgrind(a)
        js = Path(a.json).with_name("callgrind.json") if a.json.endswith("bench.json") else Path(a.json)
        js.parent.mkdir(parents=True, exist_ok=True)
        js.write_text(json.dumps({"machine": machine(), "args": vars(a), "callgrind": res}, indent=1))
        print(f"wrote {js}")
        return 0
    cv2.setNumThreads(1)
    b = Bench(a)
    b.results["dbn_macs"] = b.model_macs
    print(f"libvd: {clib.lib_path()}  cv2 {cv2.__version__} threads={cv2.getNumThreads()}  model: {b.model_name}")
    oh = b.overheads()
    for k, v in oh.items():
        print(f"overhead  {k:55s} {v / 1e3:7.2f} us")
    for name, desc, frames, mode, paths in frame_sets(a):
        if a.sets and name not in a.sets.split(","):
            continue
        t0 = time.time()
        res = b.run_set(name, desc, frames, mode)
        cres = run_c_timing(a, name, paths, mode, b.mpath)
        res["c_program"] = cres
        for cst, pst in C_STAGE_MAP.items():
            for p in pst:
                if cst in cres and p in res["stages"]:
                    res["stages"][p]["c_us"] = cres[cst]["us"]
        print(f"[{name}: {len(frames)} frames, {time.time() - t0:.0f} s]", file=sys.stderr)
    b.worst()
    table = summarise(b.results)
    print(fmt_table(table, oh["vd_status_str (ctypes no-op)"] / 1e3))
    print("\nworst cases (detector, default caps; typical frames above):")
    for k, v in b.results["worst_cases"].items():
        if isinstance(v, dict):
            print(f"  {k:45s} {v['ms']:9.2f} ms  {v['status']:16s} dets={v['detections']:3d} {v['counts']}")
        else:
            print(f"  {k:45s} {v}")
    out = {"machine": machine(), "args": vars(a), "model": b.model_name, "table": table, "raw": b.results,
           "date": time.strftime("%Y-%m-%d %H:%M:%S")}
    Path(a.json).parent.mkdir(parents=True, exist_ok=True)
    Path(a.json).write_text(json.dumps(out, indent=1, default=float))
    print(f"wrote {a.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
