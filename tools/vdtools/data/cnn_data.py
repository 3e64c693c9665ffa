# SPDX-License-Identifier: MIT
"""Frames, boxes and targets for the CNN detector (issue 10), read from ../shared/data, never copied.

The network sees the frame at HALF resolution, exactly as the C detector produces it: an exact 2x2 box
average with round-half-up, (a + b + c + d + 2) >> 2 (the same bytes as cv2.INTER_AREA at scale 1/2), then
the per-frame percentile stretch of the model header (vdtools.formats.cnn_ref.preprocess; integer, equal to C).

Splits are vdtools.data.dataset.assign_splits (groups: MSRS number // 40, HIT-UAV T_H_A flight; stable as data
grows); the HIT-UAV sequence-0_100 flight is test only. Ground truth: MSRS class 2 (car), HIT-UAV Car and
OtherVehicle; HIT-UAV DontCare boxes are ignore regions (no loss, no false positive).
"""
from dataclasses import dataclass, field

import cv2
import numpy as np

from vdtools.data import dataset as D


def half(img):
    """Exact 2x2 box average, round half up (the C detector's resample for the network input)."""
    return box_mean(img, 2)


def box_mean(img, d):
    """Exact d x d box average, round half up ((sum + d*d/2) // (d*d)); a last partial block of columns or rows
    is dropped (the C detector's resample for the network input: d = 2 half, 4 quarter resolution)."""
    h, w = img.shape[0] // d * d, img.shape[1] // d * d
    s = img[:h, :w].astype(np.uint32).reshape(h // d, d, w // d, d).sum(axis=(1, 3))
    return ((s + d * d // 2) // (d * d)).astype(np.uint8)


def pad_to(img, a=16):
    """Pads a plane by edge replication to multiples of a (the network's alignment), as the detector does."""
    h, w = img.shape
    H, W = (h + a - 1) // a * a, (w + a - 1) // a * a
    if (H, W) == (h, w):
        return img
    return np.pad(img, ((0, H - h), (0, W - w)), mode="edge")


@dataclass
class Frame:
    dataset: str
    name: str
    path: str
    group: str
    split: str
    img: np.ndarray          # full-resolution uint8
    boxes: np.ndarray        # (N, 4) float x, y, w, h in full-resolution pixels
    ignore: np.ndarray       # (M, 4)
    hot: np.ndarray          # (N,) bool: box holds a pixel >= the frame's 99th percentile (hot vehicle)
    others: np.ndarray = field(default_factory=lambda: np.zeros((0, 5), np.float32))   # (K, 5) x, y, w, h, cls


def _hot_flags(img, boxes):
    thr = np.percentile(img, 99.0)
    out = []
    for x, y, w, h in boxes:
        x0, y0 = int(x), int(y)
        roi = img[y0:y0 + max(1, int(h)), x0:x0 + max(1, int(w))]
        out.append(bool(roi.size and roi.max() >= thr))
    return np.array(out, bool)


def load_frames(data_dir, splits=("train", "val", "test"), synth=False):
    """All annotated real frames of the wanted splits, images in memory (~1 400 frames, ~450 MB); with
    synth, also the synthetic training clips of vdtools.data.dataset.load_synth (seeds 101/102, never the
    bundled clip's seed 1; train split only)."""
    frames = D.all_frames(data_dir, synth=synth)
    split_of = D.assign_splits(frames)
    out = []
    for f in frames:
        s = split_of[f.group]
        if s not in splits:
            continue
        img = cv2.imread(str(f.path), cv2.IMREAD_GRAYSCALE)
        if img is None:
            raise IOError(f"cannot read {f.path}")
        b = np.array(f.vehicles, np.float32).reshape(-1, 4)
        ig = np.array(f.ignore, np.float32).reshape(-1, 4)
        oth = np.array(f.others, np.float32).reshape(-1, 5)
        out.append(Frame(f.dataset, f.name, str(f.path), f.group, s, img, b, ig, _hot_flags(img, b), oth))
    return out


def frame_path(fr):
    return fr.path


def family(fr):
    """'msrs' (road level), 'synth' (synthetic clips) or 'hit' (drone, incl. the sequence flight)."""
    return fr.dataset if fr.dataset in ("msrs", "synth") else "hit"


def hit_view(fr):
    """(night, camera angle in degrees) of a drone-view frame, from its HIT-UAV file name T_H_A_W_ID (T 1 =
    night), the sequence flight's too; None for other frames."""
    parts = fr.name.split("_")
    if family(fr) != "hit" or len(parts) < 5 or not parts[2].isdigit():
        return None
    return parts[0] == "1", int(parts[2])


def scene_subset(frames, fam, frac, seed=0):
    """The frames of family fam from a share frac (0 < frac <= 1) of its scene groups, every other family's
    frames as they are: round(frac * groups) groups (at least 1), drawn with the seed from the sorted group
    names, so the same frac and seed always keep the same scenes. For learning curves (cnn_train
    --road-scenes): how accuracy on unseen scenes grows with the number of training scenes."""
    if not 0 < frac <= 1:
        raise ValueError("frac must be in (0, 1]")
    groups = sorted({f.group for f in frames if family(f) == fam})
    n = max(1, int(round(frac * len(groups)))) if groups else 0
    keep = {groups[i] for i in np.random.default_rng(seed).permutation(len(groups))[:n]}
    return [f for f in frames if family(f) != fam or f.group in keep]


def subset(fr):
    """The subsets results are reported for (docs/results/detector.md): MSRS night / day (file name N / D),
    HIT-UAV frames night / day (the T flag of T_H_A_W_ID, 1 = night), the sequence-0_100 flight
    (and "synth" for the synthetic training clips).
    "msrs-night" is also the set the another-camera estimate leaves out (cnn_train / cnn_export --exclude)."""
    if fr.dataset == "msrs":
        return "msrs-night" if fr.name.endswith("N.png") else "msrs-day"
    if fr.dataset in ("seq", "synth"):
        return "hit-flight" if fr.dataset == "seq" else "synth"
    return "hit-night" if fr.name.startswith("1_") else "hit-day"
