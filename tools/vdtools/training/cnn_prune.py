# SPDX-License-Identifier: MIT
"""Structured pruning: a trained network copied into a narrower architecture of the same layer list.

Every tensor the target architecture makes narrower keeps the channels that matter most to the layer that
reads it: the mean |activation| of the channel on calibration frames (training split, half resolution,
as cnn_export calibrates) times the norm of the reading pointwise layer's weight column for it (batch norm
folded). A depthwise layer keeps its input's channels, so a chain pointwise -> depthwise is scored at the
depthwise output. The result is a float checkpoint for `cnn_train --init` (a short float fine-tune, then
`--qat`); used for the pair's second network, whose s32l weights were 18 KB over the 256 KiB model budget
(docs/training.md, "A second network within the pair's 256 KiB model budget").

    python3 -m vdtools.training.cnn_prune tools/.cache/cnn/s32l/best.pt --arch s32m --out tools/.cache/cnn/s32l_pruned.pt
"""
import argparse

import numpy as np
import torch

from vdtools.bindings import clib
from vdtools.data import cnn_data as CD
from vdtools.training import cnn_export as E
from vdtools.training import cnn_train as T


def channel_importance(net, frames):
    """Per tensor: mean |value| per channel over frames (float64)."""
    acc = None
    for ts in E.forward_all(net, frames):
        m = [t[0].abs().double().mean((1, 2)).numpy() for t in ts]
        acc = m if acc is None else [a + b for a, b in zip(acc, m)]
    return [a / len(frames) for a in acc]


def keep_sets(src, dst, act):
    """keep[t]: indices of src tensor t's channels that dst tensor t keeps (ascending)."""
    L = len(src.spec)
    cs = [1] + [d["cout"] for d in src.spec]
    cd = [1] + [d["cout"] for d in dst.spec]
    readers = {}
    for i, d in enumerate(src.spec):
        readers.setdefault(d["in"], []).append(i)
        if d["op"] == "cat":
            readers.setdefault(d["in2"], []).append(i)
    keep = [np.arange(cs[0])]
    for i, d in enumerate(src.spec):
        t = i + 1
        if d["op"] in ("dw", "up"):
            keep.append(keep[d["in"]])
        elif d["op"] == "cat":
            keep.append(np.concatenate([keep[d["in"]], keep[d["in2"]] + cs[d["in"]]]))
        elif cd[t] == cs[t]:
            keep.append(np.arange(cs[t]))
        else:
            u = t                                        # follow depthwise readers to the scored tensor
            while len(readers.get(u, [])) == 1 and src.spec[readers[u][0]]["op"] == "dw":
                u = readers[u][0] + 1
            score = np.zeros(cs[t])
            for r in readers.get(u, []):
                rd = src.spec[r]
                if rd["op"] not in ("pw", "head") or rd["in"] != u:
                    raise ValueError(f"tensor {u} is read by {rd['op']}: only pointwise readers can be scored")
                w, _ = T.fold_bn(src.mods[rd["mod"]], torch.float64)
                score += np.linalg.norm(w.numpy()[:, :, 0, 0], axis=0)
            score *= act[u]
            keep.append(np.sort(np.argsort(-score, kind="stable")[:cd[t]]))
    assert all(len(keep[t]) == cd[t] for t in range(L + 1)), "architectures differ beyond channel counts"
    return keep


def prune(src, dst, keep):
    """Copies src's weights into dst (both Nets) through the keep sets."""
    sd = src.state_dict()
    out = {}
    for i, d in enumerate(src.spec):
        if d["mod"] is None:
            continue
        rows, cols = keep[i + 1], keep[d["in"]]
        pre = f"mods.{d['mod']}."
        for k, v in sd.items():
            if not k.startswith(pre):
                continue
            if v.dim() == 4:                           # conv weight (cout, cin/groups, kh, kw)
                v = v[rows] if d["op"] == "dw" else v[rows][:, cols]
            elif v.dim() == 1:                         # bias, batch-norm parameters and statistics
                v = v[rows]
            out[k] = v.clone()
    dst.load_state_dict(out)
    return dst


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("ckpt")
    ap.add_argument("--arch", required=True, help="target architecture (cnn_train.ARCHS), same layer list")
    ap.add_argument("--out", required=True)
    ap.add_argument("--frames", type=int, default=E.CALIB_FRAMES, help="calibration frames (training split)")
    ap.add_argument("--data", default=str(clib.REPO.parent / "shared" / "data"))
    ap.add_argument("--exclude", choices=("msrs-night",), help="score channels without these frames (a network "
                    "trained with cnn_train --exclude: the another-camera estimate must not see them at all)")
    a = ap.parse_args(argv)
    ck = torch.load(a.ckpt, weights_only=False, map_location="cpu")
    src, dst = T.Net(ck["arch"]), T.Net(a.arch)
    src.load_state_dict(ck["net"])
    src.eval()
    if [(d["op"], d["stride"], d["in"], d["in2"]) for d in src.spec] != \
            [(d["op"], d["stride"], d["in"], d["in2"]) for d in dst.spec]:
        raise SystemExit(f"{ck['arch']} and {a.arch} differ beyond channel counts")
    frames = CD.load_frames(a.data, splits=("train",))
    if a.exclude == "msrs-night":
        frames = [f for f in frames if CD.subset(f) != "msrs-night"]
    keep = keep_sets(src, dst, channel_importance(src, E.calibration_frames(frames, a.frames)))
    prune(src, dst, keep)
    n = sum(p.numel() for p in dst.parameters())
    torch.save(dict(net=dst.state_dict(), arch=a.arch, step=0, pruned_from=a.ckpt), a.out)
    print(f"wrote {a.out}: {a.arch}, {n} parameters (from {ck['arch']}, {sum(p.numel() for p in src.parameters())})")


if __name__ == "__main__":
    main()
