# SPDX-License-Identifier: MIT
"""Float weights of a shipped int8 CNN, recovered from its .vdm and its export's scales (NAME.scales.json),
for networks whose float checkpoint was lost (vd_cnn's, 2026-11-28), so that they can be fine-tuned.

Per weighted layer the exporter wrote int8 weights q (symmetric per output channel, scale s_w = max|w| / 127),
int32 biases B = round(b / (s_in s_w)) and the TFLite multiplier M = s_in s_w / s_out as (mult, shift):
M = mult 2^(shift - 31). With s_in, s_out from the scales file, s_w = M s_out / s_in, w = q s_w and
b = B s_in s_w. The result is the folded network (what the int8 file computes, up to rounding); it is put
into a Net whose batch norms are the identity on frozen statistics (running mean 0, variance 1, weight
sqrt(1 + eps), bias b), so that fold_bn gives back exactly w and b and a QAT fine-tune (frozen batch norm)
starts from the shipped network. Re-quantised, the weights give the same int8 codes (each channel's
largest |q| is 127 by the exporter's rule); tests/python/test_cnn_float.py checks it.

    python3 -m vdtools.training.cnn_recover models/vd_cnn.vdm --out models/float/vd_cnn.npz
"""
import argparse
import json
from pathlib import Path

import numpy as np

from vdtools.formats import cnn_vdm as V
from vdtools.training import cnn_export as E
from vdtools.training.cnn_net import Net


def recover(desc, scales):
    """{state_dict key: float32 array} of Net(arch) from an unpacked .vdm and its scales file; the weighted
    layers of the file are matched to the net's modules in order."""
    s = scales["scale"]
    out = []
    for i, L in enumerate(desc["layers"]):
        op = V.op_id(L["op"])
        if op not in V.WEIGHTED:
            continue
        cout, cin = int(L["cout"]), int(L["cin"])
        m = np.asarray(L["mult"], np.float64) * np.exp2(np.asarray(L["shift"], np.float64) - 31)
        s_in, s_out = s[int(L["in"])], s[i + 1]
        sw = m * s_out / s_in
        q = np.asarray(L["w"], np.float64).reshape(V.weight_shape(op, cin, cout))
        if op in (V.CONV3X3, V.CONV5X5):
            w = q.transpose(0, 3, 1, 2)                       # OHWI -> OIHW
        elif op == V.DW3X3:
            w = q.transpose(2, 0, 1)[:, None]                 # HWC -> (C, 1, 3, 3)
        else:
            w = q[:, :, None, None]
        w = w * sw[:, None, None, None]
        b = np.asarray(L["bias"], np.float64) * s_in * sw
        out.append((w, b, op))
    return out


def state_for(net, layers):
    """The state dict of net with the recovered layers (weight, bias) in its modules."""
    import torch
    st = {k: v.clone() for k, v in net.state_dict().items()}
    mods = [d["mod"] for d in net.spec if d["mod"] is not None]
    if len(mods) != len(layers):
        raise ValueError(f"the file has {len(layers)} weighted layers, the architecture {len(mods)}")
    for k, (w, b, _) in zip(mods, layers):
        conv = net.mods[k][0]
        if tuple(conv.weight.shape) != w.shape:
            raise ValueError(f"module {k}: file weights {w.shape}, architecture {tuple(conv.weight.shape)}")
        st[f"mods.{k}.0.weight"] = torch.from_numpy(w.astype(np.float32))
        if len(net.mods[k]) > 1 and isinstance(net.mods[k][1], torch.nn.BatchNorm2d):
            bn = net.mods[k][1]
            st[f"mods.{k}.1.weight"] = torch.full_like(bn.weight, float(np.sqrt(1.0 + bn.eps)))
            st[f"mods.{k}.1.bias"] = torch.from_numpy(b.astype(np.float32))
            st[f"mods.{k}.1.running_mean"] = torch.zeros_like(bn.running_mean)
            st[f"mods.{k}.1.running_var"] = torch.ones_like(bn.running_var)
        else:
            st[f"mods.{k}.0.bias"] = torch.from_numpy(b.astype(np.float32))
    return st


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("model", help="the shipped .vdm (its NAME.scales.json beside it)")
    ap.add_argument("--scales", help="the export's scales file (default: beside the model)")
    ap.add_argument("--out", required=True, help="float weights (.npz, as cnn_export --float-out writes them)")
    a = ap.parse_args(argv)
    model = Path(a.model)
    scales = json.loads(Path(a.scales or model.with_suffix(".scales.json")).read_text())
    desc = V.unpack(model.read_bytes())
    net = Net(scales["arch"])
    net.load_state_dict(state_for(net, recover(desc, scales)))
    net.eval()
    E.save_float(net, dict(arch=scales["arch"], step=scales.get("step", 0), qat=True), a.out)
    print(f"{a.out}: {scales['arch']} recovered from {model.name}")


if __name__ == "__main__":
    main()
