# SPDX-License-Identifier: MIT
"""ctypes bindings of the C detector (lib/include/vd/detector.h) for evaluation tools.

    from vdtools.bindings.detector import Detector
    det = Detector(max_width=640, max_height=512, thr_mode="adaptive", model="models/x.vdm")
    dets, stats = det.run(frame)          # frame: 2-D uint8 or uint16 numpy array
    # dets: list of dicts {box, candidate, score, score_q8, contour_length, track, state, flags, ...}
    # stats: dict of per-stage counts (hot_pixels, components, kept, refined, verified, ...)

Configuration keywords are the fields of vd_detector_cfg_t (0 = the paper's default);
thr_mode also accepts "constant" / "adaptive", and temporal=True enables temporal.h.
`exp_tables()` regenerates the exp() tables of lib/src/detector/temporal.c.
"""
import ctypes as C
import math
from pathlib import Path

import numpy as np

from vdtools.bindings import clib, components
from vdtools.bindings.sources import ContrastCfg, WindowsCfg, windows_cfg as _windows_cfg

THR_CONSTANT, THR_ADAPTIVE = 0, 1
# cfg.cnn_res (VD_DETECTOR_CNN_RES_HALF, _FULL, _QUARTER) is the index: its name, and the frame pixels per network
# input pixel and axis (the detector's vd__detector_cnn_div)
CNN_RES_NAMES = ("half", "full", "quarter")
CNN_RES_DIV = (2, 1, 4)
FLAG_UNVERIFIED, FLAG_DECIMATED, FLAG_CONTOUR_TRUNC, FLAG_RECOVERED = 0x01, 0x02, 0x04, 0x08
STATES = {0: None, 1: "new", 2: "confirmed", 3: "recovered"}
STAGES = ("threshold", "components", "refine", "contour", "sample", "dbn", "nms", "temporal", "contrast", "windows",
          "cnn", "total")
SRC_HOTSPOT, SRC_CONTRAST, SRC_WINDOW, SRC_CNN = 0x01, 0x02, 0x04, 0x08
SRC_ALL = 0x07   # VD_DETECTOR_SRC_ALL: the paper pipeline's three sources, not the CNN
SOURCE_BITS = {"hotspot": SRC_HOTSPOT, "contrast": SRC_CONTRAST, "window": SRC_WINDOW, "cnn": SRC_CNN}
SOURCE_NAMES = {1: "hotspot", 2: "window", 3: "contrast", 4: "cnn"}

CLOCK_FN = C.CFUNCTYPE(C.c_uint32, C.c_void_p)


# One mirror per C struct (tests/python/test_bindings_layout.py checks them against the headers).
Calib = clib.Calib
CcRules = components.Rules


class TemporalCfg(C.Structure):
    _fields_ = [("sigma_x", C.c_uint16), ("sigma_y", C.c_uint16), ("sigma_w", C.c_uint16),
                ("sigma_h", C.c_uint16), ("weight_c_q15", C.c_uint16), ("match_thr_q15", C.c_uint16),
                ("recover_thr_q15", C.c_uint16), ("confirm_frames", C.c_uint8), ("max_misses", C.c_uint8),
                ("search_radius", C.c_uint8), ("search_step", C.c_uint8), ("sigma_rel_q8", C.c_uint16),
                ("max_motion", C.c_uint16), ("flags", C.c_uint8), ("coast_frames", C.c_uint8),
                ("score_alpha_q15", C.c_uint16), ("score_weight_q15", C.c_uint16), ("score_gain_q15", C.c_uint16),
                ("new_penalty_q15", C.c_uint16), ("confirm_hi_q15", C.c_uint16), ("confirm_lo_q15", C.c_uint16),
                ("miss_decay_q15", C.c_uint16), ("reserved2", C.c_uint16)]


TEMPORAL_SCORES = 0x10   # vd/temporal.h VD_TEMPORAL_SCORES


class Detection(C.Structure):
    _fields_ = [("box", clib.Rect), ("candidate", clib.Rect), ("contour_length", C.c_uint32),
                ("track_id", C.c_uint32), ("complexity_q15", C.c_uint16), ("score_q8", C.c_uint8),
                ("source", C.c_uint8), ("state", C.c_uint8), ("flags", C.c_uint8), ("hot_thr", C.c_uint8),
                ("reserved", C.c_uint8)]


# void (*on_candidate)(void *user, const vd_detection_t *cand)
CANDIDATE_FN = C.CFUNCTYPE(None, C.c_void_p, C.POINTER(Detection))


class DetectorCfg(C.Structure):
    # vd_detector_cfg_t in header order (field order may change between 0.x minor versions).
    _fields_ = [("max_width", C.c_uint32), ("max_height", C.c_uint32),
                ("sources", C.c_uint8), ("dedup_iou_q15", C.c_uint16),
                ("thr_mode", C.c_uint8), ("hot_thr_u8", C.c_uint8), ("adaptive_floor_u8", C.c_uint8),
                ("adaptive_permille", C.c_uint16), ("hot_thr_ck", C.c_int32), ("calib", Calib),
                ("grey_lo_ck", C.c_int32), ("grey_hi_ck", C.c_int32), ("grey_mode", C.c_uint8),
                ("grey_tail_permille", C.c_uint16), ("rules", CcRules),
                ("expand_w_q8", C.c_uint16), ("expand_h_q8", C.c_uint16), ("median_ksize", C.c_uint8),
                ("edge_step", C.c_uint8), ("window", C.c_uint8),
                ("contrast", ContrastCfg), ("win_min_std_u8", C.c_uint8), ("windows", WindowsCfg),
                ("cnn_model", C.c_void_p), ("cnn_model2", C.c_void_p), ("cnn_score_thr_q15", C.c_uint16),
                ("cnn_rescore", C.c_uint8), ("cnn_flip", C.c_uint8), ("cnn_res", C.c_uint8),
                ("cnn_invert", C.c_uint8),
                ("verifier", C.c_uint8), ("score_thr_q8", C.c_uint8), ("boost_model", C.c_void_p),
                ("boost_thr_offset", C.c_int32),
                ("nms_iou_q15", C.c_uint16), ("temporal", C.c_bool), ("max_tracks", C.c_uint16),
                ("temporal_cfg", TemporalCfg),
                ("max_runs", C.c_uint32), ("max_components", C.c_uint16), ("max_candidates", C.c_uint16),
                ("max_detections", C.c_uint16), ("max_region_w", C.c_uint16), ("max_region_h", C.c_uint16),
                ("clock_us", CLOCK_FN), ("clock_user", C.c_void_p),
                ("on_candidate", CANDIDATE_FN), ("candidate_user", C.c_void_p)]


STAT_FIELDS = ("hot_thr_u8", "hot_thr_raw", "hot_pixels", "components", "kept", "refined", "verified",
               "suppressed", "detections", "recovered", "decimated", "overflow_components",
               "overflow_candidates", "overflow_contours", "overflow_detections", "overflow_tracks",
               "runs", "overflow_runs", "cand_hotspot", "cand_contrast", "cand_window", "windows",
               "windows_passed", "deduplicated", "cnn_boxes", "cand_cnn", "grey_lo_raw", "grey_hi_raw")


class Stats(C.Structure):
    _fields_ = [(n, C.c_uint32) for n in STAT_FIELDS] + [("time_us", C.c_uint32 * len(STAGES))]


# vd_detector_t / vd_dbn_model_t are opaque here: generous aligned buffers (both are < 2 KiB in C).
_DET_BYTES = 8192
_MODEL_BYTES = 4096

_bound = False


def _lib():
    global _bound
    lib = clib.load()
    if not _bound:
        lib.vd_detector_cfg_default.argtypes = [C.POINTER(DetectorCfg)]
        lib.vd_detector_cfg_default.restype = None
        lib.vd_detector_workspace_size.argtypes = [C.POINTER(DetectorCfg), C.c_void_p, C.POINTER(C.c_size_t)]
        lib.vd_detector_workspace_size.restype = C.c_int
        lib.vd_detector_init.argtypes = [C.c_void_p, C.POINTER(DetectorCfg), C.c_void_p, C.c_void_p, C.c_size_t]
        lib.vd_detector_init.restype = C.c_int
        lib.vd_detector_run.argtypes = [C.c_void_p, C.POINTER(clib.Frame), C.POINTER(Detection), C.c_size_t,
                                        C.POINTER(C.c_size_t)]
        lib.vd_detector_run.restype = C.c_int
        lib.vd_detector_last_stats.argtypes = [C.c_void_p]
        lib.vd_detector_last_stats.restype = C.POINTER(Stats)
        lib.vd_dbn_load.argtypes = [C.c_void_p, C.c_void_p, C.c_size_t]
        lib.vd_dbn_load.restype = C.c_int
        _bound = True
    return lib


def default_cfg():
    """vd_detector_cfg_default() as a dict of its scalar fields."""
    c = DetectorCfg()
    _lib().vd_detector_cfg_default(C.byref(c))
    return _struct_dict(c)


def _struct_dict(s):
    out = {}
    for name, _ in s._fields_:
        v = getattr(s, name)
        if isinstance(v, C.Structure):
            v = _struct_dict(v)
        elif name in ("clock_us", "clock_user", "on_candidate", "candidate_user", "cnn_model", "boost_model",
                      "cnn_model2"):
            continue
        out[name] = v
    return out


def make_cfg(**kw):
    """A zeroed DetectorCfg (= paper defaults) with the given fields set.
    Nested structs take dicts: rules={...}, calib={...}, temporal_cfg={...}, contrast={...}.
    sources: a bit set or names ("hotspot,window" / ("hotspot", "contrast") / "all");
    windows: a WindowsCfg, or a dict of vdtools.bindings.sources.windows_cfg keywords (preset_name="msrs", ...);
    the detector uses each frame's size."""
    c = DetectorCfg()
    for k, v in kw.items():
        if k == "thr_mode" and isinstance(v, str):
            v = {"constant": THR_CONSTANT, "adaptive": THR_ADAPTIVE}[v]
        if k == "sources" and not isinstance(v, int):
            v = source_bits(v)
        if k == "windows" and isinstance(v, dict):
            # presets are sized for frame_w x frame_h (default: 640 x 480 for "msrs", else 640 x 512);
            # the detector itself always uses each frame's size
            v = dict(v)
            fw = v.pop("frame_w", 640)
            fh = v.pop("frame_h", 480 if v.get("preset_name") == "msrs" else 512)
            v = _windows_cfg(fw, fh, **v)
            v.frame_w = v.frame_h = 0
        if isinstance(v, dict):
            sub = getattr(c, k)
            for sk, sv in v.items():
                setattr(sub, sk, sv)
        else:
            setattr(c, k, v)
    return c


def source_bits(names):
    """"hotspot,window" | iterable of names | "all" -> VD_DETECTOR_SRC_* bit set."""
    if isinstance(names, str):
        names = names.replace("+", ",").split(",")
    bits = 0
    for n in names:
        n = n.strip()
        bits |= SRC_ALL if n == "all" else SOURCE_BITS[n.rstrip("s") if n == "windows" else n]
    return bits


def _load_model(model):
    """(model buffer, keep-alive blob) from None, bytes or a path."""
    if model is None:
        return None, None
    data = Path(model).read_bytes() if isinstance(model, (str, Path)) else bytes(model)
    blob = np.frombuffer(data + b"\0" * (-len(data) % 8), dtype=np.uint64).copy()  # 8-aligned copy
    m = (C.c_uint64 * (_MODEL_BYTES // 8))()
    clib.check(_lib().vd_dbn_load(C.byref(m), blob.ctypes.data, len(data)), "vd_dbn_load")
    return m, blob


def _load_cnn(cnn_model):
    """(vd_cnn_model_t, keep-alive blob) of a version-3 .vdm given as a path or bytes (None: (None, None))."""
    if cnn_model is None:
        return None, None
    from vdtools.bindings import cnn as vd_cnn
    data = Path(cnn_model).read_bytes() if isinstance(cnn_model, (str, Path)) else bytes(cnn_model)
    keep, addr = vd_cnn.aligned_copy(data)
    m = vd_cnn.CnnModel()
    clib.check(vd_cnn.lib().vd_cnn_load(C.byref(m), addr, len(data)), "vd_cnn_load")
    return m, (keep, vd_cnn.prepare(m))   # as vd_fir_demo: the same detections, faster


def _attach_cnn(cfg, cnn_model, cnn_model2):
    """Loads cnn_model and cnn_model2 (.vdm paths or bytes, or None) into cfg's pointers; returns the
    keep-alive objects (models and blobs) the caller must hold while cfg is used."""
    cm, keep = _load_cnn(cnn_model)
    cm2, keep2 = _load_cnn(cnn_model2)
    if cm is not None:
        cfg.cnn_model = C.addressof(cm)
    if cm2 is not None:
        cfg.cnn_model2 = C.addressof(cm2)
    return cm, keep, cm2, keep2


def _cfg_with_cnn(**kw):
    """make_cfg(**kw) with cnn_model and cnn_model2 (.vdm paths or bytes) loaded: (cfg, keep-alive objects)."""
    cnn, cnn2 = kw.pop("cnn_model", None), kw.pop("cnn_model2", None)
    c = make_cfg(**kw)
    return c, _attach_cnn(c, cnn, cnn2)


def cfg_from_default(fields, cnn_model=None, cnn_model2=None):
    """vd_detector_cfg_default() with the given fields set and cnn_model / cnn_model2 (.vdm paths or bytes,
    or None) loaded: (DetectorCfg, keep-alive objects) -- the caller keeps the second alive."""
    cfg = DetectorCfg()
    _lib().vd_detector_cfg_default(C.byref(cfg))
    for k, v in fields.items():
        if "." in k:   # a nested field, e.g. "temporal_cfg.flags"
            outer, inner = k.split(".", 1)
            setattr(getattr(cfg, outer), inner, v)
        else:
            setattr(cfg, k, v)
    return cfg, _attach_cnn(cfg, cnn_model, cnn_model2)


def workspace_size(width=640, height=512, model=None, **cfg):
    """vd_detector_workspace_size for a width x height detector (other keywords:
    vd_detector_cfg_t fields, cnn_model / cnn_model2 paths/bytes of version-3 .vdm files; model: path/bytes of
    a DBN .vdm or None)."""
    c, _keep = _cfg_with_cnn(max_width=width, max_height=height, **cfg)
    m, _blob = _load_model(model)
    n = C.c_size_t()
    clib.check(_lib().vd_detector_workspace_size(C.byref(c), C.cast(m, C.c_void_p) if m is not None else None,
                                                 C.byref(n)), "vd_detector_workspace_size")
    return n.value


class Detector:
    """One C detector with its own workspace. Keyword arguments: vd_detector_cfg_t fields
    (cnn_model: path or bytes of a version-3 .vdm, with sources including "cnn"), or prepared_cfg: a
    complete DetectorCfg (its cnn_model, if any, kept alive by the caller)."""

    def __init__(self, model=None, clock=False, prepared_cfg=None, **cfg):
        lib = _lib()
        if prepared_cfg is not None:
            self.cfg, self._cnn = prepared_cfg, None
        else:
            self.cfg, self._cnn = _cfg_with_cnn(**cfg)
        self._clock_fn = None
        if clock:
            import time
            self._clock_fn = CLOCK_FN(lambda _u: int(time.perf_counter_ns() // 1000) & 0xFFFFFFFF)
            self.cfg.clock_us = self._clock_fn
        self._model, self._blob = _load_model(model)
        mptr = C.cast(self._model, C.c_void_p) if self._model is not None else None
        n = C.c_size_t()
        clib.check(lib.vd_detector_workspace_size(C.byref(self.cfg), mptr, C.byref(n)), "vd_detector_workspace_size")
        self.workspace_bytes = n.value
        self._ws, self._ws_ptr = clib.workspace(n.value)
        self._det = (C.c_uint64 * (_DET_BYTES // 8))()
        clib.check(lib.vd_detector_init(C.byref(self._det), C.byref(self.cfg), mptr, self._ws_ptr, n.value),
                   "vd_detector_init")
        cap = max(int(self.cfg.max_detections or 32) + int(self.cfg.max_tracks or 32), 1)
        self._out = (Detection * cap)()

    def run(self, frame, seq=0, allow_capacity=True):
        """Runs on a 2-D uint8/uint16 array. Returns (detections, stats); VD_ERR_CAPACITY is
        reported in stats['status'] (results still valid) unless allow_capacity is False."""
        a = np.ascontiguousarray(frame)
        if a.ndim != 2 or a.dtype not in (np.uint8, np.uint16):
            raise ValueError("frame must be a 2-D uint8 or uint16 array")
        f = clib.frame(a, seq)
        count = C.c_size_t()
        st = _lib().vd_detector_run(C.byref(self._det), C.byref(f), self._out, len(self._out), C.byref(count))
        if st != clib.VD_OK and not (allow_capacity and st == -3):
            raise clib.VdError(st, "vd_detector_run")
        dets = [detection_dict(self._out[i]) for i in range(count.value)]
        return dets, self.stats(st)

    def stats(self, status=0):
        s = _lib().vd_detector_last_stats(C.byref(self._det)).contents
        d = {n: int(getattr(s, n)) for n in STAT_FIELDS}
        d["time_us"] = {STAGES[i]: int(s.time_us[i]) for i in range(len(STAGES))}
        d["status"] = clib.STATUS.get(status, status)
        return d


def detection_dict(d):
    b, c = d.box, d.candidate
    return {
        "box": [b.x, b.y, b.w, b.h],
        "candidate": [c.x, c.y, c.w, c.h],
        "score_q8": int(d.score_q8),
        "score": d.score_q8 / 256.0,
        "contour_length": int(d.contour_length),
        "complexity_q15": int(d.complexity_q15),
        "track": int(d.track_id) or None,
        "state": STATES.get(int(d.state)),
        "source": SOURCE_NAMES.get(int(d.source), "hotspot"),
        "flags": int(d.flags),
        "hot_thr": int(d.hot_thr),
    }


def detect(frame, model=None, **cfg):
    """One-shot convenience: a detector sized for this frame, run once."""
    cfg.setdefault("max_width", frame.shape[1])
    cfg.setdefault("max_height", frame.shape[0])
    return Detector(model=model, **cfg).run(frame)


def exp_tables():
    """The two Q30 tables of lib/src/detector/temporal.c: round(2^30 exp(-k/128)), k=0..128, and
    round(2^30 exp(-n)), n=0..16 (Python round: half to even; no value is a tie)."""
    frac = [round(math.exp(-k / 128) * 2 ** 30) for k in range(129)]
    ints = [round(math.exp(-n) * 2 ** 30) for n in range(17)]
    return frac, ints


if __name__ == "__main__":
    fr, it = exp_tables()
    for name, t in (("k_exp_frac_q30", fr), ("k_exp_int_q30", it)):
        print(f"static const uint32_t {name}[{len(t)}] = {{")
        for i in range(0, len(t), 6):
            print("    " + ", ".join(f"{v}u" for v in t[i:i + 6]) + ",")
        print("};")
