# SPDX-License-Identifier: MIT
"""vd-adapt: fit the shipped networks to your camera from its own frames (docs/adapt.md).

    vd-adapt --images DIR [--labels DIR|FILE.json] [--classes 2[,3...]] --out DIR [--minutes 15] [--val-frac 0.25]

With labels (a YOLO folder or COCO JSON; a frame without labels has no vehicles): the frames are split into an
adapt part and a val part by blocks of file-name order; the shipped float networks (models/float/vd_cnn.npz
and vd_cnn2.npz, the pair the demo runs) are fine-tuned quantisation-aware on the adapt part mixed with
../shared/data's training frames (when present, so that they do not forget what they knew), exported as
int8 .vdm files, and the score threshold is chosen on the val part (the one-standard-error rule towards the
shipped threshold: docs/adapt.md). Without labels: the input resolution is chosen on the frames (the
mean score of the networks' boxes) and the shipped networks are kept, since self-training lowered AP on every proxy
measured with them; --self-train still fine-tunes on pseudo-labels of the shipped pair (its fused flip
passes, a high score threshold, boxes of middling score as ignore regions; iterated with the adapted
networks' own labels), threshold unchanged.

OUT holds vd_cnn.vdm / vd_cnn2.vdm (+ the firmware arrays NAME_vdm.c/.h, the export scales, the float
weights), vd.json (settings for `vd_fir_demo --config` and the GStreamer element's config property) and
report.md / report.json: before / after AP@0.5 and TP / FP on the val part through the C library, the time
taken, the command. OUT appears complete or not at all: the run works in OUT.tmp-<key> beside it, which
keeps its checkpoints until the end, so the same command run again resumes there. Bad input gets one line
on stderr and exit status 2 before anything is written.
"""
import argparse
import hashlib
import importlib.util
import json
import os
import sys
import time
from pathlib import Path

from vdtools.adapt import inputs as I
from vdtools.adapt.inputs import InputError
from vdtools.bindings import clib

SHIPPED_FLOAT = (clib.REPO / "models" / "float" / "vd_cnn.npz", clib.REPO / "models" / "float" / "vd_cnn2.npz")
SHIPPED_VDM = (clib.REPO / "models" / "vd_cnn.vdm", clib.REPO / "models" / "vd_cnn2.vdm")
REPLAY_FAMILIES = ("msrs", "hit")
EXIT_INPUT = 2


class _Parser(argparse.ArgumentParser):
    def error(self, message):               # one line, not argparse's usage + error
        raise InputError(message)


def parser():
    ap = _Parser(prog="vd-adapt", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--images", required=True, help="folder of your camera's frames (PNG, JPEG or PGM; 8 or 16 bit)")
    ap.add_argument("--labels", help="YOLO label folder (<stem>.txt) or COCO JSON; without it: the resolution is "
                    "chosen and the shipped networks kept (or --self-train)")
    ap.add_argument("--classes", help="vehicle class ids or names, comma separated (default: classes named car, "
                    "vehicle, truck, bus, van, othervehicle; else the only class the labels use)")
    ap.add_argument("--out", required=True, help="new folder for the adapted models, vd.json and the report")
    ap.add_argument("--minutes", type=float, default=15.0, help="wall-time budget of the whole run (default 15)")
    ap.add_argument("--steps", type=int, default=0, help="training steps instead of a time budget (the "
                    "cosine schedule runs over them; --minutes then does not bound the run)")
    ap.add_argument("--val-frac", type=float, default=0.25, help="share of the frames (whole blocks) kept to "
                    "choose the threshold and measure before / after (default 0.25)")
    ap.add_argument("--block", type=int, help="frames per block of the split (default ceil(frames / 16), >= 2)")
    ap.add_argument("--base", help="float networks to adapt, one or two comma separated (.npz of models/float "
                    "or cnn_train checkpoints; default the shipped pair)")
    ap.add_argument("--before", help="their int8 files, for the 'before' figures (default: the shipped pair "
                    "with the default --base, else the base quantised here)")
    ap.add_argument("--data", default=str(clib.DATA_DIR), help="../shared/data, mixed in when present")
    ap.add_argument("--replay", default="msrs,hit", help="families of --data mixed in: msrs, hit, both "
                    "(default) or none")
    ap.add_argument("--user-share", type=float, default=0.5, help="share of your frames among the training "
                    "crops when frames are mixed in (default 0.5)")
    ap.add_argument("--resolution", choices=("auto", "half", "full", "quarter"), default="auto",
                    help="the networks' input: half resolution (the scale they trained at), full (for cameras "
                         "whose vehicles are about half the size: 4x the time) or quarter (vehicles about twice "
                         "the size: a quarter of the time; vd_fir_demo --cnn-res); auto (default): whichever the "
                         "shipped networks do best on all your frames (AP@0.5 with labels; without, the rating of "
                         "their boxes on the frames and their mirror images, vd_fir_demo's rule)")
    ap.add_argument("--polarity", choices=("auto", "white-hot", "black-hot"), default="auto",
                    help="your camera's: white-hot (warm is bright, as every frame the networks trained on) or "
                         "black-hot (your frames are inverted, 255 - v, before anything else, and vd.json says "
                         "cnn-polarity black-hot); auto (default): whichever the shipped networks do better on all "
                         "your frames (AP@0.5 with labels; without, vd_fir_demo's --cnn-polarity auto rule)")
    ap.add_argument("--lr", type=float, default=3e-4, help="peak learning rate of the fine-tuning's cosine schedule "
                    "(default 3e-4, the shipped networks' QAT stage)")
    ap.add_argument("--self-train", action="store_true", help="without labels: fine-tune on the networks' own "
                    "pseudo-labels. Off by default: on every proxy measured with the shipped pair it lowered AP "
                    "(docs/results/adapt.md, section E), so without it an unlabelled run chooses the input "
                    "resolution and keeps the shipped networks")
    ap.add_argument("--rounds", type=int, default=2, help="self-training rounds (--self-train; default 2)")
    ap.add_argument("--threads", type=int, default=2, help="PyTorch threads (default 2)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--demo", help="vd_fir_demo to check OUT/vd.json with (default: the build's, when present)")
    ap.add_argument("--quiet", action="store_true", help="no progress bar")
    ap.add_argument("--interrupt-after", type=int, help=argparse.SUPPRESS)   # tests: stop as if killed
    return ap


# ---------------------------------------------------------------- checks (no PyTorch, nothing written)

def _check_out(out):
    out = Path(out).absolute()
    if out.exists() and not (out.is_dir() and not any(out.iterdir())):
        raise InputError(f"--out {out}: exists and is not an empty folder (vd-adapt writes a new one)")
    parent = out.parent
    if not parent.is_dir():
        raise InputError(f"--out {out}: its parent {parent} is not an existing folder")
    probe = parent / f".{out.name}.probe-{os.getpid()}"
    try:
        probe.mkdir()
        probe.rmdir()
    except OSError as e:
        raise InputError(f"--out {out}: cannot write in {parent} ({e.strerror or e})")
    return out


def _paths(spec, what):
    ps = [Path(p.strip()) for p in spec.split(",") if p.strip()]
    if not 1 <= len(ps) <= 2:
        raise InputError(f"--{what}: one or two files, comma separated")
    for p in ps:
        if not p.is_file():
            raise InputError(f"--{what} {p}: no such file")
    return ps


def prepare(a):
    """Every check of the arguments and the input; returns the plan dict. Raises InputError."""
    if a.minutes <= 0:
        raise InputError("--minutes must be > 0")
    if not 0 < a.val_frac < 1:
        raise InputError("--val-frac must be between 0 and 1")
    if a.steps < 0 or a.rounds < 1 or a.threads < 1 or not 0 < a.user_share <= 1 or not 0 < a.lr <= 0.1:
        raise InputError("--steps >= 0, --rounds >= 1, --threads >= 1, 0 < --user-share <= 1 and 0 < --lr <= 0.1")
    if a.block is not None and a.block < 1:
        raise InputError("--block must be >= 1")
    replay = [] if a.replay == "none" else [f.strip() for f in a.replay.split(",") if f.strip()]
    if any(f not in REPLAY_FAMILIES for f in replay):
        raise InputError(f"--replay: msrs, hit or none, comma separated (got {a.replay!r})")
    out = _check_out(a.out)
    bases = _paths(a.base, "base") if a.base else list(SHIPPED_FLOAT)
    if a.before:
        before = _paths(a.before, "before")
        if len(before) != len(bases):
            raise InputError("--before: one int8 file per --base network")
    else:
        before = list(SHIPPED_VDM) if not a.base else None
    for p in bases + (before or []):
        if not Path(p).is_file():
            raise InputError(f"{p}: missing (a checkout without its models?)")
    files = I.list_frames(a.images)
    frames = I.read_frames(files)
    label_info = None
    if a.labels:
        label_info = I.read_labels(a.labels, frames, a.classes)
    elif a.classes:
        raise InputError("--classes names classes of --labels: give --labels too")
    if a.labels and a.self_train:
        raise InputError("--self-train is for frames without labels: leave out --labels or --self-train")
    block = I.split_blocks(frames, a.val_frac, a.block, need_vehicles=a.labels is not None)
    try:
        clib.load()
    except OSError as e:
        raise InputError(f"the C library is needed for the figures: not found at {clib.lib_path()} "
                         f"({str(e).splitlines()[0]}); build it or set VD_LIB")
    data = Path(a.data)
    if replay and not data.is_dir():
        replay = []
    key = hashlib.sha1(json.dumps(dict(
        images=[(f.name, f.stat().st_size, int(f.stat().st_mtime)) for f in files],
        labels=None if not a.labels else [str(Path(a.labels).resolve()), Path(a.labels).stat().st_mtime],
        classes=a.classes, bases=[str(Path(p).resolve()) for p in bases], minutes=a.minutes, steps=a.steps,
        val_frac=a.val_frac, block=block, seed=a.seed, replay=replay, user_share=a.user_share, rounds=a.rounds, lr=a.lr, self_train=a.self_train,
        data=str(data.resolve()))).encode()).hexdigest()[:10]
    return dict(out=out, tmp=out.parent / f"{out.name}.tmp-{key}", frames=frames, labels=label_info, block=block,
                bases=[Path(p) for p in bases], before=[Path(p) for p in before] if before else None,
                replay=replay, data=data)


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    t_start = time.time()
    try:
        a = parser().parse_args(argv)
        plan = prepare(a)
        if importlib.util.find_spec("torch") is None:
            raise InputError("PyTorch is not installed: pip install torch (the CPU build is enough)")
        from vdtools.adapt.run import run
        return run(a, plan, t_start, argv)
    except InputError as e:
        print(f"vd-adapt: error: {e}", file=sys.stderr)
        return EXIT_INPUT
