# SPDX-License-Identifier: MIT
"""Trains the CNN vehicle detector of issue 10 (PyTorch, CPU) on ../shared/data's training split.

Network: a small fully-convolutional CenterNet-style detector built ONLY from the ops vd's int8 CNN
module runs (lib/include/vd/cnn.h): 3x3 convolution (stride 1/2, pad 1), depthwise 3x3, pointwise 1x1,
x2 nearest upsample and channel concat for skips; batch norm is folded into the convolutions at export
and ReLU becomes the int8 clamp. Input: the frame at half resolution (exact 2x2 box average) after the
per-frame percentile stretch (input_norm 1 of the .vdm). Output at stride 4: a centre heatmap (focal loss
of CenterNet, Zhou et al. 2019), log width / log height (L1, at the centre cell) and the sub-cell centre
offset (L1).

Training: random 192x192 crops of the half-resolution frames, MSRS (road level) and HIT-UAV (drone)
drawn 50/50, augmented: horizontal flip, scale 0.75-1.5, gain/offset and gamma (AGC-like changes),
Gaussian blur and noise; AdamW with a cosine schedule; checkpoints every 500 steps to --out. Frames of
the val split choose the checkpoint/thresholds; the test split is never read here.

    python3 -m vdtools.training.cnn_train --arch main --minutes 40 --out tools/.cache/cnn/main
    python3 -m vdtools.training.cnn_train --arch compact --minutes 30 --out tools/.cache/cnn/compact
    python3 -m vdtools.training.cnn_train --arch main --init tools/.cache/cnn/main_ft2/best.pt --qat --lr 3e-4 \
        --minutes 60 --out tools/.cache/cnn/qat     # quantisation-aware fine-tuning (docs/training.md)

Then vdtools.training.cnn_export quantises and writes models/vd_cnn_<arch>.vdm (docs/training.md).
"""
import argparse
import json
import math
import time
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F

from vdtools.bindings import clib
from vdtools.data import cnn_data as CD
from vdtools.metrics.evaluate import average_precision
from vdtools.training import cnn_export as E
from vdtools.training.cnn_net import (ARCHS, HEAD, Net, fold_bn, load_weights, macs, pad_to,  # noqa: F401
                                      strip_aux, to_input)    # fold_bn, strip_aux: T.* elsewhere
from vdtools.training.cnn_targets import CROP, NORMS, STRIDE, aux_targets, frame_weights, sample, targets

SIZE_WEIGHT = 1.0           # L1 of log sizes + offsets, against the focal heatmap loss
AUX_CLASSES = 2             # cnn_train --aux: person and bicycle heatmaps after the exported channels
AUX_WEIGHT = 0.5            # their focal loss, against the vehicles'

def weight_average(net, decay):
    """cnn_train --ema: an exponential moving average of the weights and the batch-norm statistics
    (torch's AveragedModel with use_buffers; the first update copies the network, each later one
    gives avg = decay * avg + (1 - decay) * net). Its .module is a Net like any other."""
    from torch.optim.swa_utils import AveragedModel, get_ema_multi_avg_fn
    return AveragedModel(net, multi_avg_fn=get_ema_multi_avg_fn(decay), use_buffers=True)


BN_BATCHES = 40     # training batches that re-estimate the average's batch-norm statistics


def refresh_bn(avg_net, frames_by_fam, crop=CROP):
    """Batch-norm statistics measured on the averaged weights (torch's update_bn, as for SWA): the
    average of the statistics the trained weights had over the last ~1/(1-decay) steps does not fit the
    averaged weights while the learning rate is high (measured: val AP@0.5 at step 3 500 road / drone
    0.9 / 0.0 with them, 17.8 / 48.8 re-estimated, 10.2 / 42.2 for the trained weights themselves).
    A fixed seed draws the same crops every time and leaves the training's random stream alone. Not for
    QAT, whose batch norm is frozen and folded (update_bn would reset statistics no forward refills)."""
    from torch.optim.swa_utils import update_bn
    rng = np.random.default_rng(12345)
    norm = getattr(avg_net, "module", avg_net).norm     # an AveragedModel, or a Net itself
    update_bn([batch(frames_by_fam, rng, 16, crop, norm=norm)[0] for _ in range(BN_BATCHES)], avg_net)


FAMILY_SHARE = {"msrs": 0.45, "hit": 0.40, "synth": 0.15}   # of the crops in a batch


def batch(frames_by_fam, rng, n, crop=CROP, cut_ignore=False, paste_p=0.0, donors=None, weights=None, aux=0,
          invert_p=0.0, inv_rng=None, camera_p=0.0, small_p=0.0, cam_rng=None, norm="stretch"):
    """(x, heatmap, mask, size/offset targets, their mask[, aux heatmaps with aux > 0]) of n crops."""
    xs, hms, ms, regs, regms, auxs = [], [], [], [], [], []
    fams = sorted(frames_by_fam)
    p = np.array([FAMILY_SHARE[f] for f in fams])
    for i in range(n):
        fam = fams[rng.choice(len(fams), p=p / p.sum())]
        lst = frames_by_fam[fam]
        k = rng.integers(len(lst)) if weights is None else rng.choice(len(lst), p=weights[fam])
        img, b, ig, *oth = sample(lst[k], rng, crop, cut_ignore=cut_ignore,
                                  donors=(donors or {}).get(fam), paste_p=paste_p, others=aux > 0,
                                  invert_p=invert_p, inv_rng=inv_rng, camera_p=camera_p, small_p=small_p,
                                  cam_rng=cam_rng, norm=norm)
        hm, m, reg, regm = targets(b, ig, crop)
        if aux:
            auxs.append(aux_targets(oth[0], crop, aux))
        xs.append(img)
        hms.append(hm)
        ms.append(m)
        regs.append(reg)
        regms.append(regm)
    x = torch.from_numpy(np.stack(xs)[:, None].astype(np.float32) / 255.0)
    out = (x, torch.from_numpy(np.stack(hms)), torch.from_numpy(np.stack(ms)),
           torch.from_numpy(np.stack(regs)), torch.from_numpy(np.stack(regms)))
    return out + ((torch.from_numpy(np.stack(auxs)),) if aux else ())


def focal(logit, hm, m):
    """CenterNet's penalty-reduced focal loss of a heatmap logit against its target (m: loss mask)."""
    p = torch.sigmoid(logit).clamp(1e-4, 1 - 1e-4)
    pos = (hm >= 1.0).float()
    neg = (1 - pos) * m
    pos_l = -(torch.log(p) * (1 - p) ** 2 * pos).sum()
    neg_l = -(torch.log(1 - p) * p ** 2 * (1 - hm) ** 4 * neg).sum()
    return (pos_l + neg_l) / pos.sum().clamp(min=1)


def mean_maps(outs):
    """Several networks' outputs averaged (cnn_train --teacher, cnn_eval --ensemble): (heatmap probability
    [N, H, W], box channels [N, 4, H, W]) on the region all of them cover (their inputs are padded right and
    bottom to different alignments); channels after HEAD (--aux) are left out."""
    ho, wo = min(o.shape[2] for o in outs), min(o.shape[3] for o in outs)
    outs = [o[:, :HEAD, :ho, :wo] for o in outs]
    return (torch.stack([torch.sigmoid(o[:, 0]) for o in outs]).mean(0),
            torch.stack([o[:, 1:] for o in outs]).mean(0))


def soft_focal(logit, target, m, n_pos):
    """Quality focal loss (Li et al., "Generalized Focal Loss", 2020) of a heatmap logit against soft targets
    in [0, 1] (cnn_train --teacher: the teachers' mean heatmap): binary cross-entropy weighted by
    |target - p|^2, so that the many cells both call background add little; summed over the mask m and
    divided by n_pos, as focal()."""
    p = torch.sigmoid(logit)
    bce = F.binary_cross_entropy_with_logits(logit, target, reduction="none")
    return (bce * (target - p).abs() ** 2 * m).sum() / n_pos.clamp(min=1)


def loss_fn(out, hm, m, reg, regm, giou_weight=0.0, aux_hm=None):
    """giou_weight: cnn_train --giou, the weight of a GIoU box term (0 in the shipped models). aux_hm
    (cnn_train --aux): targets of the head's channels after HEAD, AUX_WEIGHT times their focal loss."""
    hm_l = focal(out[:, 0], hm, m)
    r = (out[:, 1:5] - reg).abs().sum(1)
    size_l = (r * regm).sum() / regm.sum().clamp(min=1)
    total = hm_l + SIZE_WEIGHT * size_l
    if giou_weight > 0:
        total = total + giou_weight * ((1 - giou(out[:, 1:5], reg)) * regm).sum() / regm.sum().clamp(min=1)
    if aux_hm is not None:
        total = total + AUX_WEIGHT * focal(out[:, HEAD:], aux_hm, m[:, None])
    return total, hm_l.item(), size_l.item()


def giou(o, t, stride=STRIDE):
    """Generalised IoU (Rezatofighi et al. 2019) of the decoded box and the target box at each cell:
    (log w, log h, dx, dy) channels, both boxes anchored at the same cell, target centred at 0.
    Added to the L1 terms because an L1 on log sizes does not weigh what AP@0.5 measures: large close
    cars whose detections overlap 0.3-0.5 (docs/results/detector.md)."""
    wp, hp = torch.exp(o[:, 0].clamp(max=8.0)), torch.exp(o[:, 1].clamp(max=8.0))
    wt, ht = torch.exp(t[:, 0]), torch.exp(t[:, 1])
    dx, dy = (o[:, 2] - t[:, 2]) * stride, (o[:, 3] - t[:, 3]) * stride
    def span(d, a, b):          # predicted [d - a/2, d + a/2] against target [-b/2, b/2]
        inter = (torch.minimum(d + a / 2, b / 2) - torch.maximum(d - a / 2, -b / 2)).clamp(min=0)
        hull = torch.maximum(d + a / 2, b / 2) - torch.minimum(d - a / 2, -b / 2)
        return inter, hull
    iw, cw = span(dx, wp, wt)
    ih, ch = span(dy, hp, ht)
    inter = iw * ih
    union = wp * hp + wt * ht - inter
    hull = cw * ch
    return inter / union - (hull - union) / hull


# ---------------------------------------------------------------- float decoding and evaluation



def decode_float(out, thr=0.05, k=100, stride=STRIDE):
    """Float twin of vd_cnn_decode: 3x3 peaks, top-k, boxes in network-input pixels (x, y, w, h, score)."""
    o = out[0]
    p = torch.sigmoid(o[0])
    mx = F.max_pool2d(p[None, None], 3, 1, 1)[0, 0]
    peaks = (p == mx) & (p >= thr)
    ys, xs = torch.nonzero(peaks, as_tuple=True)
    sc = p[ys, xs]
    order = torch.argsort(sc, descending=True)[:k]
    res = []
    for i in order.tolist():
        y, x = int(ys[i]), int(xs[i])
        w, h = math.exp(float(o[1, y, x])), math.exp(float(o[2, y, x]))
        cx, cy = (x + float(o[3, y, x])) * stride, (y + float(o[4, y, x])) * stride
        res.append((cx - w / 2, cy - h / 2, w, h, float(sc[i])))
    return res


def nms(dets, thr=0.5):
    from vdtools.metrics.evaluate import iou
    keep = []
    for d in sorted(dets, key=lambda d: -d[4]):
        if all(iou(d[:4], k[:4]) < thr for k in keep):
            keep.append(d)
    return keep


def gts_of(fr):
    return [tuple(b) + (True, False) for b in fr.boxes.tolist()] + [tuple(b) + (False, True) for b in fr.ignore.tolist()]


@torch.no_grad()
def evaluate(net, frames, thr=0.05):
    """{family: AP@0.5} of the float network on full frames (boxes back to full resolution)."""
    net.eval()
    per = {}
    for fr in frames:
        img = pad_to(CD.half(fr.img), net.align)
        out = net(to_input(img, net.norm))
        dets = [((x * 2, y * 2, w * 2, h * 2), s) for x, y, w, h, s in nms(decode_float(out, thr))]
        per.setdefault(CD.family(fr), []).append((dets, gts_of(fr)))
    net.train()
    return {f: average_precision(v)[0] for f, v in per.items()}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--arch", default="main", choices=sorted(ARCHS))
    ap.add_argument("--data", default=str(clib.REPO.parent / "shared" / "data"))
    ap.add_argument("--out", required=True)
    ap.add_argument("--minutes", type=float, default=40.0)
    ap.add_argument("--steps", type=int, default=0, help="budget in optimiser steps instead of --minutes (the cosine "
                    "schedule runs over them): the same run whatever else shares the machine's cores")
    ap.add_argument("--batch", type=int, default=16)
    ap.add_argument("--lr", type=float, default=3e-3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--eval-every", type=int, default=1000)
    ap.add_argument("--resume", action="store_true")
    ap.add_argument("--init", help="start from this checkpoint's weights (fine-tuning; fresh optimiser and schedule)")
    ap.add_argument("--share", help="crop shares per family, e.g. msrs=0.6,hit=0.3,synth=0.1 (default 0.45/0.40/0.15)")
    ap.add_argument("--synth", action="store_true", help="add the synthetic training clips (15 %% of the crops)")
    ap.add_argument("--exclude", choices=("msrs-night",), help="leave these frames out of training (the "
                    "another-camera estimate of docs/results/detector.md: train without night MSRS, test on it)")
    ap.add_argument("--road-scenes", type=float, default=1.0, help="train on this share of the MSRS training "
                    "scene groups only (cnn_data.scene_subset, seed 0; val unchanged): the learning curve of "
                    "docs/training.md")
    ap.add_argument("--qat", action="store_true", help="quantisation-aware fine-tuning of --init: frozen batch "
                    "norm, weights and activations fake-quantised with the exporter's scales (recalibrated at "
                    "every evaluation); best.pt is chosen on the fake-quantised val AP")
    ap.add_argument("--giou", type=float, default=0.0, help="weight of a GIoU box term (0: L1 only)")
    ap.add_argument("--crop", type=int, default=CROP, help="side of the square training crops, half-resolution "
                    "pixels (multiple of 16)")
    ap.add_argument("--cut-ignore", action="store_true", help="a vehicle the crop cuts to under 60 %% of its area, "
                    "or whose centre it cuts off, is an ignore region (cnn_targets.split_cut) instead of a clipped "
                    "positive or background; measured without a val gain (docs/training.md), so off by default")
    ap.add_argument("--paste", type=float, default=0.0, help="probability of copy-paste augmentation per crop: "
                    "1-3 vehicles of other training frames of the same family pasted in (cnn_targets.paste)")
    ap.add_argument("--oblique", type=float, default=1.0, help="draw drone frames with a camera angle of at most "
                    "40 degrees this many times as often as the others (1: uniform)")
    ap.add_argument("--wd", type=float, default=1e-4, help="AdamW weight decay (1e-4 in every shipped model)")
    ap.add_argument("--dropout", type=float, default=0.0, help="channel dropout (Dropout2d) on the decoder's "
                    "concat outputs while training, float only (0 in every shipped model)")
    ap.add_argument("--invert", type=float, default=0.0, help="probability of inverting a training frame's "
                    "polarity (255 - v): hot cars look like cold ones and back (0 in every shipped model)")
    ap.add_argument("--camera", type=float, default=0.0, help="probability of another camera's tone curve and "
                    "texture per training frame (cnn_targets.camera_shift; docs/results/cameras.md)")
    ap.add_argument("--small", type=float, default=0.0, help="probability that a training frame is shrunk by "
                    "0.3-0.6 instead of 0.6-1.4 (small cars, as a wider lens or a higher mount shows them)")
    ap.add_argument("--norm", choices=sorted(NORMS), help="input normalisation (cnn_targets.NORMS; the .vdm "
                    "input_norm): stretch (percentile, every model before 2026-11-28) or equalise (histogram "
                    "equalisation: any monotone tone curve of a camera gives the same input); default: --init's, "
                    "else stretch")
    ap.add_argument("--aux", action="store_true", help="also learn person and bicycle heatmaps in extra head "
                    "channels (AUX_WEIGHT of their focal loss) that the export drops (0 extra cost at run time)")
    ap.add_argument("--teacher", action="append", default=[], help="distillation (repeatable): a float "
                    "checkpoint (.pt or models/float/*.npz) whose heatmap, averaged over every --teacher, is a "
                    "second, soft target of the vehicle heatmap (soft_focal, weight --distill)")
    ap.add_argument("--distill", type=float, default=1.0, help="weight of the teachers' soft heatmap term")
    ap.add_argument("--ema", type=float, default=0.0, help="keep an exponential moving average of the weights "
                    "and batch-norm statistics with this decay per step (e.g. 0.999; 0: off) and evaluate, "
                    "choose and save it instead of the raw weights")
    a = ap.parse_args(argv)
    if a.qat and not a.init:
        ap.error("--qat fine-tunes a trained network: give --init")
    if a.crop % 16:
        ap.error("--crop must be a multiple of 16")
    if not 0.0 <= a.ema < 1.0:
        ap.error("--ema must be in [0, 1)")
    torch.set_num_threads(a.threads)
    torch.manual_seed(a.seed)
    rng = np.random.default_rng(a.seed)
    inv_rng = np.random.default_rng(a.seed + 7919)     # --invert's own draws: rng's crops stay unchanged
    cam_rng = np.random.default_rng(a.seed + 104729)   # --camera / --small: their own draws too
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    frames = CD.load_frames(a.data, splits=("train", "val"), synth=a.synth)
    train = [f for f in frames if f.split == "train"]
    val = [f for f in frames if f.split == "val"]
    if a.exclude == "msrs-night":
        train = [f for f in train if CD.subset(f) != "msrs-night"]
        val = [f for f in val if CD.subset(f) != "msrs-night"]      # nor choose the checkpoint on them
    if a.road_scenes != 1.0:
        train = CD.scene_subset(train, "msrs", a.road_scenes)
    by_fam = {}
    for f in train:
        by_fam.setdefault(CD.family(f), []).append(f)
    donors = {k: [f for f in v if len(f.boxes)] for k, v in by_fam.items()}
    weights = None if a.oblique == 1.0 else {k: frame_weights(v, a.oblique) for k, v in by_fam.items()}
    print(f"train {len(train)} frames ({ {k: len(v) for k, v in by_fam.items()} }; "
          f"{len({f.group for f in by_fam.get('msrs', [])})} MSRS scene groups), val {len(val)}", flush=True)
    n_aux = AUX_CLASSES if a.aux else 0
    init = E.read_ckpt(a.init) if a.init else None
    net = Net(a.arch, n_aux, norm=a.norm or (init["norm"] if init else "stretch"))
    if a.init:     # a checkpoint, or the float weights kept beside a shipped model (models/float)
        load_weights(net, init["net"])
    teachers = []
    if a.teacher:
        teachers = [E.load_net(t)[0] for t in a.teacher]     # eval mode; they draw no random numbers
        if any(a.crop % t.align for t in teachers):
            ap.error("--crop must be a multiple of every teacher's input alignment")
    # --ema: torch's own averaging (AveragedModel with use_buffers averages the batch-norm statistics too);
    # `ev` is the network evaluated, chosen and saved: the average, or the trained weights themselves.
    ema = weight_average(net, a.ema) if a.ema else None
    ev = ema.module if ema is not None else net
    net.dropout = a.dropout     # after the average copied the network: the average is only evaluated (no dropout)
    if a.qat:
        calib = E.calibration_frames(train)
        def recalibrate():
            """The exporter's scales for the trained weights and, with --ema, for the average."""
            for m in (net,) if ev is net else (net, ev):
                m.set_fake_quant(None)
                m.eval()
                _, q = E.quantise(m, E.calibrate(m, calib))
                m.train()
                m.set_fake_quant(q)
        recalibrate()
        print(f"QAT: int8 val AP at start {evaluate(ev, val)}", flush=True)
    if a.share:
        FAMILY_SHARE.update({k: float(v) for k, v in (kv.split("=") for kv in a.share.split(","))})
    print(f"arch {a.arch}: {sum(p.numel() for p in net.parameters())} parameters, "
          f"{macs(net, 320, 256) / 1e6:.1f} M MACs at 320x256", flush=True)
    opt = torch.optim.AdamW(net.parameters(), lr=a.lr, weight_decay=a.wd)
    step, t_used, log = 0, 0.0, []
    if a.resume and (out / "last.pt").exists():
        ck = torch.load(out / "last.pt", weights_only=False)
        net.load_state_dict(ck["net"])
        if ema is not None and "ema" in ck:
            ema.load_state_dict(ck["ema"])
        opt.load_state_dict(ck["opt"])
        step, t_used, log = ck["step"], ck["t_used"], ck["log"]
    budget = a.minutes * 60
    t0 = time.time() - t_used

    def evaluate_now():
        """Val AP of the network that is chosen and saved (`ev`), made ready as its export will run it."""
        if a.qat:
            recalibrate()
        elif ema is not None:
            refresh_bn(ev, by_fam, a.crop)
        aps = evaluate(ev, val)
        log.append(dict(step=step, minutes=(time.time() - t0) / 60, val_ap=aps))
        return aps

    def save_eval(aps, name):
        """A checkpoint of the network evaluated (`ev`), as cnn_export.load_net reads it."""
        torch.save(dict(net=ev.state_dict(), arch=a.arch, step=step, val_ap=aps, qat=a.qat, aux=n_aux,
                        norm=net.norm), out / name)

    def progress():
        """Share of the budget used: steps with --steps, else wall time."""
        return step / a.steps if a.steps > 0 else (time.time() - t0) / budget

    best, best_fam = -1.0, {}
    while True:
        el = time.time() - t0
        done = progress()
        if done >= 1.0:
            break
        lr = a.lr * 0.5 * (1 + math.cos(math.pi * min(1.0, done)))
        if step < 200:
            lr *= (step + 1) / 200
        for g in opt.param_groups:
            g["lr"] = lr
        x, hm, m, reg, regm, *aux_hm = batch(by_fam, rng, a.batch, a.crop, a.cut_ignore, a.paste, donors, weights,
                                             n_aux, a.invert, inv_rng, a.camera, a.small, cam_rng, net.norm)
        o = net(x)
        loss, hl, sl = loss_fn(o, hm, m, reg, regm, a.giou, aux_hm[0] if aux_hm else None)
        if teachers:
            with torch.no_grad():
                soft = mean_maps([t(x) for t in teachers])[0]
            loss = loss + a.distill * soft_focal(o[:, 0], soft, m, (hm >= 1.0).float().sum())
        opt.zero_grad()
        loss.backward()
        opt.step()
        if ema is not None:
            ema.update_parameters(net)
        step += 1
        if step % 50 == 0:
            print(f"step {step} t {el / 60:.1f} min lr {lr:.2e} loss {loss.item():.3f} hm {hl:.3f} size {sl:.3f}", flush=True)
        if step % a.eval_every == 0 or progress() >= 1.0:
            aps = evaluate_now()
            mean = float(np.nanmean(list(aps.values())))
            print(f"== step {step}: val AP {aps}", flush=True)
            if mean > best:
                best = mean
                save_eval(aps, "best.pt")
            for fam, v in aps.items():      # per family too: a preset for one viewpoint is chosen on its AP alone
                if v > best_fam.get(fam, -1.0):
                    best_fam[fam] = v
                    save_eval(aps, f"best_{fam}.pt")
        if step % 250 == 0:
            torch.save(dict(net=net.state_dict(), opt=opt.state_dict(), step=step, t_used=time.time() - t0,
                            log=log, arch=a.arch, aux=n_aux, norm=net.norm, **({"ema": ema.state_dict()} if ema is not None else {})),
                       out / "last.pt")
    # the loop's last step is normally evaluated already (its time budget ran out there)
    aps = log[-1]["val_ap"] if log and log[-1]["step"] == step else evaluate_now()
    save_eval(aps, "final.pt")
    (out / "log.json").write_text(json.dumps(log, indent=1))
    print(f"done: {step} steps, val AP {aps}", flush=True)


if __name__ == "__main__":
    main()
