# SPDX-License-Identifier: MIT
"""One family of ../shared/data laid out as a user's camera folder for vd-adapt's measured demonstration
(docs/results/adapt.md): the frames of one split as symbolic links (never copies: ../shared/data's licences)
and their vehicles as YOLO labels (class 0 vehicle, 1 dontcare = HIT-UAV's DontCare ignore regions; frames
without vehicles get no label file), optionally every k-th frame only and optionally as another camera
would show them (--shift: cnn_eval.PERTURB / RESCALE applied, written as PNG files instead of links).

    python3 -m vdtools.adapt.shared_camera --family msrs --split train --every 11 --out /tmp/msrs50
    vd-adapt --images /tmp/msrs50/images --labels /tmp/msrs50/labels --out /tmp/msrs50-adapted ...

The split is ../shared/data's scene split (vdtools.data.dataset.assign_splits), so frames taken from its train
split share no scene with its test split.
"""
import argparse
import os
from pathlib import Path

from vdtools.bindings import clib
from vdtools.data import cnn_data as CD
from vdtools.evaluation import cnn_eval as CE


def write(frames, out, shift=None):
    """images/ (links, or PNG files of the shifted frames) and labels/ (YOLO) of frames under out."""
    import cv2
    out = Path(out)
    (out / "images").mkdir(parents=True, exist_ok=False)
    (out / "labels").mkdir()
    (out / "labels" / "classes.txt").write_text("vehicle\ndontcare\n")
    if shift:
        frames = CE.perturb(frames, shift)
    n_boxes = 0
    for fr in frames:
        src = Path(fr.path)
        stem = f"{fr.dataset}_{src.stem}"
        if shift:
            cv2.imwrite(str(out / "images" / f"{stem}.png"), fr.img)
        else:
            os.symlink(src.resolve(), out / "images" / f"{stem}{src.suffix}")
        h, w = fr.img.shape
        rows = [(0, b) for b in fr.boxes.tolist()] + [(1, b) for b in fr.ignore.tolist()]
        n_boxes += len(fr.boxes)
        if rows:
            (out / "labels" / f"{stem}.txt").write_text("".join(
                f"{c} {(x + bw / 2) / w:.6f} {(y + bh / 2) / h:.6f} {bw / w:.6f} {bh / h:.6f}\n"
                for c, (x, y, bw, bh) in rows))
    return len(frames), n_boxes


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--family", required=True, choices=("msrs", "hit"))
    ap.add_argument("--split", required=True, choices=("train", "val", "test"))
    ap.add_argument("--every", type=int, default=1, help="keep every k-th frame in name order (default all)")
    ap.add_argument("--shift", choices=sorted(CE.PERTURB) + sorted(CE.RESCALE), help="show the frames as another camera would (written as PNG)")
    ap.add_argument("--data", default=str(clib.DATA_DIR))
    ap.add_argument("--out", required=True, help="new folder")
    a = ap.parse_args(argv)
    frames = [f for f in CD.load_frames(a.data, splits=(a.split,)) if CD.family(f) == a.family]
    frames = sorted(frames, key=lambda f: (f.dataset, Path(f.path).name))[::a.every]
    n, nb = write(frames, a.out, a.shift)
    print(f"{a.out}: {n} frames of {a.family} {a.split}, {nb} vehicles, "
          f"{sum(1 for f in frames if len(f.boxes))} frames with vehicles")


if __name__ == "__main__":
    main()
