# SPDX-License-Identifier: MIT
"""Fleet-scale evaluation: the C detector over many recordings on a Dask cluster (docs/fleet.md).

    python3 -m vdtools.evaluation.fleet MANIFEST --out DIR [--scheduler ADDRESS | --workers N] [--shard-frames 256]
                             [--config FILE] [--sources ...] [--cnn-model F] [--model F] [--temporal on|off]
                             [--mine DIR]

MANIFEST: JSON Lines or CSV, one recording per row: "input" (a directory, a list file, or one image /
raw / video file the port reads; relative paths are relative to the manifest), optional "id", "gt"
(COCO-like JSON or YOLO folder, as vd_fir_demo --eval), "classes", "raw_size" ("WxH"), "raw_format"
(u16 | u16be | u8), and any metadata ("camera", "date", "daynight", ...).

Each recording is cut into shards of consecutive frame files (a multi-frame raw file and a file whose
frame count is unknown, e.g. a video, stay whole). A shard runs on one worker: the capture port
(libvd_port.so) reads its frames exactly as vd_fir_demo does, a fresh C detector (libvd.so, the code
firmware links; the model bytes and the settings travel with the task) runs on each frame, and the
shard's JSON Lines (the DESIGN.md contract, byte for byte what `vd_fir_demo --json` writes for the same
frames) and metrics are written under temporary names and renamed when complete. Temporal analysis starts
afresh at each shard (a tracker reset), so a shard's output equals the demo run on that shard's frames.
The driver skips complete shards (resume), merges each recording's shards, checks that every input frame
appears exactly once, and writes DIR/report.json and DIR/report.md.
"""
import argparse
import csv
import hashlib
import io
import json
import math
import os
import shutil
import socket
import sys
import time
from pathlib import Path

from vdtools.bindings import clib
from vdtools.bindings.detector import CNN_RES_NAMES

FRAME_EXTS = (".pgm", ".png", ".jpg", ".jpeg", ".raw", ".y16", ".gray")   # file_capture.c, k_frame_exts
RAW_EXTS = (".raw", ".y16", ".gray")
LIST_EXTS = (".txt", ".lst")
IMAGE_EXTS = (".pgm", ".png", ".jpg", ".jpeg")
STAGES = ("threshold", "components", "refine", "contour", "sample", "dbn", "nms", "temporal", "contrast", "windows",
          "cnn", "total")
SRC_HOTSPOT, SRC_CONTRAST, SRC_WINDOW, SRC_CNN, SRC_ALL = 0x01, 0x02, 0x04, 0x08, 0x07
VERSION = 2   # of the shard files (2: tracking metrics); part of every shard's key


class FleetError(RuntimeError):
    pass


# ------------------------------------------------------------------ manifest and shards

def _parse_size(s):
    w, h = str(s).lower().split("x")
    return int(w), int(h)


def read_manifest(path):
    """[{id, input, gt, classes, raw_size, raw_format, meta}] from a JSON Lines or CSV manifest."""
    path = Path(path)
    text = path.read_text()
    rows = []
    if path.suffix.lower() == ".csv":
        rows = [{k: v for k, v in r.items() if v not in (None, "")} for r in csv.DictReader(io.StringIO(text))]
    else:
        for n, line in enumerate(text.splitlines(), 1):
            if line.strip() and not line.lstrip().startswith("#"):
                try:
                    rows.append(json.loads(line))
                except json.JSONDecodeError as e:
                    raise FleetError(f"{path}:{n}: not JSON ({e})") from None
    recs, seen = [], set()
    base = path.resolve().parent
    for n, r in enumerate(rows):
        if "input" not in r:
            raise FleetError(f"{path}: row {n + 1} has no \"input\"")
        inp = (base / r["input"]).resolve()
        rid = str(r.get("id") or f"{n:04d}-{inp.stem if inp.is_file() else inp.name}")
        rid = "".join(c if c.isalnum() or c in "-_." else "_" for c in rid)
        if rid in seen:
            raise FleetError(f"{path}: recording id {rid!r} appears twice")
        seen.add(rid)
        meta = {k: v for k, v in r.items() if k not in ("id", "input", "gt", "classes", "raw_size", "raw_format")}
        recs.append(dict(id=rid, input=str(inp), gt=str((base / r["gt"]).resolve()) if r.get("gt") else None,
                         classes=r.get("classes"), raw_size=_parse_size(r["raw_size"]) if r.get("raw_size") else None,
                         raw_format=r.get("raw_format", "u16"), meta=meta))
    return recs


def _raw_frames(path, raw_size, raw_format):
    if raw_size is None:
        raise FleetError(f"{path}: a raw file needs raw_size (WxH) in the manifest")
    bpp = 1 if raw_format == "u8" else 2
    n = os.path.getsize(path) // (raw_size[0] * raw_size[1] * bpp)
    return n


def frame_files(rec):
    """[(path, n_frames, names)] of a recording in the port's order (names None: unknown, e.g. a video).
    Directory: every frame file sorted by name (bytes); list file: its lines (relative to the list, '#'
    comments); otherwise the file itself. A raw file with several frames names them file#k."""
    inp = Path(rec["input"])
    if inp.is_dir():
        paths = sorted((p for p in inp.iterdir() if p.suffix.lower() in FRAME_EXTS and p.is_file()
                        and not p.name.startswith(".")), key=lambda p: os.fsencode(p.name))
    elif inp.suffix.lower() in LIST_EXTS:
        paths = []
        for line in inp.read_text().splitlines():
            s = line.strip()
            if s and not s.startswith("#"):
                paths.append(Path(s) if s.startswith("/") else inp.parent / s)
    else:
        paths = [inp]
    out = []
    for p in paths:
        ext = p.suffix.lower()
        if ext in RAW_EXTS:
            n = _raw_frames(p, rec["raw_size"], rec["raw_format"])
            names = [p.name] if n == 1 else [f"{p.name}#{k}" for k in range(n)]
            out.append((str(p), n, names))
        elif ext in IMAGE_EXTS:
            out.append((str(p), 1, [p.name]))
        else:
            out.append((str(p), None, None))   # a video or another input only the port knows
    return out


def plan(recs, shard_frames=256):
    """Shards: [{rec, index, files, names}] -- consecutive files of one recording, about shard_frames frames
    each (0: whole recordings); a file is never split. names: the frame names the shard must produce
    (None when the port alone knows them)."""
    shards = []
    for rec in recs:
        files = frame_files(rec)
        if not files:
            raise FleetError(f"recording {rec['id']}: no frames in {rec['input']}")
        cur, count = [], 0
        groups = []
        for f in files:
            if f[1] is None or (cur and shard_frames and count + f[1] > shard_frames):
                if cur:
                    groups.append(cur)
                cur, count = [], 0
            cur.append(f)
            count += f[1] or 0
            if f[1] is None:
                groups.append(cur)
                cur, count = [], 0
        if cur:
            groups.append(cur)
        for k, g in enumerate(groups):
            names = None if any(f[1] is None for f in g) else [n for f in g for n in f[2]]
            shards.append(dict(rec=rec["id"], index=k, files=[f[0] for f in g], names=names))
    return shards


# ------------------------------------------------------------------ detector settings (as vd_fir_demo)

SETTINGS = ("sources", "cnn-model", "cnn-model2", "model", "temporal", "cnn-thr", "cnn-flip", "cnn-full-res",
            "thr-mode", "hot-thr", "max-candidates", "max-detections", "max-tracks", "track-scores", "track-coast", "track-confirm",
            "grey-window", "grey-tail", "cnn-polarity", "cnn-res")


def _vdm_version(blob):
    return blob[4] | (blob[5] << 8) if len(blob) >= 6 else 0


def _source_bits(text):
    bits = 0
    for t in str(text).replace("+", ",").split(","):
        t = t.strip()
        b = {"hotspot": SRC_HOTSPOT, "contrast": SRC_CONTRAST, "window": SRC_WINDOW, "windows": SRC_WINDOW,
             "all": SRC_ALL, "cnn": SRC_CNN}.get(t)
        if b is None:
            raise FleetError(f"bad value {text!r} for sources")
        bits |= b
    return bits


def _switch(v):
    if isinstance(v, bool):
        return v
    if str(v) in ("on", "true", "1", "yes"):
        return True
    if str(v) in ("off", "false", "0", "no"):
        return False
    raise FleetError(f"bad switch value {v!r}")


def _confirm_q15(v):
    """settings.c's set_track_confirm: "HI" or "HI,LO" -> (hi, lo) in Q15 (LO left out: HI - 0.07)."""
    try:
        parts = [float(x) for x in str(v).split(",")]
    except ValueError:
        raise FleetError(f"bad value {v!r} for track-confirm") from None
    if len(parts) == 1:
        parts.append(max(parts[0] - 0.07, 1 / 32768))
    if len(parts) != 2 or not (1 / 32768 <= parts[1] <= parts[0] <= 1.0):
        raise FleetError(f"bad value {v!r} for track-confirm")
    hi, lo = parts
    return int(math.floor(hi * 32768 + 0.5)), int(math.floor(lo * 32768 + 0.5))


def vdet_scores_flag():
    from vdtools.bindings import detector as vdet
    return vdet.TEMPORAL_SCORES


def resolve(settings, models_dir=None):
    """vd_fir_demo's detector set-up (tools/demo/common/models.c demo_models_load and demo_detector_cfg, settings.c)
    for the settings it shares with the fleet: ({cfg field: value}, CNN model bytes (a pair of them with a
    second network, cfg.cnn_model2) or None, DBN model bytes or None, description).
    settings: {name: value} with the demo's names (dashes or underscores)."""
    s = {k.replace("_", "-"): v for k, v in (settings or {}).items()}
    bad = sorted(set(s) - set(SETTINGS))
    if bad:
        raise FleetError(f"settings not supported by vdtools.evaluation.fleet: {', '.join(bad)} "
                         f"(supported: {', '.join(SETTINGS)})")
    models_dir = Path(models_dir or clib.REPO / "models")
    fields = {"temporal": _switch(s.get("temporal", True)), "cnn_flip": int(_switch(s.get("cnn-flip", True)))}
    # cnn-full-res: on/off, or auto (the default, as vd_fir_demo's): no field here, run() measures each
    # recording's frames as the demo does (auto_resolution: 64 spread over it)
    # cnn-res: half/full/quarter, or auto as cnn-full-res auto; the later of the two wins, as in the demo's config
    for k in [k for k in s if k in ("cnn-full-res", "cnn-res")]:
        v = str(s[k])
        if v == "auto":
            fields.pop("cnn_res", None)
        elif k == "cnn-full-res":
            fields["cnn_res"] = int(_switch(s[k]))
        elif v in CNN_RES_NAMES:
            fields["cnn_res"] = CNN_RES_NAMES.index(v)
        else:
            raise FleetError(f"bad value '{v}' for cnn-res (expected half|full|quarter|auto)")
    # temporal_cfg: the demo's track-aware scores (default on) and coasting (default 0)
    fields["temporal_cfg.flags"] = vdet_scores_flag() if _switch(s.get("track-scores", True)) else 0
    if "track-coast" in s:
        fields["temporal_cfg.coast_frames"] = int(s["track-coast"])
    if "track-confirm" in s:
        fields["temporal_cfg.confirm_hi_q15"], fields["temporal_cfg.confirm_lo_q15"] = _confirm_q15(s["track-confirm"])
    # grey-window: fixed / frame set cfg.grey_mode here; auto (the default, as vd_fir_demo's): no field here, run()
    # decides per recording on its first frame read (grey_decision)
    gw = str(s.get("grey-window", "auto"))
    if gw not in ("auto", "fixed", "frame"):
        raise FleetError(f"bad value '{gw}' for grey-window (expected auto|fixed|frame)")
    if gw != "auto":
        fields["grey_mode"] = int(gw == "frame")
    if "grey-tail" in s:
        tail = int(math.floor(float(s["grey-tail"]) * 10.0 + 0.5))
        if not 1 <= tail <= 499:
            raise FleetError(f"bad value '{s['grey-tail']}' for grey-tail (expected 0.1..49.9)")
        fields["grey_tail_permille"] = tail
    # cnn-polarity: a black-hot camera's networks read 255 - v (cfg.cnn_invert); auto sets no field here: run()
    # measures each recording (auto_resolution), as the demo does
    pol = str(s.get("cnn-polarity", DEFAULT_POLARITY))
    if pol not in ("white-hot", "black-hot", "auto"):
        raise FleetError(f"bad value '{pol}' for cnn-polarity (expected white-hot|black-hot|auto)")
    if pol != "auto":
        fields["cnn_invert"] = int(pol == "black-hot")
    if "thr-mode" in s:
        fields["thr_mode"] = {"constant": 0, "adaptive": 1}[s["thr-mode"]]
    if "hot-thr" in s:
        fields["hot_thr_u8"] = int(s["hot-thr"])
    for k in ("max-candidates", "max-detections", "max-tracks"):
        if k in s:
            fields[k.replace("-", "_")] = int(s[k])
    if "cnn-thr" in s:
        fields["cnn_score_thr_q15"] = max(1, int(math.floor(float(s["cnn-thr"]) * 32768.0 + 0.5)))
    mp = s.get("model")
    none = mp == "none"
    mblob = Path(mp).read_bytes() if mp and not none else None
    model_is_cnn = mblob is not None and _vdm_version(mblob) == 3
    def_cnn = models_dir / "vd_cnn.vdm"
    if "sources" in s:
        sources = _source_bits(s["sources"])
    else:
        use_cnn = "cnn-model" in s or model_is_cnn or (mp is None and def_cnn.is_file())
        sources = SRC_CNN if use_cnn else SRC_HOTSPOT
    fields["sources"] = sources
    cnn = dbn = None
    desc = {"sources": ",".join(n for n, b in (("hotspot", SRC_HOTSPOT), ("contrast", SRC_CONTRAST),
                                               ("window", SRC_WINDOW), ("cnn", SRC_CNN)) if sources & b)}
    if sources & SRC_CNN:
        if "cnn-model" in s:
            cnn, desc["cnn_model"] = Path(s["cnn-model"]).read_bytes(), Path(s["cnn-model"]).name
        elif model_is_cnn:
            cnn, desc["cnn_model"] = mblob, Path(mp).name
        elif def_cnn.is_file():
            cnn, desc["cnn_model"] = def_cnn.read_bytes(), def_cnn.name
        else:
            raise FleetError(f"the cnn source needs a CNN model: cnn-model FILE ({def_cnn} not found)")
        # the second network: cnn-model2, or models/vd_cnn2.vdm beside the default first one ('none': one)
        def_cnn2 = models_dir / "vd_cnn2.vdm"
        m2 = s.get("cnn-model2")
        if m2 is None and "cnn-model" not in s and not model_is_cnn and def_cnn2.is_file():
            m2 = def_cnn2
        from vdtools.bindings import detector as vdet
        m, _keep = vdet._load_cnn(cnn)
        topk = int(m.max_peaks) * (2 if fields["cnn_flip"] else 1)     # the fused flip pass: up to 2 K boxes
        md = int(m.max_peaks)   # top-K, also with the flip pass (the best by score survive)
        if m2 is not None and str(m2) != "none":
            cnn2, desc["cnn_model2"] = Path(m2).read_bytes(), Path(m2).name
            topk, md = max(int(m.max_peaks), int(vdet._load_cnn(cnn2)[0].max_peaks)), 32   # the pair's budgets
            cnn = (cnn, cnn2)   # the pair: cfg.cnn_model2
        if "max-candidates" not in s:
            mc = topk + (64 if sources & SRC_ALL else 0)
            fields["max_candidates"] = min(mc, 4096)
        if "max-detections" not in s:
            fields["max_detections"] = min(md, fields["max_candidates"])
    want_dbn = bool(sources & SRC_ALL)
    if mblob is not None and not model_is_cnn:
        dbn, desc["dbn_model"] = (mblob if want_dbn else None), Path(mp).name
    elif want_dbn and not none:
        cand = models_dir / "vd_dbn_grey.vdm"
        if not cand.is_file():
            cand = next((p for p in sorted(models_dir.glob("*.vdm"), key=lambda p: os.fsencode(p.name))
                         if not p.name.startswith(".") and _vdm_version(p.read_bytes()) in (1, 2)), None)
        if cand is not None:
            dbn, desc["dbn_model"] = cand.read_bytes(), cand.name
    return fields, cnn, dbn, desc


AUTO_SPREAD_FRAMES, AUTO_MIN_FRAMES, AUTO_AGREE_WEIGHT = 64, 16, 0.25   # tools/demo/common/flipagree.h DEMO_AUTORES_*
AUTO_INVERT_MARGIN = 0.025   # ... DEMO_AUTORES_INVERT_MARGIN
DEFAULT_POLARITY = "auto"   # vd_fir_demo's --cnn-polarity default (tools/demo/common/args.c)


def auto_sample(total, parts=AUTO_SPREAD_FRAMES):
    """The frames (0-based, ascending) vd_fir_demo's --cnn-full-res auto measures of a recording of `total`:
    all of a short one, else the middle frame of each of `parts` equal parts, (2k + 1) total / (2 parts)
    (tools/demo/common/flipagree.c demo_autores_sample; other `parts`: vdtools.adapt.window_evidence)."""
    if total <= parts:
        return list(range(total))
    return [(2 * k + 1) * total // (2 * parts) for k in range(parts)]


def grey_decision(rec, fields, spread):
    """vd_fir_demo's --grey-window auto (tools/demo/common/models.c demo_grey_decide) on a recording: the first
    frame the demo reads (spread: the first of the --cnn-full-res auto sample, auto_sample; else frame 0); a 16-bit
    frame with at least dataset.GREY_AUTO_PERMILLE per mille of its samples outside the fixed window (the default
    TLinear 0-51 C, which the fleet's settings do not change) gets the per-frame window. Returns fields with
    grey_mode set."""
    import numpy as np
    from vdtools.bindings import port
    from vdtools.data import dataset as D
    with port.Capture(rec["input"], rec.get("raw_size"), rec.get("raw_format") or "u16") as cap:
        first = (auto_sample(cap.total()) or [0])[0] if spread else 0
        img = None
        for f, _name in cap.frames_at([first]):   # run to its end: the frame is released before the capture closes
            img = port.pixels(f).copy()
    if img is None or img.dtype != np.uint16:
        return dict(fields, grey_mode=0)
    return dict(fields, grey_mode=int(D.grey_outside_permille(img) >= D.GREY_AUTO_PERMILLE))


def polarity_choice(rating, rating_inverted, frames):
    """--cnn-polarity auto's rule (tools/demo/common/flipagree.c demo_autores_decide): the other polarity only
    when its highest rating is above the highest of the frames as they are by more than AUTO_INVERT_MARGIN, and
    only with at least AUTO_MIN_FRAMES frames. Ratings: lists over the resolutions measured, None = no box (0)."""
    best = lambda r: max(0.0 if v is None else v for v in r)
    return frames >= AUTO_MIN_FRAMES and best(rating_inverted) > best(rating) + AUTO_INVERT_MARGIN


def auto_resolution(rec, fields, cnn, res_auto=True, polarity_auto=False):
    """vd_fir_demo's --cnn-full-res / --cnn-polarity auto (tools/demo/common/flipagree.c) on a recording:
    AUTO_SPREAD_FRAMES frames spread over it (auto_sample; as the port reads them) and their mirror images through
    the CNN source alone (the resolved networks and threshold, one pass each, no tracking) at half, full and quarter
    resolution and, with polarity_auto, inverted too (cfg.cnn_invert flipped; without res_auto the resolution
    fields fix stays the run's): the
    mean score of those boxes (score_q8 / 255) and their agreement (boxes of the mirror image, mirrored back,
    matched one to one at IoU >= 0.5: metrics.evaluate.one_to_one; pooled 2 x matched / boxes). The resolution of
    the highest rating, mean score + 1/4 agreement (ties to the lower cfg.cnn_res; full or quarter only when at
    least AUTO_MIN_FRAMES frames were read); the other polarity's when polarity_choice says so. Returns dict(res
    (its name), cnn_res, full, invert (cfg.cnn_invert to run with), frames, total, rating=, score=, agreement=
    [half, full, quarter] in the options' polarity, and with polarity_auto rating_inverted= etc.) (None: no box
    at that resolution or not measured)."""
    import numpy as np
    from vdtools.metrics.evaluate import first_highest, one_to_one, rating_of
    from vdtools.bindings import port
    sub = dict(fields, sources=SRC_CNN, cnn_flip=0, cnn_rescore=0, temporal=False)
    nres = len(CNN_RES_NAMES)
    # the three resolutions, inverted too with polarity_auto: the polarity is chosen over every resolution,
    # whichever the run takes (flipagree.c demo_autores_configs; res_auto or polarity_auto is set)
    ks = list(range(2 * nres if polarity_auto else nres))
    runners, counts, n = {}, {k: [0, 0, 0] for k in ks}, 0   # matched, boxes, qsum
    with port.Capture(rec["input"], rec.get("raw_size"), rec.get("raw_format") or "u16") as cap:
        total = cap.total()
        for f, _name in cap.frames_at(auto_sample(total)):
            img = port.pixels(f).copy()
            mirror = np.ascontiguousarray(img[:, ::-1])
            w = img.shape[1]
            for k in ks:   # cfg.cnn_res + 3 x inverted
                if k not in runners:
                    runners[k] = _Runner(dict(sub, cnn_res=k % nres,
                                              cnn_invert=fields.get("cnn_invert", 0) ^ (k // nres)),
                                         cnn, None, f.width, f.height)
                da, db = runners[k].det.run(img)[0], runners[k].det.run(mirror)[0]
                counts[k][2] += sum(d["score_q8"] for d in da + db)
                a = [tuple(d["box"]) for d in da]
                b = [(w - d["box"][0] - d["box"][2], *d["box"][1:]) for d in db]
                r = one_to_one(a, b, 0.5)
                if r is not None:
                    counts[k][0] += r[0]
                    counts[k][1] += r[1]
            n += 1
    c = lambda k: counts.get(k, [0, 0, 0])
    agree = [2 * c(k)[0] / c(k)[1] if c(k)[1] else None for k in range(2 * nres)]
    score = [c(k)[2] / (255.0 * c(k)[1]) if c(k)[1] else None for k in range(2 * nres)]
    rating = [rating_of(s, a, AUTO_AGREE_WEIGHT) for s, a in zip(score, agree)]
    inv = polarity_auto and polarity_choice([rating[k] for k in ks if k < nres],
                                            [rating[k] for k in ks if k >= nres], n)
    if not res_auto:
        res = fields.get("cnn_res", 0)
    elif n < AUTO_MIN_FRAMES:
        res = 0
    else:
        res = first_highest(rating[nres:] if inv else rating[:nres])
    out = dict(res=CNN_RES_NAMES[res], cnn_res=res, full=res == 1, invert=fields.get("cnn_invert", 0) ^ int(inv),
               frames=n, total=total, rating=rating[:nres], score=score[:nres], agreement=agree[:nres])
    if polarity_auto:
        out.update(rating_inverted=rating[nres:], score_inverted=score[nres:], agreement_inverted=agree[nres:])
    return out


# ------------------------------------------------------------------ one shard (runs on a worker)

def _atomic_write(path, data):
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp.{socket.gethostname()}.{os.getpid()}")
    with open(tmp, "wb") as f:
        f.write(data if isinstance(data, bytes) else data.encode())
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def shard_paths(out_dir, rec, index):
    d = Path(out_dir) / "shards" / rec
    return d / f"{index:05d}.jsonl", d / f"{index:05d}.json"


class _Runner:
    """The C detector set up as vd_fir_demo does (tools/demo/common/models.c demo_detector_cfg) for the first
    frame's size."""

    def __init__(self, fields, cnn, dbn, width, height):
        from vdtools.bindings import detector as vdet
        cfg, self._cnn = vdet.cfg_from_default(fields, *(cnn if isinstance(cnn, tuple) else (cnn,)))
        cfg.max_width, cfg.max_height = width, height
        cfg.max_region_w = min(cfg.max_region_w, width)
        cfg.max_region_h = min(cfg.max_region_h, height)
        self.det = vdet.Detector(model=dbn, clock=True, prepared_cfg=cfg)
        self.width, self.height = width, height


def _json_line(name, seq, w, h, dets):
    """One line exactly as tools/demo/main.c write_json_line prints it."""
    parts = []
    for d in dets:
        tr = str(d["track"]) if d["track"] and d["state"] is not None else "null"
        parts.append(f"{{\"box\": [{d['box'][0]}, {d['box'][1]}, {d['box'][2]}, {d['box'][3]}], "
                     f"\"score\": {d['score_q8'] / 255.0:.3f}, \"track\": {tr}, \"source\": \"{d['source']}\", "
                     f"\"state\": \"{d['state'] or 'new'}\"}}")
    return (f"{{\"frame\": {json.dumps(name, ensure_ascii=False)}, \"seq\": {seq}, \"width\": {w}, \"height\": {h}, "
            f"\"detections\": [{', '.join(parts)}]}}\n")


_GT_CACHE = {}


def _ground_truth(path, classes):
    from vdtools.metrics.evaluate import GroundTruth
    key = (path, str(classes), os.path.getmtime(path))
    if key not in _GT_CACHE:
        _GT_CACHE.clear()
        _GT_CACHE[key] = GroundTruth(path, classes)
    return _GT_CACHE[key]


def _hot_flags(img, boxes):
    """vdtools.data.cnn_data's rule: a vehicle is hot when its box holds a pixel >= the frame's 99th percentile."""
    import numpy as np
    thr = np.percentile(img, 99.0)
    out = []
    for x, y, w, h in boxes:
        x0, y0 = max(int(x), 0), max(int(y), 0)
        roi = img[y0:y0 + max(1, int(h)), x0:x0 + max(1, int(w))]
        out.append(bool(roi.size and roi.max() >= thr))
    return out


def _crop_rect(box, fw, fh):
    """The box with as much context again around it (2x each side, at least 32 px), clipped to the frame."""
    x, y, w, h = box
    cw, ch = max(2 * w, 32), max(2 * h, 32)
    x0 = int(max(0, math.floor(x + w / 2 - cw / 2)))
    y0 = int(max(0, math.floor(y + h / 2 - ch / 2)))
    x1 = int(min(fw, math.ceil(x + w / 2 + cw / 2)))
    y1 = int(min(fh, math.ceil(y + h / 2 + ch / 2)))
    return x0, y0, x1 - x0, y1 - y0


def _mine_frame(img, gts, kinds, stem, tmp_dir, per_frame=False):
    """Crops of one frame's false positives and misses: [(image entry, [annotations])] with the crop PNGs
    written into tmp_dir. Annotations: every ground-truth vehicle (1 Car) and ignore region (4 DontCare)
    that overlaps the crop, clipped and in crop coordinates; a false positive's crop has no vehicle
    where the detector fired (a hard negative), a miss's crop has the missed vehicle (a hard positive). A 16-bit
    frame is cropped from grey as the detector saw it (per_frame: cfg.grey_mode percentile)."""
    import cv2
    import numpy as np
    from vdtools.data.dataset import grey_of_ck, grey_window_ck
    fh, fw = img.shape
    grey = img if img.dtype == np.uint8 else grey_of_ck(img, *grey_window_ck(img)) if per_frame else grey_of_ck(img)
    out = []
    for j, (kind, box, score) in enumerate(kinds):
        cx, cy, cw, ch = _crop_rect(box, fw, fh)
        if cw <= 0 or ch <= 0:
            continue
        fn = f"{stem}_{kind}{j}.png"
        cv2.imwrite(str(Path(tmp_dir) / fn), grey[cy:cy + ch, cx:cx + cw])
        anns = []
        for g in gts:
            if not (g[4] or g[5]):
                continue
            gx0, gy0 = max(g[0], cx), max(g[1], cy)
            gx1, gy1 = min(g[0] + g[2], cx + cw), min(g[1] + g[3], cy + ch)
            if gx1 > gx0 and gy1 > gy0:
                bbox = [round(gx0 - cx, 2), round(gy0 - cy, 2), round(gx1 - gx0, 2), round(gy1 - gy0, 2)]
                anns.append(dict(bbox=bbox, category_id=1 if g[4] else 4))
        out.append((dict(filename=fn, width=cw, height=ch, kind=kind, crop=[cx, cy, cw, ch],
                         box=[round(float(v), 2) for v in box], score=score), anns))
    return out


def run_shard(spec, models, on_frame=None):
    """Runs one shard and commits its files; returns its metrics. spec: a plan() shard plus out, key,
    settings (resolve()'s fields), recording (gt, classes, raw_size, raw_format, meta), mine (dir or None).
    models: (cnn bytes, DBN bytes). on_frame(i): called after frame i is written (progress, fault tests).
    A shard whose metrics file exists with the same key is not run again."""
    from vdtools.bindings import port
    from vdtools.metrics.evaluate import match_flags
    t_start, cpu_start = time.perf_counter(), time.process_time()
    jpath, mpath = shard_paths(spec["out"], spec["rec"], spec["index"])
    if mpath.exists():
        old = json.loads(mpath.read_text())
        if old.get("key") == spec["key"]:
            return old
    rec = spec["recording"]
    tag = f"{socket.gethostname()}.{os.getpid()}"
    jpath.parent.mkdir(parents=True, exist_ok=True)
    jtmp = jpath.with_name(f".{jpath.name}.tmp.{tag}")
    # frames as the demo reads them: one capture over the shard's files
    if len(spec["files"]) == 1:
        src = spec["files"][0]
        lst = None
    else:
        lst = jpath.with_name(f".{jpath.stem}.tmp.{tag}.lst")   # the port knows a list by its extension
        lst.write_text("".join(f + "\n" for f in spec["files"]))
        src = str(lst)
    gt = _ground_truth(rec["gt"], rec.get("classes")) if rec.get("gt") else None
    mine_dir = spec.get("mine")
    mine_tmp = None
    if mine_dir and gt is not None:
        mine_tmp = Path(mine_dir) / "images" / f".tmp.{spec['rec']}.{spec['index']:05d}.{tag}"
        mine_tmp.mkdir(parents=True, exist_ok=True)
    cnn, dbn = models
    by_name = {Path(p).name: p for p in spec["files"]}   # frame name -> file, for the mined crops' references
    runner = None
    stage_us = [0] * len(STAGES)
    acc = dict(frames=0, frames_annotated=0, detections=0, vehicles=0, tp=0, fp=0, ignored=0, hot=0, hot_tp=0,
               confirmed_tp=0, confirmed_fp=0)
    mot_frames = []   # (vehicles, ignore boxes, detections) per annotated frame: tracking metrics of the shard
    ap_flags, names, mined = [], [], []
    t_det = 0.0
    try:
        with open(jtmp, "w") as jf, port.Capture(src, rec.get("raw_size"), rec.get("raw_format") or "u16") as cap:
            for i, (f, name) in enumerate(cap):
                if runner is None:
                    runner = _Runner(spec["settings"], cnn, dbn, f.width, f.height)
                elif (f.width, f.height) != (runner.width, runner.height):
                    raise FleetError(f"{name}: {f.width}x{f.height}, but the shard started with "
                                     f"{runner.width}x{runner.height} frames")
                t0 = time.perf_counter()
                img = port.pixels(f)
                dets, st = runner.det.run(img, seq=f.seq)
                t_det += time.perf_counter() - t0
                for k, s in enumerate(STAGES):
                    stage_us[k] += st["time_us"][s]
                jf.write(_json_line(name, f.seq, f.width, f.height, dets))
                names.append(name)
                acc["frames"] += 1
                acc["detections"] += len(dets)
                boxes = gt.boxes(name, f.width, f.height) if gt is not None else None
                if boxes is not None:
                    pairs = [(d["box"], round(d["score_q8"] / 255.0, 3)) for d in dets]
                    flags, matched = match_flags(pairs, boxes)
                    order = sorted(range(len(pairs)), key=lambda i2: (-pairs[i2][1], i2))
                    veh = [k for k, g in enumerate(boxes) if g[4]]
                    hot = _hot_flags(img, [boxes[k][:4] for k in veh]) if veh else []
                    acc["frames_annotated"] += 1
                    acc["vehicles"] += len(veh)
                    acc["tp"] += sum(1 for _, t in flags if t == 1)
                    acc["fp"] += sum(1 for _, t in flags if t == 0)
                    acc["ignored"] += sum(1 for _, t in flags if t is None)
                    acc["hot"] += sum(hot)
                    acc["hot_tp"] += sum(1 for k, h in zip(veh, hot) if h and k in matched)
                    ap_flags += [[s, t] for s, t in flags if t is not None]
                    cflags, _ = match_flags([p for p, d in zip(pairs, dets) if d["state"] == "confirmed"], boxes)
                    acc["confirmed_tp"] += sum(1 for _, t in cflags if t == 1)
                    acc["confirmed_fp"] += sum(1 for _, t in cflags if t == 0)
                    mot_frames.append(([tuple(g[:4]) for g in boxes if g[4]], [tuple(g[:4]) for g in boxes if g[5]],
                                       [dict(box=d["box"], track=d["track"], state=d["state"]) for d in dets]))
                    if mine_tmp is not None:
                        kinds = [("fp", pairs[order[j]][0], pairs[order[j]][1])
                                 for j, (_, t) in enumerate(flags) if t == 0]
                        kinds += [("miss", list(boxes[k][:4]), None) for k in veh if k not in matched]
                        if kinds:
                            # unique per recording even when a list names two files alike
                            stem = f"{spec['rec']}_{spec['index']:05d}_{i:05d}_{Path(name).stem.replace('#', '_')}"
                            per_frame = bool(spec["settings"].get("grey_mode"))   # the detector's grey window
                            for im, anns in _mine_frame(img, boxes, kinds, stem, mine_tmp, per_frame):
                                im.update(recording=spec["rec"], frame=name, seq=int(f.seq),
                                          frame_path=by_name.get(name.split("#")[0]))
                                mined.append((im, anns))
                if on_frame is not None:
                    on_frame(i)
            jf.flush()
            os.fsync(jf.fileno())
        if spec["names"] is not None and names != spec["names"]:
            raise FleetError(f"shard {spec['rec']}/{spec['index']}: read {len(names)} frames, expected "
                             f"{len(spec['names'])} ({spec['files'][0]} ...)")
        worker = "local"
        try:
            from distributed import get_worker
            worker = get_worker().address
        except (ImportError, ValueError):
            pass
        mot = mot_conf = None
        if mot_frames:   # tracking metrics (py-motmetrics): the tracker starts afresh at each shard
            from vdtools.metrics import tracking as T
            mot = T.sequence_counts(mot_frames)
            mot_conf = T.sequence_counts(mot_frames, lambda d: d["state"] == "confirmed")
        metrics = dict(key=spec["key"], rec=spec["rec"], index=spec["index"], meta=rec.get("meta", {}),
                       mot=mot, mot_confirmed=mot_conf,
                       names=names, worker=worker, pid=os.getpid(), wall_s=time.perf_counter() - t_start,
                       cpu_s=time.process_time() - cpu_start,
                       detector_s=t_det, stage_us=dict(zip(STAGES, stage_us)), ap_flags=ap_flags,
                       has_gt=gt is not None, mined=0, **acc)
        # commit: crops, then the mining fragment, then the detections, and last the metrics (the shard's
        # completion mark): a shard killed before the last rename is run again from scratch
        if mine_tmp is not None:
            final = Path(mine_dir) / "images"
            for im, _ in mined:
                os.replace(mine_tmp / im["filename"], final / im["filename"])
            frag = Path(mine_dir) / "shards" / spec["rec"] / f"{spec['index']:05d}.json"
            _atomic_write(frag, json.dumps([[im, anns] for im, anns in mined]))
            metrics["mined"] = len(mined)
        os.replace(jtmp, jpath)
        _atomic_write(mpath, json.dumps(metrics))
        return metrics
    finally:
        for p in (jtmp, lst):
            if p is not None and p.exists():
                p.unlink()
        if mine_tmp is not None and mine_tmp.exists():
            shutil.rmtree(mine_tmp, ignore_errors=True)


# ------------------------------------------------------------------ driver

def _key(shard, fields, models):
    h = hashlib.sha256()
    h.update(json.dumps([VERSION, shard["rec"], shard["index"], shard["files"], fields], sort_keys=True).encode())
    for m in models:
        for b in (m if isinstance(m, tuple) else (m,)):   # a pair of CNN models
            h.update(hashlib.sha256(b or b"").digest())
    return h.hexdigest()[:24]


def _start_client(scheduler, workers):
    from distributed import Client, LocalCluster
    if scheduler:
        return Client(scheduler), None
    cluster = LocalCluster(n_workers=workers or os.cpu_count() or 1, threads_per_worker=1, processes=True,
                           dashboard_address=":0", silence_logs=50)
    return Client(cluster), cluster


def _clean_tmp(out_dir, mine_dir):
    """Removes temporary files of killed attempts (never a committed file)."""
    for root in (Path(out_dir) / "shards", Path(mine_dir) / "images" if mine_dir else None):
        if root is None or not root.exists():
            continue
        for p in list(root.rglob(".*.tmp.*")) + list(root.glob(".tmp.*")):
            if p.is_dir():
                shutil.rmtree(p, ignore_errors=True)
            elif p.exists():
                p.unlink()


def run(manifest, out_dir, settings=None, scheduler=None, workers=None, shard_frames=256, mine=None,
        retries=2, shard_fn=None, client=None, log=print):
    """The whole evaluation; returns the report dict (also DIR/report.json and DIR/report.md).
    shard_fn: the task (default run_shard; tests wrap it to inject faults); client: an existing
    distributed.Client (then scheduler/workers are not used). Raises FleetError when a shard fails for
    good or a frame is missing or duplicated."""
    out_dir = Path(out_dir).resolve()
    recs = read_manifest(manifest)
    fields, cnn, dbn, desc = resolve(settings)
    shards = plan(recs, shard_frames)
    byid = {r["id"]: r for r in recs}
    # cnn-full-res auto (the default with the cnn source): each recording's own choice, as the demo makes it
    rec_fields, cnn_input = {r["id"]: fields for r in recs}, None
    auto_res = "cnn_res" not in fields and fields["sources"] & SRC_CNN
    auto_pol = "cnn_invert" not in fields and fields["sources"] & SRC_CNN   # cnn-polarity auto
    if "grey_mode" not in fields:   # grey-window auto: each recording's first frame read decides, as in the demo
        for r in recs:
            rec_fields[r["id"]] = grey_decision(r, fields, bool(auto_res or auto_pol))
    if auto_res or auto_pol:
        cnn_input = {}
        for r in recs:
            c = auto_resolution(r, rec_fields[r["id"]], cnn, res_auto=bool(auto_res), polarity_auto=bool(auto_pol))
            cnn_input[r["id"]] = c
            rec_fields[r["id"]] = dict(rec_fields[r["id"]], cnn_res=c["cnn_res"], cnn_invert=c["invert"])
    mine_dir = str(Path(mine).resolve()) if mine else None
    if mine_dir:
        (Path(mine_dir) / "images").mkdir(parents=True, exist_ok=True)
    _clean_tmp(out_dir, mine_dir)
    todo, results = [], {}
    for s in shards:
        r = byid[s["rec"]]
        f_r = rec_fields[s["rec"]]
        s.update(out=str(out_dir), key=_key(s, f_r, (cnn, dbn)), settings=f_r, mine=mine_dir,
                 recording=dict(gt=r["gt"], classes=r["classes"], raw_size=r["raw_size"],
                                raw_format=r["raw_format"], meta=r["meta"]))
        _, mpath = shard_paths(out_dir, s["rec"], s["index"])
        if mpath.exists():
            old = json.loads(mpath.read_text())
            if old.get("key") != s["key"]:
                raise FleetError(f"{mpath} holds a result of other settings, models or frames: use another --out")
            if mine_dir and old.get("has_gt") and not (Path(mine_dir) / "shards" / s["rec"] /
                                                       f"{s['index']:05d}.json").exists():
                mpath.unlink()   # run again for its hard examples
                todo.append(s)
                continue
            results[(s["rec"], s["index"])] = old
        else:
            todo.append(s)
    log(f"vdtools.evaluation.fleet: {len(recs)} recordings, {len(shards)} shards ({len(shards) - len(todo)} complete, "
        f"{len(todo)} to run); " + ", ".join(f"{k} {v}" for k, v in desc.items()))
    if cnn_input:
        some = lambda ids: f" ({', '.join(ids[:8])}{' ...' if len(ids) > 8 else ''})" if ids else ""
        for name in CNN_RES_NAMES[1:] if auto_res else ():
            ids = sorted(k for k, v in cnn_input.items() if v["res"] == name)
            log(f"vdtools.evaluation.fleet: cnn-full-res auto: {name} resolution for {len(ids)} of {len(recs)} "
                f"recordings" + some(ids))
        if auto_pol:
            ids = sorted(k for k, v in cnn_input.items() if v["invert"])
            log(f"vdtools.evaluation.fleet: cnn-polarity auto: black-hot for {len(ids)} of {len(recs)} recordings"
                + some(ids))
    cluster = None
    n_workers = 0
    wall = 0.0
    if todo:
        from distributed import as_completed
        own = client is None
        if own:
            client, cluster = _start_client(scheduler, workers)
        try:
            n_workers = len(client.scheduler_info()["workers"])
            mfut = client.scatter((cnn, dbn), broadcast=True)
            t0 = time.perf_counter()   # cluster start-up is not part of the throughput
            fn = shard_fn or run_shard
            futs = {client.submit(fn, s, mfut, retries=retries, pure=False,
                                  key=f"vd-shard-{s['rec']}-{s['index']:05d}-{s['key'][:8]}"): s for s in todo}
            failed = []
            for fut in as_completed(futs):
                s = futs[fut]
                if fut.status == "finished":
                    results[(s["rec"], s["index"])] = fut.result()
                else:
                    failed.append((s, repr(fut.exception())))
            if failed:
                raise FleetError(f"{len(failed)} shards failed for good (rerun resumes): " +
                                 "; ".join(f"{s['rec']}/{s['index']}: {e}" for s, e in failed[:5]))
            wall = time.perf_counter() - t0
        finally:
            if own:
                client.close()
                if cluster is not None:
                    cluster.close()
    _clean_tmp(out_dir, mine_dir)
    ran = sum(results[(s["rec"], s["index"])]["frames"] for s in todo)
    report = reduce(recs, shards, results, out_dir, wall, n_workers, desc, mine_dir, frames_run=ran,
                    cnn_input=cnn_input)
    log(format_summary(report))
    return report


def _merge_recordings(recs, shards, out_dir):
    """DIR/recordings/<id>.jsonl: the shards in order. Returns {id: frames} after checking every frame
    exactly once (names as planned; shard files agree with their metrics)."""
    per = {}
    for s in shards:
        per.setdefault(s["rec"], []).append(s)
    counts = {}
    problems = []
    for rec in recs:
        lines, names = [], []
        for s in sorted(per[rec["id"]], key=lambda s: s["index"]):
            jpath, mpath = shard_paths(out_dir, s["rec"], s["index"])
            m = json.loads(mpath.read_text())
            got = jpath.read_text().splitlines(keepends=True)
            gnames = [json.loads(x)["frame"] for x in got]
            if gnames != m["names"]:
                problems.append(f"{jpath}: {len(gnames)} lines, metrics list {len(m['names'])} frames")
            if s["names"] is not None and gnames != s["names"]:
                problems.append(f"{jpath}: frames differ from the plan ({len(gnames)} vs {len(s['names'])})")
            lines += got
            names += gnames
        expected = [n for s in per[rec["id"]] if s["names"] is not None for n in s["names"]]
        if all(s["names"] is not None for s in per[rec["id"]]) and names != expected:
            problems.append(f"recording {rec['id']}: {len(names)} frames out, {len(expected)} in")
        seen = {}
        for n in names:
            seen[n] = seen.get(n, 0) + 1
        dup = [n for n, c in seen.items() if c > 1]
        if dup and len(set(expected)) == len(expected):
            problems.append(f"recording {rec['id']}: frames twice: {dup[:3]}")
        _atomic_write(Path(out_dir) / "recordings" / f"{rec['id']}.jsonl", "".join(lines))
        counts[rec["id"]] = len(names)
    if problems:
        raise FleetError("exactly-once check failed: " + "; ".join(problems[:5]))
    return counts


def _ap(flags, n_pos):
    from vdtools.metrics.evaluate import ap_from_flags
    return ap_from_flags([tuple(f) for f in flags], n_pos)


def _group_figures(ms):
    from vdtools.metrics import tracking as T
    tot = {k: sum(m.get(k, 0) for m in ms)
           for k in ("frames_annotated", "vehicles", "tp", "fp", "ignored", "hot", "hot_tp", "confirmed_tp",
                     "confirmed_fp")}
    mot, mot_c = {}, {}
    for m in ms:
        mot = T.add_counts(mot, m.get("mot") or {})
        mot_c = T.add_counts(mot_c, m.get("mot_confirmed") or {})
    ms_mot = T.scores(mot) if mot.get("num_objects") else dict(mota=None, idf1=None, id_switches=0)
    ms_mot_c = T.scores(mot_c) if mot_c.get("num_objects") else dict(mota=None, idf1=None, id_switches=0)
    det = tot["tp"] + tot["fp"]
    cold = tot["vehicles"] - tot["hot"]
    r = lambda a, b: a / b if b else None
    ap = _ap([f for m in ms for f in m["ap_flags"]], tot["vehicles"])[0]
    cdet = tot["confirmed_tp"] + tot["confirmed_fp"]
    return dict(tot, ap50=None if ap != ap else ap, tp_rate=r(tot["tp"], tot["vehicles"]), fp_rate=r(tot["fp"], det),
                confirmed_tp_rate=r(tot["confirmed_tp"], tot["vehicles"]), confirmed_fp_rate=r(tot["confirmed_fp"], cdet),
                mota=ms_mot["mota"], idf1=ms_mot["idf1"], id_switches=ms_mot["id_switches"],
                confirmed_mota=ms_mot_c["mota"], confirmed_idf1=ms_mot_c["idf1"],
                confirmed_id_switches=ms_mot_c["id_switches"],
                fppi=r(tot["fp"], tot["frames_annotated"]), hot_tp_rate=r(tot["hot_tp"], tot["hot"]),
                cold_tp_rate=r(tot["tp"] - tot["hot_tp"], cold), cold=cold)


def reduce(recs, shards, results, out_dir, wall_s, n_workers, desc, mine_dir=None, frames_run=0, cnn_input=None):
    """One report from the shard metrics (and the merged recordings): throughput, stages, accuracy.
    frames_run: frames of the shards this run computed (the others were complete already); cnn_input: the
    auto resolution choice per recording (auto_resolution), or None."""
    counts = _merge_recordings(recs, shards, out_dir)
    ms = [results[(s["rec"], s["index"])] for s in shards]
    frames = sum(m["frames"] for m in ms)
    if frames != sum(counts.values()):
        raise FleetError(f"exactly-once check failed: metrics count {frames} frames, recordings {sum(counts.values())}")
    workers = {}
    for m in ms:
        w = workers.setdefault(m["worker"], dict(shards=0, frames=0, busy_s=0.0, detector_s=0.0, cpu_s=0.0))
        w["cpu_s"] += m.get("cpu_s", 0.0)
        w["shards"] += 1
        w["frames"] += m["frames"]
        w["busy_s"] += m["wall_s"]
        w["detector_s"] += m["detector_s"]
    for w in workers.values():
        w["fps_busy"] = w["frames"] / w["busy_s"] if w["busy_s"] else None
        w["fps_detector"] = w["frames"] / w["detector_s"] if w["detector_s"] else None
        w["fps_cpu"] = w["frames"] / w["cpu_s"] if w["cpu_s"] else None
    stage_ms = {s: sum(m["stage_us"][s] for m in ms) / 1000.0 / max(frames, 1) for s in STAGES}
    busy = sum(m["wall_s"] for m in ms)
    det_s = sum(m["detector_s"] for m in ms)
    report = dict(recordings=len(recs), shards=len(shards), frames=frames, detections=sum(m["detections"] for m in ms),
                  settings=desc, workers_in_cluster=n_workers, wall_s=wall_s,
                  frames_run=frames_run, fps_total=frames_run / wall_s if wall_s > 0 and n_workers else None,
                  shard_busy_s=busy, detector_s=det_s, cpu_s=sum(m.get("cpu_s", 0.0) for m in ms),
                  outside_detector_ms_per_frame=1000.0 * (busy - det_s) / max(frames, 1),
                  stage_ms_per_frame=stage_ms, workers=workers, exactly_once=True)
    gt_ms = [m for m in ms if m["has_gt"]]
    if gt_ms:
        acc = {"all": _group_figures(gt_ms)}
        for key in ("camera", "daynight", "date"):
            vals = sorted({str(m["meta"].get(key)) for m in gt_ms if key in m["meta"]})
            for v in vals:
                acc[f"{key}={v}"] = _group_figures([m for m in gt_ms if str(m["meta"].get(key)) == v])
        report["accuracy"] = acc
        # per recording: AP, TP/FP and the tracking metrics of each (the tracker reset per shard; with
        # --shard-frames 0 per recording)
        report["recordings_accuracy"] = {rid: _group_figures([m for m in gt_ms if m["rec"] == rid])
                                         for rid in dict.fromkeys(m["rec"] for m in gt_ms)}
    if cnn_input is not None:
        report["cnn_input"] = cnn_input
    if mine_dir:
        report["mined"] = _merge_mined(recs, shards, mine_dir)
    _atomic_write(Path(out_dir) / "report.json", json.dumps(report, indent=1))
    _atomic_write(Path(out_dir) / "report.md", format_summary(report) + "\n")
    return report


def _merge_mined(recs, shards, mine_dir):
    """mine_dir/annotations.json (the HIT-UAV COCO-like layout vdtools.data.dataset reads: images with
    "filename", boxes under "annotation" and "annotations", 1 Car / 4 DontCare) from the shard fragments."""
    from vdtools.data.clip import CATEGORIES
    gt_recs = {r["id"] for r in recs if r["gt"]}
    images, anns = [], []
    for s in shards:
        if s["rec"] not in gt_recs:
            continue
        frag = Path(mine_dir) / "shards" / s["rec"] / f"{s['index']:05d}.json"
        for im, a in json.loads(frag.read_text()):
            im = dict(im, id=len(images))
            images.append(im)
            for x in a:
                anns.append(dict(x, id=len(anns), image_id=im["id"], iscrowd=0,
                                 area=round(x["bbox"][2] * x["bbox"][3], 2)))
    doc = dict(info={"description": "hard examples mined by vdtools.evaluation.fleet: false positives (kind fp) and "
                                    "missed vehicles (kind miss), crops with their frame references"},
               categories=CATEGORIES, images=images, annotation=anns, annotations=anns)
    _atomic_write(Path(mine_dir) / "annotations.json", json.dumps(doc))
    return dict(crops=len(images), fp=sum(1 for i in images if i["kind"] == "fp"),
                miss=sum(1 for i in images if i["kind"] == "miss"))


def format_summary(r):
    pct = lambda v: "n/a" if v is None else f"{100 * v:.2f}%"
    lines = [f"vdtools.evaluation.fleet: {r['recordings']} recordings, {r['shards']} shards, {r['frames']} frames "
             f"(each exactly once), {r['detections']} detections"]
    if r["fps_total"]:
        lines.append(f"  {r['fps_total']:.1f} frames/s total ({r['frames_run']} frames run now) over "
                     f"{r['workers_in_cluster']} workers "
                     f"({r['wall_s']:.2f} s wall); in the tasks outside the detector (decoding, JSON, matching) "
                     f"{r['outside_detector_ms_per_frame']:.2f} ms per frame")
    for w, v in sorted(r["workers"].items()):
        if v["fps_busy"]:
            lines.append(f"  worker {w}: {v['shards']} shards, {v['frames']} frames, {v['fps_busy']:.1f} frames/s "
                         f"busy, {v['fps_detector']:.1f} frames/s in the detector, "
                         f"{v['fps_cpu']:.1f} frames per CPU second")
    lines.append("  ms per frame: " + ", ".join(f"{k} {v:.2f}" for k, v in r["stage_ms_per_frame"].items() if v > 0))
    for g, a in r.get("accuracy", {}).items():
        ap = "n/a" if a["ap50"] is None else f"{100 * a['ap50']:.1f}"
        lines.append(f"  [{g}] {a['frames_annotated']} frames, {a['vehicles']} vehicles: AP@0.5 {ap}  "
                     f"TP rate {pct(a['tp_rate'])}  FP rate {pct(a['fp_rate'])}  "
                     f"(hot {pct(a['hot_tp_rate'])} of {a['hot']}, cold {pct(a['cold_tp_rate'])} of {a['cold']}); "
                     f"MOTA {pct(a.get('mota'))} IDF1 {pct(a.get('idf1'))} ID switches {a.get('id_switches')}; "
                     f"confirmed TP {pct(a.get('confirmed_tp_rate'))} FP {pct(a.get('confirmed_fp_rate'))}")
    recs_acc = r.get("recordings_accuracy", {})
    if recs_acc:
        lines.append("  per recording: AP@0.5 | TP / FP | MOTA | IDF1 | ID switches")
        for g, a in recs_acc.items():
            ap = "n/a" if a["ap50"] is None else f"{100 * a['ap50']:.1f}"
            lines.append(f"    {g}: {a['frames_annotated']} frames, {a['vehicles']} vehicles: {ap} | "
                         f"{pct(a['tp_rate'])} / {pct(a['fp_rate'])} | {pct(a.get('mota'))} | {pct(a.get('idf1'))} | "
                         f"{a.get('id_switches')}")
    if "mined" in r:
        m = r["mined"]
        lines.append(f"  mined {m['crops']} crops ({m['fp']} false positives, {m['miss']} misses)")
    return "\n".join(lines)


def shared_data_manifest(data_dir, out_dir, split="test"):
    """Writes out_dir/manifest.jsonl over ../shared/data (read in place, never copied): one recording per
    MSRS block (day/night, frame number // 40: continuous drive samples), per HIT-UAV flight (T_H_A) and
    the HIT-UAV sequence; each a list file of frame paths, with its ground truth and camera / daynight.
    Only the frames of `split` (vdtools.data.dataset.assign_splits: "test" by default, so that the accuracy a
    fleet report prints is never measured on frames the shipped models trained on; "all" = every frame).
    Returns the manifest path."""
    data_dir, out_dir = Path(data_dir).resolve(), Path(out_dir).resolve()
    keep = None
    if split != "all":
        from vdtools.data import dataset as D
        frames = D.all_frames(data_dir, synth=False)
        split_of = D.assign_splits(frames)
        keep = {Path(f.path).resolve() for f in frames if split_of[f.group] == split}
    lists = out_dir / "lists"
    lists.mkdir(parents=True, exist_ok=True)
    rows = []
    groups = {}
    for p in sorted((data_dir / "msrs" / "images").glob("*.png")):
        dn = "day" if p.stem.endswith("D") else "night"
        if keep is None or p.resolve() in keep:
            groups.setdefault((dn, int(p.stem[:-1]) // 40), []).append(p)
    for (dn, blk), ps in sorted(groups.items()):
        rid = f"msrs-{dn}-{blk:02d}"
        (lists / f"{rid}.lst").write_text("".join(f"{p}\n" for p in ps))
        rows.append(dict(id=rid, input=f"lists/{rid}.lst", gt=str(data_dir / "msrs" / "labels"), camera="msrs",
                         daynight=dn))
    for sub, cam in (("frames", "hit-uav"), ("sequence-0_100", "hit-uav-seq")):
        flights = {}
        for p in sorted((data_dir / "hit-uav" / sub / "images").glob("*.jpg")):
            if keep is None or p.resolve() in keep:
                flights.setdefault("_".join(p.stem.split("_")[:3]), []).append(p)
        for f, ps in sorted(flights.items()):
            rid = f"{cam}-{f}"
            (lists / f"{rid}.lst").write_text("".join(f"{p}\n" for p in ps))
            rows.append(dict(id=rid, input=f"lists/{rid}.lst", gt=str(data_dir / "hit-uav" / sub / "annotations.json"),
                             camera=cam, daynight="day" if f.startswith("0_") else "night"))
    m = out_dir / "manifest.jsonl"
    m.write_text("".join(json.dumps(r) + "\n" for r in rows))
    return m


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python3 -m vdtools.evaluation.fleet", description=__doc__.split("\n\n")[0])
    ap.add_argument("manifest", nargs="?", help="JSON Lines or CSV, one recording per row")
    ap.add_argument("--out", help="output directory (shards/, recordings/, report.json, report.md)")
    ap.add_argument("--shared-manifest", metavar="DIR", help="only write DIR/manifest.jsonl over ../shared/data "
                    "(or $VD_DATA_DIR): MSRS blocks, HIT-UAV flights and sequence, each a recording")
    ap.add_argument("--split", default="test", choices=("test", "val", "train", "all"),
                    help="--shared-manifest: frames of this split only (default test: held out from training)")
    ap.add_argument("--scheduler", help="address of an existing Dask scheduler (default: a LocalCluster here)")
    ap.add_argument("--workers", type=int, help="LocalCluster worker processes (default: one per core)")
    ap.add_argument("--shard-frames", type=int, default=256, help="frames per shard (0: whole recordings)")
    ap.add_argument("--retries", type=int, default=2, help="retries of a shard that raises")
    ap.add_argument("--mine", metavar="DIR", help="write false positives and misses (crops + frame references)")
    ap.add_argument("--config", help="detector settings, a JSON object with vd_fir_demo's names")
    for k in SETTINGS:
        ap.add_argument(f"--{k}", dest="set_" + k.replace("-", "_"), help=f"as vd_fir_demo --{k}")
    a = ap.parse_args(argv)
    if a.shared_manifest:
        print(shared_data_manifest(clib.DATA_DIR, a.shared_manifest, a.split))
        return 0
    if not a.manifest or not a.out:
        ap.error("MANIFEST and --out are required")
    settings = json.loads(Path(a.config).read_text()) if a.config else {}
    for k in SETTINGS:
        v = getattr(a, "set_" + k.replace("-", "_"))
        if v is not None:
            settings[k] = v
    try:
        run(a.manifest, a.out, settings, scheduler=a.scheduler, workers=a.workers, shard_frames=a.shard_frames,
            mine=a.mine, retries=a.retries)
    except FleetError as e:
        print(f"vdtools.evaluation.fleet: error: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
