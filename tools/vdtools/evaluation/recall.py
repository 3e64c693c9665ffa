# SPDX-License-Identifier: MIT
"""Candidate recall: the fraction of ground-truth vehicles covered by at least one candidate
(IoU >= 0.5) BEFORE verification -- the ceiling of the detector's TP rate.

Per data set and time of day (MSRS night/day from the N/D suffix; HIT-UAV day/night from the
T flag of T_H_A_W_ID.jpg, 0 = day, 1 = night; the HIT-UAV sequence flight is night), split
into "hot" vehicles (the box holds a pixel >= the hot-spot threshold the detector used on that
frame) and "cold" ones, for each source configuration:

  hotspot      the C detector without a model (vdtools.bindings.detector, every refined candidate kept:
               max_detections = max_candidates, no suppression); candidate box = the refined
               contour box the DBN would verify. Threshold: adaptive p99 (floor 96), the
               detector's mode for AGC-scaled 8-bit video; "hotspot150" = the paper's constant 150.
  contrast     vd_contrast_candidates (contrast.h): component boxes of |I - box mean| >= thr.
  window       vd_windows_generate (windows.h) with the mounting preset of the data set
               (vdtools.bindings.sources.preset: "msrs" ground model, "hit" drone band).
  combinations are unions; "candidates/frame" counts the union after dropping a box whose IoU
  with an earlier source's box is > 0.7 (hotspot first, then contrast, then window), as the
  detector's merge does.

Times are per frame on one core: the detector's own clock for the hot-spot stages (threshold,
components, refine, contour) and perf_counter around the C calls for contrast and windows.

Candidate recall involves no model, so it is reported on all frames AND on the test split of
vdtools.data.dataset.assign_splits (groups: MSRS number // 40, HIT-UAV flight), where the verifier's
TP rate is measured.

    python3 -m vdtools.evaluation.recall [--limit N] [--out docs/results/candidates]
"""
import argparse
import json
import time
from pathlib import Path

import numpy as np

from vdtools.bindings import clib, sources as S
from vdtools.data import dataset as D
from vdtools.bindings.detector import Detector

IOU_MATCH = 0.5
IOU_DEDUP = 0.7
ORDER = ("hotspot", "contrast", "window")
CONFIGS = {
    "hotspot150": ("hotspot150",),
    "hotspot": ("hotspot",),
    "contrast": ("contrast",),
    "window": ("window",),
    "hotspot+contrast": ("hotspot", "contrast"),
    "hotspot+window": ("hotspot", "window"),
    "all": ("hotspot", "contrast", "window"),
}


def iou_matrix(a, b):
    """IoU of every box in a (N,4) with every box in b (M,4) (x, y, w, h)."""
    a = np.asarray(a, np.float64).reshape(-1, 4)
    b = np.asarray(b, np.float64).reshape(-1, 4)
    if len(a) == 0 or len(b) == 0:
        return np.zeros((len(a), len(b)))
    ax0, ay0, ax1, ay1 = a[:, 0:1], a[:, 1:2], a[:, 0:1] + a[:, 2:3], a[:, 1:2] + a[:, 3:4]
    bx0, by0, bx1, by1 = b[:, 0], b[:, 1], b[:, 0] + b[:, 2], b[:, 1] + b[:, 3]
    iw = np.clip(np.minimum(ax1, bx1) - np.maximum(ax0, bx0), 0, None)
    ih = np.clip(np.minimum(ay1, by1) - np.maximum(ay0, by0), 0, None)
    inter = iw * ih
    union = (a[:, 2:3] * a[:, 3:4]) + (b[:, 2] * b[:, 3]) - inter
    return np.where(union > 0, inter / np.maximum(union, 1e-9), 0.0)


def time_of_day(fr):
    if fr.dataset == "msrs":
        return "night" if Path(fr.name).stem.endswith("N") else "day"
    if fr.dataset == "seq":
        return "night" if fr.name.split("_")[0] == "1" else "day"
    return "night" if fr.name.split("_")[0] == "1" else "day"


class Generators:
    """The C candidate sources, each with its own workspace, sized per frame size."""

    def __init__(self, contrast_kw=None, window_kw=None):
        self.contrast_kw = contrast_kw or {}
        self.window_kw = window_kw or {}
        self._det = {}
        self._con = {}
        self._win = {}

    def _detector(self, w, h, mode):
        key = (w, h, mode)
        if key not in self._det:
            self._det[key] = Detector(model=None, clock=True, max_width=w, max_height=h, thr_mode=mode,
                                      max_components=1024, max_candidates=256, max_detections=256,
                                      nms_iou_q15=32768)
        return self._det[key]

    def hotspot(self, img, mode):
        dets, st = self._detector(img.shape[1], img.shape[0], mode).run(img)
        t = st["time_us"]
        us = t["threshold"] + t["components"] + t["refine"] + t["contour"]
        return np.array([d["box"] for d in dets], np.int32).reshape(-1, 4), us / 1e3, st["hot_thr_u8"]

    def contrast(self, img):
        key = img.shape
        if key not in self._con:
            self._con[key] = S.ContrastSource(img.shape[1], img.shape[0], cap=4096, **self.contrast_kw)
        t = time.perf_counter()
        c = self._con[key](img)
        ms = (time.perf_counter() - t) * 1e3
        return np.stack([c["x"], c["y"], c["w"], c["h"]], 1).astype(np.int32).reshape(-1, 4), ms

    def window(self, img, dataset):
        h, w = img.shape
        key = (w, h, dataset)
        if key not in self._win:
            name = S.default_preset(dataset, w, h)
            self._win[key] = S.windows_cfg(w, h, preset_name=name, max_windows=1048576, **self.window_kw)
        cfg = self._win[key]
        t = time.perf_counter()
        b = S.windows_generate(cfg)
        return b, (time.perf_counter() - t) * 1e3


def frame_record(fr, gen, split):
    img = D.read_frame(fr.path)
    boxes, times = {}, {}
    boxes["hotspot"], times["hotspot"], thr = gen.hotspot(img, "adaptive")
    boxes["hotspot150"], times["hotspot150"], _ = gen.hotspot(img, "constant")
    boxes["contrast"], times["contrast"] = gen.contrast(img)
    boxes["window"], times["window"] = gen.window(img, fr.dataset)
    gts = np.array(fr.vehicles, np.int32).reshape(-1, 4)
    hot = [bool((img[y:y + h, x:x + w] >= thr).any()) if w > 0 and h > 0 else False for x, y, w, h in gts]
    covered = {k: (iou_matrix(gts, b) >= IOU_MATCH).any(1) if len(gts) else np.zeros(0, bool)
               for k, b in boxes.items()}
    counts = {}
    for name, srcs in CONFIGS.items():
        kept = []
        for s in srcs:
            b = boxes[s]
            if kept and len(b):
                prev = np.concatenate(kept)
                b = b[~(iou_matrix(b, prev) > IOU_DEDUP).any(1)]
            kept.append(b)
        counts[name] = int(sum(len(k) for k in kept))
    return dict(dataset="hit" if fr.dataset == "seq" else fr.dataset, seq=fr.dataset == "seq", tod=time_of_day(fr),
                split=split, frame=fr.name, hot_thr=int(thr), hot=hot, covered={k: v.tolist() for k, v in covered.items()},
                counts=counts, times=times)


def summarise(recs):
    """{config: {vehicles, hot, cold, recall, recall_hot, recall_cold, cand_per_frame, ms_per_frame}}."""
    out = {}
    n_frames = len(recs)
    for name, srcs in CONFIGS.items():
        cov, hot = [], []
        for r in recs:
            c = np.zeros(len(r["hot"]), bool)
            for s in srcs:
                c |= np.array(r["covered"][s], bool)
            cov.extend(c.tolist())
            hot.extend(r["hot"])
        cov, hot = np.array(cov, bool), np.array(hot, bool)
        rate = lambda m: float(cov[m].mean()) if m.any() else None
        out[name] = dict(frames=n_frames, vehicles=int(len(cov)), hot=int(hot.sum()), cold=int((~hot).sum()),
                         recall=rate(np.ones_like(cov)), recall_hot=rate(hot), recall_cold=rate(~hot),
                         cand_per_frame=float(np.mean([r["counts"][name] for r in recs])) if recs else 0.0,
                         ms_per_frame=float(np.mean([sum(r["times"][s] for s in srcs) for r in recs])) if recs else 0.0)
    return out


def groups(recs):
    """(label, records) per data set x time of day x split scope."""
    out = []
    for scope in ("all", "test"):
        for ds in ("msrs", "hit"):
            for tod in ("night", "day"):
                sel = [r for r in recs if r["dataset"] == ds and r["tod"] == tod and (scope == "all" or r["split"] == "test")]
                if sel:
                    out.append((scope, ds, tod, sel))
    return out


def fmt(v):
    return "–" if v is None else f"{100 * v:.1f}"


def markdown(summary, meta):
    lines = ["# Candidate recall (before verification)", "",
             "Fraction of ground-truth vehicles covered by at least one candidate with IoU ≥ 0.5, before the DBN: "
             "the ceiling of the detector's TP rate. \"hot\" vehicles hold a pixel ≥ the hot-spot threshold the "
             "detector used on that frame (adaptive p99, floor 96); \"cold\" ones do not. Candidates/frame counts the "
             "merged set (a box with IoU > 0.7 with an earlier source's box is dropped); ms/frame is candidate "
             "generation on one core (hot spots include refine + contour, the detector's own clock).", "",
             f"Reproduce: `{meta['command']}` (library {meta['lib']}, {meta['frames']} frames, "
             f"{meta['seconds']:.0f} s). Data: MSRS (Tang et al. 2022; Ha et al. 2017) and HIT-UAV (Suo et al. 2023, "
             "CC BY 4.0), read from ../shared/data.", "",
             "Sources: `hotspot150` paper 001 constant 150; `hotspot` adaptive threshold (detector THR_ADAPTIVE); "
             f"`contrast` contrast.h {meta['contrast']}; `window` windows.h presets {meta['windows']} "
             "(tools/vdtools/bindings/sources.py).", ""]
    for (scope, ds, tod), s in summary:
        first = next(iter(s.values()))
        lines += [f"## {ds.upper() if ds == 'msrs' else 'HIT-UAV'} {tod} — {'all frames' if scope == 'all' else 'test split'}"
                  f" ({first['frames']} frames, {first['vehicles']} vehicles: {first['hot']} hot, {first['cold']} cold)", "",
                  "| sources | recall % | hot % | cold % | candidates/frame | ms/frame |", "|---|---:|---:|---:|---:|---:|"]
        for name, v in s.items():
            lines.append(f"| {name} | {fmt(v['recall'])} | {fmt(v['recall_hot'])} | {fmt(v['recall_cold'])} | "
                         f"{v['cand_per_frame']:.1f} | {v['ms_per_frame']:.2f} |")
        lines.append("")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description="candidate recall per source configuration")
    ap.add_argument("--data", default=str(clib.DATA_DIR))
    ap.add_argument("--limit", type=int, default=0, help="every k-th frame only, to make a quick run (0 = all)")
    ap.add_argument("--out", default=None, help="write OUT.md and OUT.json")
    ap.add_argument("--contrast", default="{}", help="JSON keywords of sources.contrast_cfg")
    ap.add_argument("--windows", default="{}", help="JSON keywords of sources.windows_cfg (override the preset)")
    a = ap.parse_args(argv)
    t0 = time.time()
    frames = D.all_frames(a.data)
    split_of = D.assign_splits(frames)
    if a.limit:
        frames = frames[::a.limit]
    gen = Generators(json.loads(a.contrast), json.loads(a.windows))
    recs = [frame_record(fr, gen, split_of[fr.group]) for fr in frames]
    summary = [((scope, ds, tod), summarise(sel)) for scope, ds, tod, sel in groups(recs)]
    meta = dict(command="python3 -m vdtools.evaluation.recall " + " ".join(argv if argv is not None else __import__("sys").argv[1:]),
                lib=str(clib.lib_path().name), frames=len(recs), seconds=time.time() - t0,
                contrast=json.loads(a.contrast) or "defaults (radius 16, |I - mean| >= 24, paper rules)",
                windows=json.loads(a.windows) or "msrs / hit")
    for (scope, ds, tod), s in summary:
        print(f"{scope:4s} {ds:4s} {tod:5s} " + "  ".join(
            f"{k}={fmt(v['recall'])}({fmt(v['recall_hot'])}/{fmt(v['recall_cold'])}),{v['cand_per_frame']:.0f}"
            for k, v in s.items()))
    if a.out:
        out = Path(a.out)
        out.parent.mkdir(parents=True, exist_ok=True)
        out.with_suffix(".md").write_text(markdown(summary, meta) + "\n")
        out.with_suffix(".json").write_text(json.dumps(dict(meta=meta, results=[
            dict(scope=sc, dataset=ds, time=tod, sources=s) for (sc, ds, tod), s in summary]), indent=1) + "\n")


if __name__ == "__main__":
    main()
