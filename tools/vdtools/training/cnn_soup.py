# SPDX-License-Identifier: MIT
"""Weight averaging ("model soup", Wortsman et al. 2022) of CNN checkpoints fine-tuned from one network.

Fine-tunes that start from the same weights stay in one basin of the loss, so the mean of their weights is
itself a good network, and usually a better one than any of them: their checkpoint-to-checkpoint noise
averages out (docs/training.md gives the val figures). Every float tensor is averaged (weights, biases and
the frozen batch-norm statistics of QAT fine-tunes); integer ones (batch counters) come from the first.
The checkpoints must share the architecture and all be QAT fine-tunes or all float. The result is a
checkpoint like cnn_train's, which cnn_export quantises (and recalibrates) as any other.

    python3 -m vdtools.training.cnn_soup tools/.cache/cnn/soup5/best.pt tools/.cache/cnn/qat/best.pt \\
        tools/.cache/cnn/qat_cut/best.pt tools/.cache/cnn/qat_cut256/best.pt ...
"""
import argparse
from pathlib import Path

import torch


def soup(ckpts):
    """The uniform average of checkpoint dicts (cnn_train's format) as a new checkpoint dict."""
    if not ckpts:
        raise ValueError("no checkpoints to average")
    first = ckpts[0]
    for c in ckpts[1:]:
        if c["arch"] != first["arch"] or bool(c.get("qat")) != bool(first.get("qat")):
            raise ValueError("checkpoints differ in architecture or QAT: they are not fine-tunes of one network")
        if c["net"].keys() != first["net"].keys():
            raise ValueError("checkpoints have different tensors")
    net = {}
    for k, v in first["net"].items():
        if v.dtype.is_floating_point:
            net[k] = torch.stack([c["net"][k].to(torch.float64) for c in ckpts]).mean(0).to(v.dtype)
        else:
            net[k] = v.clone()
    return dict(net=net, arch=first["arch"], step=None, val_ap=None,   # no single step or evaluation
                qat=bool(first.get("qat")), soup=len(ckpts))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out", help="checkpoint to write")
    ap.add_argument("ckpts", nargs="+", help="checkpoints to average (cnn_train's best.pt / final.pt)")
    a = ap.parse_args(argv)
    c = soup([torch.load(p, weights_only=False, map_location="cpu") for p in a.ckpts])
    c["sources"] = [Path(p).as_posix() for p in a.ckpts]
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    torch.save(c, a.out)
    print(f"wrote {a.out}: mean of {len(a.ckpts)} {c['arch']} checkpoints{' (QAT)' if c['qat'] else ''}")


if __name__ == "__main__":
    main()
