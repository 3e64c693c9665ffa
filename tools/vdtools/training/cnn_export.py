# SPDX-License-Identifier: MIT
"""Post-training int8 quantisation of a trained CNN detector and export to the version-3 .vdm kind.

Steps (docs/fixed-point.md "CNN", docs/model-format.md "CNN kind"):
1. batch norm folded into the preceding convolution (w' = w g / sqrt(v + eps), b' = beta - m g / sqrt(v + eps));
2. calibration: the folded float network runs on CALIB_FRAMES training-split frames (half resolution,
   stretched, as in the detector); each tensor's range is the CALIB_PCT percentile of its values (post-ReLU
   tensors: [0, p]; the head: [min, max] with the heatmap logit clipped to [-8, 8]);
3. tensors joined by upsample / concat share one scale (the C module copies them without requantising);
4. weights int8 symmetric per output channel (scale max|w| / 127), biases int32 in accumulator units,
   multipliers s_in s_w / s_out as Q31 + shift (TFLite QuantizeMultiplier), ReLU as act_min = out_zp;
5. decode table: heatmap logit -> Q15 sigmoid, log sizes -> Q8 pixels, offsets -> Q8 cells.

    python3 -m vdtools.training.cnn_export tools/.cache/cnn/main/best.pt --name vd_cnn --thr 0.3
"""
import argparse
import json
import math
from pathlib import Path

import numpy as np
import torch

from vdtools.bindings import clib
from vdtools.data import cnn_data as CD
from vdtools.formats import cnn_vdm as V
from vdtools.formats.quantise import int8_per_channel, quantize_multiplier
from vdtools.training import cnn_net as N
from vdtools.training.cnn_targets import NORM, NORM_CODE, STRIDE

CALIB_FRAMES = 96
# Vehicles cover few pixels, so the largest activations are theirs: the 99.99th percentile clipped them and
# cost val road AP 1.7-2.7 points on each of five trained networks (fake-quantised against float), the
# 99.999th 0.0-1.5 (docs/training.md "Calibration").
CALIB_PCT = 99.999
OPS = {"conv": V.CONV3X3, "dw": V.DW3X3, "pw": V.PW1X1, "head": V.PW1X1, "up": V.UPSAMPLE2, "cat": V.CONCAT}


def read_ckpt(ckpt):
    """{net: state dict, arch, step, qat, ...} of a training checkpoint (.pt) or of the float weights kept
    beside a shipped model (.npz, save_float)."""
    if str(ckpt).endswith(".npz"):
        with np.load(ckpt) as z:
            return dict(net={k: torch.from_numpy(z[k]) for k in z.files if not k.startswith("__")},
                        arch=str(z["__arch__"]), step=int(z["__step__"]), qat=bool(z["__qat__"]),
                        norm=str(z["__norm__"]) if "__norm__" in z.files else "stretch")
    ck = torch.load(ckpt, weights_only=False, map_location="cpu")
    ck.setdefault("norm", "stretch")      # checkpoints before cnn_train --norm
    return ck


def load_net(ckpt):
    """The network of read_ckpt(ckpt), in eval mode, with its checkpoint dict."""
    ck = read_ckpt(ckpt)
    net = N.Net(ck["arch"], norm=ck["norm"])
    net.load_state_dict(N.strip_aux(ck["net"], ck["arch"]) if ck.get("aux") else ck["net"])   # --aux channels dropped
    net.eval()
    return net, ck


def folded(net):
    """Per layer (float weights in the C layout, float bias) after folding batch norm."""
    out = []
    for d in net.spec:
        if d["mod"] is None:
            out.append(None)
            continue
        w, b = N.fold_bn(net.mods[d["mod"]], torch.float64)     # w: (cout, cin/groups, kh, kw)
        out.append((w.numpy(), b.numpy()))
    return out


def save_float(net, ck, path):
    """The float weights a .vdm was exported from, as plain arrays (.npz: no pickle, no torch needed to read
    them): `cnn_eval --ckpt` measures int8 against float from them after the training cache is gone, and
    tests/python/test_cnn_float.py checks that they quantise to the shipped int8 weights."""
    arrays = {k: v.detach().cpu().numpy() for k, v in net.state_dict().items()}
    np.savez_compressed(path, __arch__=np.array(ck["arch"]), __step__=np.array(int(ck.get("step") or 0)),
                        __qat__=np.array(bool(ck.get("qat"))), __norm__=np.array(ck.get("norm", "stretch")),
                        **arrays)


def calibration_frames(frames, n=CALIB_FRAMES):
    """The n frames (seeded draw without replacement) the exporter, QAT and cnn_prune calibrate on."""
    rng = np.random.default_rng(0)
    return [frames[i] for i in rng.choice(len(frames), min(n, len(frames)), replace=False)]


def forward_all(net, frames):
    """Every tensor of net (float, as cnn_export calibrates: half resolution, padded) per frame."""
    with torch.no_grad():
        for fr in frames:
            yield net(N.to_input(N.pad_to(CD.half(fr.img), net.align), net.norm), return_all=True)


def calibrate(net, frames):
    """Per tensor: (lo, hi) real range."""
    vals = None
    for ts in forward_all(net, frames):
        if vals is None:
            vals = [[] for _ in ts]
        for i, t in enumerate(ts):
            a = t.numpy().ravel()
            if a.size > 200000:
                a = a[:: a.size // 200000]
            vals[i].append(a)
    rng = []
    for i, v in enumerate(vals):
        a = np.concatenate(v)
        rng.append((float(np.percentile(a, 100.0 - CALIB_PCT)), float(np.percentile(a, CALIB_PCT))))
    return rng


def quantise(net, ranges, thr_score=0.3, max_peaks=100, name="vd_cnn"):
    L = len(net.spec)
    head_t = L                        # the last tensor
    # tensors joined by up / cat share one scale: union-find
    parent = list(range(L + 1))
    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i
    def join(a, b):
        parent[find(a)] = find(b)
    for i, d in enumerate(net.spec):
        if d["op"] == "up":
            join(i + 1, d["in"])
        elif d["op"] == "cat":
            join(i + 1, d["in"])
            join(i + 1, d["in2"])
    hi = {}
    for t in range(1, L + 1):
        if t == head_t:
            continue
        r = find(t)
        hi[r] = max(hi.get(r, 1e-6), ranges[t][1])
    scale, zp = [1.0 / 255.0], [-128]
    for t in range(1, L + 1):
        if t == head_t:
            lo_h, hi_h = ranges[t]
            lo_h, hi_h = max(-8.0, min(lo_h, -0.5)), min(max(hi_h, 6.0), 16.0)
            s = (hi_h - lo_h) / 255.0
            scale.append(s)
            zp.append(int(np.clip(round(-128 - lo_h / s), -128, 127)))
        else:
            scale.append(hi[find(t)] / 255.0)
            zp.append(-128)
    fl = folded(net)
    layers = []
    for i, d in enumerate(net.spec):
        s_in, z_in = scale[d["in"]], zp[d["in"]]
        s_out, z_out = scale[i + 1], zp[i + 1]
        lay = dict(op=OPS[d["op"]], stride=d["stride"], **{"in": d["in"]}, in2=d["in2"], cin=d["cin"],
                   cout=d["cout"], out_zp=z_out, act_min=-128, act_max=127)
        if fl[i] is not None:
            w, b = fl[i]
            cout = w.shape[0]
            wq, sw = int8_per_channel(w)
            lay["w"] = V.weights_from_oihw(wq, OPS[d["op"]])
            lay["bias"] = np.round(b / (s_in * sw)).astype(np.int64).clip(-(2 ** 31) + 1, 2 ** 31 - 1).astype(np.int32)
            ms = [quantize_multiplier(float(s_in * sw[o] / s_out)) for o in range(cout)]
            lay["mult"] = np.array([m for m, _ in ms], np.int32)
            lay["shift"] = np.array([sh for _, sh in ms], np.int8)
            if d["op"] != "head":
                lay["act_min"] = z_out                         # ReLU
        else:
            lay["w"] = lay["bias"] = lay["mult"] = lay["shift"] = None
        layers.append(lay)
    s_h, z_h = scale[head_t], zp[head_t]
    v = (np.arange(256) - 128 - z_h) * s_h                     # real value of each int8 code
    table = np.zeros((5, 256), np.int64)
    table[0] = np.round(32768.0 / (1.0 + np.exp(-v)))
    table[1] = table[2] = np.clip(np.round(np.exp(np.minimum(v, math.log(4096))) * 256), 0, 4096 * 256)
    table[3] = table[4] = np.clip(np.round(v * 256), -256, 512)
    logit = math.log(thr_score / (1 - thr_score))
    thr_q = int(np.clip(math.ceil(logit / s_h + z_h), -128, 127))
    norm = dict(input_norm=1, **NORM) if net.norm == "stretch" else dict(
        input_norm=NORM_CODE[net.norm], norm_lo_permille=0, norm_hi_permille=0, norm_min_range=0)
    desc = dict(input_w=320, input_h=256, input_zp=-128, out_stride=STRIDE, out_channels=5,
                score_threshold_q=thr_q, max_peaks=max_peaks, name=name, layers=layers,
                table=table.astype(np.int32), **norm)
    return desc, dict(scale=scale, zp=zp)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("ckpt")
    ap.add_argument("--name", default="vd_cnn")
    ap.add_argument("--data", default=str(clib.REPO.parent / "shared" / "data"))
    ap.add_argument("--thr", type=float, default=0.3, help="default score threshold written into the header")
    ap.add_argument("--out-dir", default=str(clib.REPO / "models"))
    ap.add_argument("--max-peaks", type=int, default=100, help="decoding top-K written into the header (the "
                    "demo sizes its candidate and detection budgets from it: docs/embedded.md)")
    ap.add_argument("--float-out", help="also write the checkpoint's float weights here (.npz, models/float/)")
    ap.add_argument("--exclude", choices=("msrs-night",), help="calibrate without these frames (a model "
                    "trained with cnn_train --exclude: the another-camera estimate must not see them at all)")
    a = ap.parse_args(argv)
    net, ck = load_net(a.ckpt)
    frames = CD.load_frames(a.data, splits=("train",))
    if a.exclude == "msrs-night":
        frames = [f for f in frames if CD.subset(f) != "msrs-night"]
    ranges = calibrate(net, calibration_frames(frames))
    desc, q = quantise(net, ranges, a.thr, max_peaks=a.max_peaks, name=a.name)
    blob = V.pack(desc)
    V.write_c_array(blob, a.name, a.out_dir)
    kind = "fake-quantised (QAT)" if ck.get("qat") else "float"   # what the checkpoint's val AP measured
    # per-tensor real scales: the ONNX peer (vdtools.formats.cnn_onnx) needs them; the .vdm holds only multipliers
    meta = dict(scale=q["scale"], zp=q["zp"], ranges=ranges, arch=ck["arch"], step=ck.get("step"),
                val_ap_float=ck.get("val_ap"), val_ap_kind=kind, thr=a.thr)
    Path(a.out_dir, f"{a.name}.scales.json").write_text(json.dumps(meta, indent=1) + "\n")
    if a.float_out:
        save_float(net, ck, a.float_out)
    print(f"wrote {a.out_dir}/{a.name}.vdm ({len(blob)} bytes), step {ck.get('step')}, val AP ({kind}) {ck.get('val_ap')}")


if __name__ == "__main__":
    main()
