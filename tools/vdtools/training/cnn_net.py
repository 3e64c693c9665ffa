# SPDX-License-Identifier: MIT
"""The CNN vehicle detector's network as PyTorch runs it: the architectures (ARCHS), the module that
executes one (Net, with the exporter's fake quantisation for QAT), batch-norm folding, the float input of
a frame, and the weight helpers that training, export, evaluation and adaptation share.

The network uses ONLY the ops vd's int8 CNN module runs (lib/include/vd/cnn.h): 3x3 convolution (stride
1/2, pad 1), depthwise 3x3, pointwise 1x1, x2 nearest upsample and channel concat for skips; batch norm
is folded into the convolutions at export and ReLU becomes the int8 clamp. Below both the trainer
(cnn_train) and the exporter (cnn_export), so that the trainer can call the exporter and the exporter
build a network without an import cycle.
"""
import numpy as np
import torch
import torch.nn as nn
import torch.nn.functional as F

from vdtools.data import cnn_data as CD
from vdtools.training.cnn_targets import normalise

HEAD = 5                    # the exported head: heatmap logit, log w, log h, x / y offset

# Architectures: (op, args) in execution order; tensors are numbered as in the .vdm (0 = input,
# i + 1 = output of layer i). ("save", name) labels the latest tensor for a later ("cat", name).
ARCHS = {
    # ~67 M multiply-adds at 320x256, ~110 k parameters
    "main": [("conv", 16, 2), ("dw", 2), ("pw", 32), ("dw", 1), ("pw", 32), ("save", "s4"),
             ("dw", 2), ("pw", 64), ("dw", 1), ("pw", 64), ("dw", 1), ("pw", 64), ("save", "s8"),
             ("dw", 2), ("pw", 128), ("dw", 1), ("pw", 128), ("dw", 1), ("pw", 128),
             ("pw", 64), ("up",), ("cat", "s8"), ("dw", 1), ("pw", 64),
             ("pw", 16), ("up",), ("cat", "s4"), ("dw", 1), ("pw", 24),
             ("dw", 1), ("head", 5)],
    # main + a stride-32 stage (receptive field for cars up to ~300 px at road level), ~80 M multiply-adds
    "wide": [("conv", 16, 2), ("dw", 2), ("pw", 32), ("dw", 1), ("pw", 32), ("save", "s4"),
             ("dw", 2), ("pw", 64), ("dw", 1), ("pw", 64), ("dw", 1), ("pw", 64), ("save", "s8"),
             ("dw", 2), ("pw", 128), ("dw", 1), ("pw", 128), ("save", "s16"),
             ("dw", 2), ("pw", 160), ("dw", 1), ("pw", 160), ("dw", 1), ("pw", 160),
             ("pw", 64), ("up",), ("cat", "s16"), ("dw", 1), ("pw", 128),
             ("pw", 64), ("up",), ("cat", "s8"), ("dw", 1), ("pw", 64),
             ("pw", 16), ("up",), ("cat", "s4"), ("dw", 1), ("pw", 24),
             ("dw", 1), ("head", 5)],
    # main with a stride-32 stage instead of the third blocks at strides 4 and 8 and the decoder's last
    # pointwise: more receptive field for close road cars (~300 px) within the format's 32 layers
    "s32": [("conv", 16, 2), ("dw", 2), ("pw", 32), ("save", "s4"),
            ("dw", 2), ("pw", 64), ("dw", 1), ("pw", 64), ("save", "s8"),
            ("dw", 2), ("pw", 128), ("dw", 1), ("pw", 128), ("save", "s16"),
            ("dw", 2), ("pw", 160), ("dw", 1), ("pw", 160), ("dw", 1), ("pw", 160),
            ("pw", 64), ("up",), ("cat", "s16"), ("dw", 1), ("pw", 128),
            ("pw", 64), ("up",), ("cat", "s8"), ("dw", 1), ("pw", 64),
            ("pw", 16), ("up",), ("cat", "s4"), ("dw", 1), ("head", 5)],
    # main whose bottleneck runs at stride 32 (receptive field of s32, main's stride-4/8 blocks, 30 layers),
    # joined straight to stride 8 by two upsamples; 24 stride-4 skip channels and a 32-channel bottleneck
    # output keep the detector workspace within 256 KiB at 640x512 (253 856 B with the flip pass)
    "m32": [("conv", 16, 2), ("dw", 2), ("pw", 32), ("dw", 1), ("pw", 24), ("save", "s4"),
            ("dw", 2), ("pw", 64), ("dw", 1), ("pw", 64), ("dw", 1), ("pw", 64), ("save", "s8"),
            ("dw", 2), ("pw", 128), ("dw", 2), ("pw", 128), ("dw", 1), ("pw", 128),
            ("pw", 32), ("up",), ("up",), ("cat", "s8"), ("dw", 1), ("pw", 64),
            ("pw", 16), ("up",), ("cat", "s4"), ("dw", 1), ("pw", 24),
            ("dw", 1), ("head", 5)],
    # Cortex-M variant: <= 15 M multiply-adds at 320x256, ~20 k parameters (int8: ~20 KiB)
    "compact": [("conv", 8, 2), ("dw", 2), ("pw", 16), ("save", "s4"),
                ("dw", 2), ("pw", 32), ("dw", 1), ("pw", 32), ("save", "s8"),
                ("dw", 2), ("pw", 64), ("dw", 1), ("pw", 64),
                ("pw", 32), ("up",), ("cat", "s8"), ("dw", 1), ("pw", 24),
                ("pw", 8), ("up",), ("cat", "s4"), ("dw", 1), ("pw", 12),
                ("dw", 1), ("head", 5)],
}


def _thin_skips(arch, widths):
    """arch with the pointwise layer before each ("save", name) of widths narrowed to widths[name] channels."""
    out = list(arch)
    for i, op in enumerate(out):
        if op[0] == "save" and op[1] in widths:
            assert out[i - 1][0] == "pw", (arch, i)
            out[i - 1] = ("pw", widths[op[1]])
    return out


# s32 with thinner skips (16 stride-4, 32 stride-8 channels): its stride-32 receptive field within the
# detector's 256 KiB workspace budget at 640x512 (the second network of the shipped pair, models/vd_cnn2.vdm)
ARCHS["s32l"] = _thin_skips(ARCHS["s32"], {"s4": 16, "s8": 32})

def _stride32_width(arch, width):
    """arch (s32l) with its 160-channel stride-32 pointwise layers narrowed to width channels."""
    return [("pw", width) if op == ("pw", 160) else op for op in arch]


# s32l narrowed at stride 32 so that the pair vd_cnn + this network fits the 256 KiB model budget (s32l's
# pair file total is 279 824 B): s32m 128 channels (~25 k fewer weights); s32n 136, the widest multiple of
# 8 that fits (98 304 + 161 192 B), so that pruning s32l to it removes as little as the budget allows
ARCHS["s32m"] = _stride32_width(ARCHS["s32l"], 128)
ARCHS["s32n"] = _stride32_width(ARCHS["s32l"], 136)


def fold_bn(seq, dtype=None):
    """(weight, bias) of a conv [+ batch norm] block with the norm's running statistics folded in:
    w' = w g, b' = beta + (b - mean) g, g = gamma / sqrt(var + eps). QAT folds in float32 with gradients;
    cnn_export in float64 (dtype), with g computed in the parameters' own precision."""
    conv = seq[0]
    cast = (lambda t: t) if dtype is None else (lambda t: t.detach().to(dtype))
    w = cast(conv.weight)
    b = cast(conv.bias) if conv.bias is not None else torch.zeros(w.shape[0], dtype=w.dtype)
    if len(seq) > 1 and isinstance(seq[1], nn.BatchNorm2d):
        bn = seq[1]
        g = cast(bn.weight / torch.sqrt(bn.running_var + bn.eps))
        w = w * g[:, None, None, None]
        b = cast(bn.bias) + (b - cast(bn.running_mean)) * g
    return w, b


class Net(nn.Module):
    """Executes an ARCHS list; `self.spec` is the layer list the exporter turns into .vdm layers."""

    def __init__(self, arch, aux=0, norm="stretch"):
        """aux: extra head channels after the HEAD exported ones (cnn_train --aux), dropped by the export.
        norm: the input normalisation the network was trained with (cnn_targets.NORMS), kept with its weights."""
        super().__init__()
        self.norm = norm
        self.spec = []          # dicts: op, stride, in, in2, cin, cout, module index
        self.mods = nn.ModuleList()
        chans = [1]             # channels of tensor t
        saved = {}
        cur = 0
        for item in ARCHS[arch]:
            kind = item[0]
            if kind == "save":
                saved[item[1]] = cur
                continue
            cin = chans[cur]
            if kind == "conv":
                cout, s = item[1], item[2]
                m = nn.Sequential(nn.Conv2d(cin, cout, 3, s, 1, bias=False), nn.BatchNorm2d(cout), nn.ReLU())
                d = dict(op="conv", stride=s, cin=cin, cout=cout)
            elif kind == "dw":
                cout, s = cin, item[1]
                m = nn.Sequential(nn.Conv2d(cin, cin, 3, s, 1, groups=cin, bias=False), nn.BatchNorm2d(cin), nn.ReLU())
                d = dict(op="dw", stride=s, cin=cin, cout=cout)
            elif kind == "pw":
                cout = item[1]
                m = nn.Sequential(nn.Conv2d(cin, cout, 1, bias=False), nn.BatchNorm2d(cout), nn.ReLU())
                d = dict(op="pw", stride=1, cin=cin, cout=cout)
            elif kind == "head":
                cout = item[1] + aux
                conv = nn.Conv2d(cin, cout, 1, bias=True)
                with torch.no_grad():
                    conv.weight.mul_(0.1)
                    conv.bias.zero_()
                    conv.bias[0] = -2.19          # CenterNet prior: p = 0.1
                    conv.bias[1:3] = 2.5          # log size ~ 12 px
                    conv.bias[3:HEAD] = 0.5
                    conv.bias[HEAD:] = -2.19      # aux heatmaps: the same prior
                m = nn.Sequential(conv)
                d = dict(op="head", stride=1, cin=cin, cout=cout)
            elif kind == "up":
                m, cout = None, cin
                d = dict(op="up", stride=1, cin=cin, cout=cin)
            elif kind == "cat":
                other = saved[item[1]]
                m, cout = None, cin + chans[other]
                d = dict(op="cat", stride=1, cin=cin, cout=cout, in2=other)
            else:
                raise ValueError(kind)
            d["in"] = cur
            d.setdefault("in2", 0)
            d["mod"] = None
            if m is not None:
                d["mod"] = len(self.mods)
                self.mods.append(m)
            self.spec.append(d)
            chans.append(cout)
            cur = len(chans) - 1
        self.n_out = chans[-1]
        # input sides must be multiples of the largest downsampling factor (the .vdm's alignment)
        f = [1]
        for d in self.spec:
            fi = f[d["in"]]
            f.append(fi * d["stride"] if d["op"] in ("conv", "dw") else (fi // 2 if d["op"] == "up" else fi))
        self.align = max(f)

    fq = None   # quantisation-aware training: dict(scale, zp) per tensor (set_fake_quant)
    dropout = 0.0   # cnn_train --dropout: channel dropout on every concat output while training (float only)

    def set_fake_quant(self, q):
        """q = the exporter's per-tensor scales and zero points (cnn_export.quantise), or None for float."""
        self.fq = q

    def _fq_layer(self, d, i, a):
        """One weighted layer as the int8 export runs it: batch norm folded with its running statistics
        (frozen: QAT fine-tunes a trained network), weights fake-quantised per output channel (symmetric,
        max|w| / 127, as cnn_export), ReLU, then the output fake-quantised with the tensor's scale. Rounding
        passes gradients straight through; values clamped by the int8 range get none."""
        conv = self.mods[d["mod"]][0]
        w, b = fold_bn(self.mods[d["mod"]])
        sw = (w.detach().abs().flatten(1).amax(1).clamp(min=1e-8) / 127.0)[:, None, None, None]
        w = w + (torch.clamp(torch.round(w / sw), -127, 127) * sw - w).detach()
        y = F.conv2d(a, w, b, conv.stride, conv.padding, 1, conv.groups)
        if d["op"] != "head":
            y = F.relu(y)
        s, z = self.fq["scale"][i + 1], self.fq["zp"][i + 1]
        y = torch.clamp(y, (-128 - z) * s, (127 - z) * s)
        return y + (torch.round(y / s) * s - y).detach()

    def forward(self, x, return_all=False):
        t = [x]
        for i, d in enumerate(self.spec):
            a = t[d["in"]]
            if d["op"] == "up":
                y = F.interpolate(a, scale_factor=2, mode="nearest")
            elif d["op"] == "cat":
                y = torch.cat([a, t[d["in2"]]], 1)
                if self.dropout and self.training and self.fq is None:
                    y = F.dropout2d(y, self.dropout)
            elif self.fq is not None:
                y = self._fq_layer(d, i, a)
            else:
                y = self.mods[d["mod"]](a)
            t.append(y)
        return t if return_all else t[-1]


def load_weights(net, state):
    """state into net; a head with fewer output channels than net's (a checkpoint without --aux into a net
    with it) fills the leading channels and leaves the aux ones as initialised."""
    own = net.state_dict()
    for k, v in state.items():
        if k in own and own[k].shape != v.shape and v.shape[1:] == own[k].shape[1:] and v.shape[0] < own[k].shape[0]:
            w = own[k].clone()
            w[:v.shape[0]] = v
            state = dict(state, **{k: w})
    net.load_state_dict(state)


def strip_aux(state, arch):
    """state of a net trained with --aux, as the exported net (Net(arch)) takes it: the head's leading HEAD
    channels."""
    own = Net(arch).state_dict()
    return {k: (v[:own[k].shape[0]] if k in own and own[k].shape != v.shape else v) for k, v in state.items()}


def macs(net, w, h):
    f, total = {0: 1}, 0
    for i, d in enumerate(net.spec):
        fi = f[d["in"]]
        fo = fi * d["stride"] if d["op"] in ("conv", "dw") else (fi // 2 if d["op"] == "up" else fi)
        f[i + 1] = fo
        n = (w // fo) * (h // fo)
        total += n * {"conv": 9 * d["cin"] * d["cout"], "dw": 9 * d["cout"], "pw": d["cin"] * d["cout"],
                      "head": d["cin"] * d["cout"]}.get(d["op"], 0)
    return total


def to_input(img_half, norm="stretch"):
    """The network's float input (1, 1, h, w) in [0, 1] of a uint8 half-resolution plane, through the input
    normalisation `norm` (cnn_targets.NORMS; a Net's own is net.norm)."""
    return torch.from_numpy(normalise(img_half, norm)[None, None].astype(np.float32) / 255.0)


pad_to = CD.pad_to
