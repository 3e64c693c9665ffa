# SPDX-License-Identifier: MIT
"""Could vd_fir_demo choose a camera's polarity (white-hot or black-hot, `--cnn-polarity`) by itself, with the
rating its --cnn-full-res auto measurement computes (mean box score + flip agreement / 4, vdtools.adapt.measure)?

On a split of ../shared/data, per family and camera change (cnn_eval's, '+'-joined), every frame is measured at
half resolution as it is and inverted (255 - v): the shipped pair's boxes of the frame and its mirror image above
the header threshold. Per scene group (a HIT-UAV flight, an MSRS group) and for the whole split, the margin is
rating(as it is) - rating(inverted): every frame of ../shared/data is white-hot, so a rule "black-hot when the
inverted frames rate higher by more than m" is wrong on a group whose margin is below -m. Groups under 16 frames
are left out of the counts (the demo decides nothing on fewer: DEMO_AUTORES_MIN_FRAMES).

    python3 -m vdtools.adapt.polarity_evidence --split val --out ../docs/results/polarity_val.json
    python3 -m vdtools.adapt.polarity_evidence --split train --shifts none,down33,equalize --out …_train.json
"""
import argparse
import copy
import json
from pathlib import Path

import numpy as np

from vdtools.adapt import measure as M
from vdtools.adapt import window_evidence as W
from vdtools.adapt.resolution_evidence import MODELS, shifted
from vdtools.bindings import clib
from vdtools.data import cnn_data as CD
from vdtools.evaluation import fleet

SHIFTS = ("none", "down50", "down33", "equalize")


def inverted(frames):
    out = []
    for f in frames:
        g = copy.copy(f)
        g.img = (255 - f.img).astype(np.uint8)
        out.append(g)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--split", choices=("train", "val", "test"), required=True)
    ap.add_argument("--shifts", default=",".join(SHIFTS))
    ap.add_argument("--data", default=str(clib.DATA_DIR))
    ap.add_argument("--out", help="JSON: per shift and family, every group's margin and the counts")
    a = ap.parse_args(argv)
    thr = M.header_threshold(MODELS)
    frames = [f for f in CD.load_frames(a.data, splits=(a.split,)) if CD.family(f) in W.FAMILIES]
    frames.sort(key=lambda f: (CD.family(f), Path(f.path).name))
    rows = []
    for shift in a.shifts.split(","):
        for fam in W.FAMILIES:
            fs = [f for f in frames if CD.family(f) == fam]
            if not fs:
                continue
            part = shifted(fs, shift)
            white = W.flip_counts(*M.flip_runs(MODELS, part, False), thr)
            black = W.flip_counts(*M.flip_runs(MODELS, inverted(part), False), thr)
            groups = {}
            for i, f in enumerate(fs):
                groups.setdefault(str(f.group), []).append(i)
            margins = {g: round(W.rating(white, idx) - W.rating(black, idx), 4) for g, idx in groups.items()}
            big = {g: m for g, m in margins.items() if len(groups[g]) >= fleet.AUTO_MIN_FRAMES}
            whole = list(range(len(fs)))
            row = dict(shift=shift, family=fam, frames=len(fs), groups=len(groups), groups_16=len(big),
                       inverted_higher_16=sorted(g for g, m in big.items() if m < 0),
                       smallest_margin_16=min(big.values()) if big else None,
                       whole_split=[round(W.rating(white, whole), 4), round(W.rating(black, whole), 4)],
                       margins={g: [len(groups[g]), m] for g, m in sorted(margins.items())})
            rows.append(row)
            print(f"{a.split} {shift} {fam}: {len(big)} groups of >= {fleet.AUTO_MIN_FRAMES} frames, inverted rated "
                  f"higher in {len(row['inverted_higher_16'])} {row['inverted_higher_16']}; smallest margin "
                  f"{row['smallest_margin_16']}; whole split white-hot {row['whole_split'][0]:.3f}, inverted "
                  f"{row['whole_split'][1]:.3f}", flush=True)
    if a.out:
        Path(a.out).write_text(json.dumps(dict(split=a.split, rows=rows), indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
