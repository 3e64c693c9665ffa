# SPDX-License-Identifier: MIT
"""Paper 003's verifier on our data: a five-layer 5x5 CNN trained on 64x64 vehicle / non-vehicle crops,
the feature maps with the largest activation selected in Maxpool_1, Conv_4 and Conv_5 (paper §2.5, §3.2),
AdaBoost (SAMME) of decision stumps on the concatenated int8 maps, exported as one boosted-kind .vdm
(tools/vdtools/formats/boost_vdm.py, docs/model-format.md "Boosted kind").

Steps (each cached in tools/.cache/p003/, see docs/training.md "Paper 003"):
  crops    vdtools.data.dataset.build(size=64, test_windows=60): the DBN data set's rows (vehicles, jittered
           and mirrored train copies, candidate / random / window / contrast hard negatives) cut at 64x64,
           with 60 window negatives per test frame (the DET protocol reads 1e-4 FPPW)
  train    the CNN (float, PyTorch CPU): conv5x5 F -> conv5x5 F -> maxpool -> conv5x5 F x3 -> maxpool ->
           1x1 head (global mean of the head's channel 0 = vehicle logit); padding 2 ("same"), ReLU;
           Adam, batch 128, random horizontal flips; input = the CNN module's percentile stretch of the
           crop (exactly what the int8 network sees); best epoch by val loss
  quant    int8 post-training quantisation (per-tensor activation scales from the 99.99th percentile of
           2000 train crops, per-channel symmetric weights), version-3 CNN desc
  features the int8 tensors of every crop by the C library (vd_cnn_run_ex, bit-exact with cnn_ref)
  select   per layer (Maxpool_1 = t3, Conv_4 = t5, Conv_5 = t6) the maps ranked by mean activation over
           the val vehicles (the paper's "largest activation"; int8 values of one tensor share a scale)
  boost    sklearn AdaBoostClassifier(DecisionTreeClassifier(max_depth=1)), SAMME, on the train rows;
           the number of stumps and the accept threshold chosen on val; stumps -> int8 thresholds,
           int16 weights (Q-format of the largest AdaBoost weight)

    cd tools && python3 -m vdtools.training.boost_train all --filters 8 --epochs 4
    cd tools && python3 -m vdtools.training.boost_train time --time-steps 5   # training cost at 8 vs 60 filters,
                                                          # docs/results/boost_train_time.json (no data needed)
"""
import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

from vdtools.formats import boost_vdm as B
from vdtools.bindings import clib
from vdtools.formats import cnn_ref as R
from vdtools.formats import cnn_vdm as V
from vdtools.bindings import cnn as vd_cnn
from vdtools.formats.quantise import quantize_multiplier

CACHE = clib.REPO / "tools" / ".cache" / "p003"
CROPS = CACHE / "crops64_grey_s0_v3_tw60.npz"
SIDE = 64
NORM = dict(input_norm=1, norm_lo_permille=10, norm_hi_permille=990, norm_min_range=16)
LAYER_T = {"Maxpool_1": 3, "Conv_4": 5, "Conv_5": 6}   # tensor index of the paper's three layers


def log(*a):
    print(time.strftime("%H:%M:%S"), *a, flush=True)


def load_crops(path=CROPS):
    from vdtools.data import dataset
    if not Path(path).exists():
        ds = dataset.build(mode="grey", seed=0, progress=True, size=SIDE, test_windows=60)
        dataset.save(ds, Path(path))
    return dataset.load(Path(path))


def norm_desc():
    return dict(NORM, input_w=SIDE, input_h=SIDE)


def preprocess_all(X):
    d = norm_desc()
    return np.stack([R.preprocess(x, d)[:, :, 0] for x in X])


def test_crops(limit=None):
    """uint8 [N, 64, 64]: every row of the standard test split (vdtools.data.dataset, the DBN's 32x32 rows:
    vehicles, candidate / random / window / contrast negatives) re-cut at 64x64 from its frame with the
    C resampler. What CI's parity test runs (tests/python/test_boost_parity.py)."""
    from vdtools.data import dataset, samples
    ds = dataset.load_or_build_split("test")
    paths = {f.name: f.path for f in dataset.all_frames(clib.DATA_DIR, synth=False)}
    out = np.empty((len(ds["y"]), SIDE, SIDE), np.uint8)
    cur, img = None, None
    for i, (fr, r) in enumerate(zip(ds["frame"], ds["rect"])):
        if fr != cur:
            cur, img = fr, dataset.read_frame(paths[fr])
        out[i] = samples.sample32(img, tuple(int(v) for v in r), "grey", SIDE)
    return out[:limit]


# ------------------------------------------------------------------ float network

def make_net(F):
    import torch.nn as nn

    class Net(nn.Module):
        def __init__(self):
            super().__init__()
            c = lambda i, o: nn.Conv2d(i, o, 5, padding=2)
            self.convs = nn.ModuleList([c(1, F), c(F, F), c(F, F), c(F, F), c(F, F)])
            self.head = nn.Conv2d(F, 1, 1)
            self.drop = nn.Dropout(0.3)

        def forward(self, x, taps=False):
            import torch.nn.functional as Fn
            t = [x]
            x = Fn.relu(self.convs[0](x)); t.append(x)
            x = Fn.relu(self.convs[1](x)); t.append(x)
            x = Fn.max_pool2d(x, 2); t.append(x)
            for k in (2, 3, 4):
                x = Fn.relu(self.convs[k](x)); t.append(x)
            x = Fn.max_pool2d(x, 2); t.append(x)
            h = self.head(self.drop(x)); t.append(h)
            logit = h.mean(dim=(1, 2, 3))
            return (logit, t) if taps else logit
    return Net()


def to_float(q):
    """int8 network input -> the float the int8 model represents (scale 1/255, zero point -128)."""
    return (q.astype(np.float32) + 128.0) / 255.0


def train(ds, F=8, epochs=4, seed=0, out=CACHE / "cnn.pt", max_train=None):
    import torch
    torch.set_num_threads(1)
    torch.manual_seed(seed)
    rng = np.random.default_rng(seed)
    tr = np.nonzero(ds["split"] == "train")[0]
    va = np.nonzero(ds["split"] == "val")[0]
    if max_train and len(tr) > max_train:
        tr = np.sort(rng.choice(tr, max_train, replace=False))
    log(f"preprocess {len(tr)} train + {len(va)} val crops")
    Xtr = torch.from_numpy(to_float(preprocess_all(ds["X"][tr])))[:, None]
    ytr = torch.from_numpy(ds["y"][tr].astype(np.float32))
    Xva = torch.from_numpy(to_float(preprocess_all(ds["X"][va])))[:, None]
    yva = torch.from_numpy(ds["y"][va].astype(np.float32))
    net = make_net(F)
    opt = torch.optim.Adam(net.parameters(), lr=1e-3)
    pos_w = torch.tensor(float((ytr == 0).sum()) / max(1.0, float((ytr == 1).sum())))
    lossf = torch.nn.BCEWithLogitsLoss(pos_weight=pos_w)
    best = (math.inf, -1)
    for ep in range(epochs):
        net.train()
        perm = torch.from_numpy(rng.permutation(len(tr)))
        t0, tot = time.time(), 0.0
        for b0 in range(0, len(tr), 128):
            idx = perm[b0:b0 + 128]
            x = Xtr[idx]
            flip = torch.from_numpy(rng.random(len(idx)) < 0.5)
            x = torch.where(flip[:, None, None, None], x.flip(3), x)
            opt.zero_grad()
            loss = lossf(net(x), ytr[idx])
            loss.backward()
            opt.step()
            tot += float(loss) * len(idx)
        net.eval()
        with torch.no_grad():
            logits = torch.cat([net(Xva[i:i + 512]) for i in range(0, len(va), 512)])
            lv = float(torch.nn.functional.binary_cross_entropy_with_logits(logits, yva))
            acc = float(((logits > 0).float() == yva).float().mean())
        log(f"epoch {ep + 1}/{epochs}: train loss {tot / len(tr):.4f}, val loss {lv:.4f}, val acc {acc:.4f}, "
            f"{time.time() - t0:.0f} s")
        if lv < best[0]:
            best = (lv, ep + 1)
            torch.save({"F": F, "net": net.state_dict(), "epoch": ep + 1, "val_loss": lv, "val_acc": acc}, out)
    log(f"best epoch {best[1]} (val loss {best[0]:.4f}) -> {out}")
    return out


def net_macs(F, side=SIDE):
    """Multiply-adds of make_net(F)'s forward pass on one side x side crop (convolutions and head)."""
    full, half, quarter = side * side, (side // 2) ** 2, (side // 4) ** 2
    return full * 25 * F + full * 25 * F * F + 3 * half * 25 * F * F + quarter * F


def time_train(filters=(8, 60), steps=3, batch=128, seed=0, n_train=12000, epochs=3):
    """Seconds per training batch of make_net(F) (one thread, Adam + BCE as train(), random inputs: the
    cost of a convolution does not depend on the pixel values), the first batch not counted; extrapolated
    to one epoch of n_train crops and to the shipped schedule (epochs x n_train, docs/training.md)."""
    import torch
    torch.set_num_threads(1)
    torch.manual_seed(seed)
    x = torch.rand(batch, 1, SIDE, SIDE)
    y = (torch.rand(batch) < 0.5).float()
    lossf = torch.nn.BCEWithLogitsLoss()
    rows = []
    for F in filters:
        net = make_net(F)
        net.train()
        opt = torch.optim.Adam(net.parameters(), lr=1e-3)
        ts = []
        for k in range(steps + 1):
            t0 = time.perf_counter()
            opt.zero_grad()
            lossf(net(x), y).backward()
            opt.step()
            if k:
                ts.append(time.perf_counter() - t0)
            log(f"filters {F}: batch {k} {time.perf_counter() - t0:.2f} s" + ("" if k else " (warm-up, not counted)"))
        per = float(np.median(ts))
        nb = math.ceil(n_train / batch)
        rows.append(dict(filters=F, macs=net_macs(F), s_per_batch=round(per, 3), steps=steps,
                         s_per_epoch=round(per * nb, 1), s_schedule=round(per * nb * epochs, 1)))
    return dict(batch=batch, n_train=n_train, epochs=epochs, threads=1, torch=torch.__version__, rows=rows)


# ------------------------------------------------------------------ int8 quantisation

def quantise(ck, ds, name="vd_boost", n_calib=2000, seed=0):
    """Version-3 CNN desc of the trained float net (see module doc); head = 3 channels (channel 0 the
    vehicle logit map, 1-2 zero: the CNN kind needs 3 or 5 head channels and a decode table; the boosted
    verifier reads only the selected maps)."""
    import torch
    F = ck["F"]
    net = make_net(F)
    net.load_state_dict(ck["net"])
    net.eval()
    rng = np.random.default_rng(seed)
    tr = np.nonzero(ds["split"] == "train")[0]
    pick = np.sort(rng.choice(tr, min(n_calib, len(tr)), replace=False))
    x = torch.from_numpy(to_float(preprocess_all(ds["X"][pick])))[:, None]
    with torch.no_grad():
        _, taps = net(x, taps=True)
    # tensors: 0 in, 1 c1, 2 c2, 3 mp1 (= 2's scale), 4 c3, 5 c4, 6 c5, 7 mp2 (= 6's scale), 8 head
    hi = [1.0] + [max(float(np.percentile(taps[t].numpy(), 99.99)), 1e-3) for t in range(1, 8)]
    hi[3], hi[7] = hi[2], hi[6]
    scale = [1.0 / 255.0] + [h / 255.0 for h in hi[1:]]
    zp = [-128] * 8
    hv = taps[8].numpy()
    lo_h, hi_h = min(float(hv.min()), -1.0), max(float(hv.max()), 1.0)
    s_h = (hi_h - lo_h) / 255.0
    z_h = int(np.clip(round(-128 - lo_h / s_h), -128, 127))
    scale.append(s_h)
    zp.append(z_h)
    convs = [net.convs[k] for k in range(5)]
    plan = [("c", 0, 0), ("c", 1, 1), ("p", 2, None), ("c", 3, 2), ("c", 4, 3), ("c", 5, 4), ("p", 6, None),
            ("h", 7, None)]
    layers = []
    for i, (kind, tin, k) in enumerate(plan):
        s_in, s_out, z_out = scale[tin], scale[i + 1], zp[i + 1]
        if kind == "p":
            layers.append(dict(op=V.MAXPOOL2, stride=1, **{"in": tin}, cin=F, cout=F, out_zp=zp[tin],
                               act_min=-128, act_max=127))
            continue
        if kind == "c":
            w = convs[k].weight.detach().double().numpy()
            b = convs[k].bias.detach().double().numpy()
        else:
            w1 = net.head.weight.detach().double().numpy()
            w = np.zeros((3,) + w1.shape[1:])
            w[0] = w1[0]
            b = np.zeros(3)
            b[0] = float(net.head.bias.detach()[0])
        cout = w.shape[0]
        sw = np.maximum(np.abs(w.reshape(cout, -1)).max(1), 1e-4) / 127.0   # dead channels: m stays >= 2^-31
        wq = np.clip(np.round(w / sw[:, None, None, None]), -127, 127).astype(np.int8)
        if kind == "c":
            wq = wq.transpose(0, 2, 3, 1)
            op = V.CONV5X5
        else:
            wq = wq[:, :, 0, 0]
            op = V.PW1X1
        bias = np.round(b / (s_in * sw)).astype(np.int64)
        bb = V.bias_bound(op, w.shape[1])
        ms = [quantize_multiplier(float(s_in * sw[o] / s_out)) for o in range(cout)]
        layers.append(dict(op=op, stride=1, **{"in": tin}, cin=w.shape[1], cout=cout, out_zp=z_out,
                           act_min=z_out if kind == "c" else -128, act_max=127,
                           w=np.ascontiguousarray(wq), bias=np.clip(bias, -bb, bb).astype(np.int32),
                           mult=np.array([m for m, _ in ms], np.int32), shift=np.array([s for _, s in ms], np.int8)))
    v = (np.arange(256) - 128 - z_h) * s_h
    table = np.zeros((3, 256), np.int64)
    table[0] = np.round(32768.0 / (1.0 + np.exp(-v)))
    table[1] = table[2] = SIDE * 256
    desc = dict(norm_desc(), input_zp=-128, out_stride=4, out_channels=3, score_threshold_q=int(np.clip(z_h, -128, 127)),
                max_peaks=1, name=name[:16], layers=layers, table=table.astype(np.int32))
    return V.validate(desc), dict(scale=scale, zp=zp)


def tensors_c(cnn_desc, X, tensors=(3, 5, 6)):
    """{t: int8 [N, h, w, c]} of the C library's run on every crop."""
    m = vd_cnn.CModel(V.pack(cnn_desc))
    out = None
    for i, x in enumerate(X):
        ts = m.run_all(x)
        if out is None:
            out = {t: np.empty((len(X),) + ts[t].shape, np.int8) for t in tensors}
        for t in tensors:
            out[t][i] = ts[t]
    return out


def select_maps(T, ds, zp, k=3):
    """{layer: [channels by mean activation over the val vehicles, descending][:k]} (paper §3.2 Table 2)."""
    va = (ds["split"] == "val") & (ds["y"] == 1)
    sel, act = {}, {}
    for name, t in LAYER_T.items():
        a = (T[t][va].astype(np.float64) - zp[t]).mean(axis=(0, 1, 2))
        order = np.argsort(-a, kind="stable")
        sel[name] = [int(c) for c in order[:k]]
        act[name] = [round(float(a[c]), 2) for c in order]
    return sel, act


def feature_matrix(T, maps):
    return np.concatenate([T[t][:, :, :, c].reshape(len(T[t]), -1) for t, c in maps], axis=1)


# ------------------------------------------------------------------ AdaBoost of stumps

def adaboost(n_estimators, seed=0):
    from sklearn.ensemble import AdaBoostClassifier
    from sklearn.tree import DecisionTreeClassifier
    return AdaBoostClassifier(estimator=DecisionTreeClassifier(max_depth=1), n_estimators=n_estimators,
                              random_state=seed)


def int_stumps(clf, maps, map_len, n=None):
    """[n, 5] int stumps (map, pos, thr, left, right) of the first n estimators of a fitted SAMME
    AdaBoostClassifier, and the Q exponent of the values."""
    ests = clf.estimators_[:n]
    w = np.asarray(clf.estimator_weights_[:len(ests)], np.float64)
    q = int(min(12, math.floor(math.log2(32767.0 / max(float(w.max()), 1e-9)))))
    offs = np.r_[0, np.cumsum(map_len)]
    rows = []
    for e, wm in zip(ests, w):
        t = e.tree_
        v = int(round(wm * (1 << q)))
        if t.feature[0] < 0:         # no split: the same vote for every crop
            cls = int(np.argmax(t.value[0]))
            s = v if e.classes_[cls] == 1 else -v
            rows.append((0, 0, 127, s, s))
            continue
        f = int(t.feature[0])
        mi = int(np.searchsorted(offs, f, side="right") - 1)
        left_cls = e.classes_[int(np.argmax(t.value[t.children_left[0]]))]
        right_cls = e.classes_[int(np.argmax(t.value[t.children_right[0]]))]
        thr = int(math.floor(float(t.threshold[0])))
        rows.append((mi, f - offs[mi], int(np.clip(thr, -128, 127)), v if left_cls == 1 else -v,
                     v if right_cls == 1 else -v))
    return np.array(rows, np.int64).reshape(-1, 5), q


def staged_int_scores(stumps, maps_offsets, F):
    """int64 [n_stumps, N] cumulative scores (prefixes of the stump list)."""
    col = maps_offsets[stumps[:, 0]] + stumps[:, 1]
    x = F[:, col].astype(np.int64)
    votes = np.where(x <= stumps[:, 2], stumps[:, 3], stumps[:, 4])
    return np.cumsum(votes, axis=1).T


def pick_threshold(scores, y, target_fppw):
    """Smallest score threshold with FPPW <= target on (scores, y): accept score >= thr."""
    neg = np.sort(scores[y == 0])[::-1]
    k = int(math.floor(target_fppw * len(neg)))    # allowed false positives
    return int(neg[k] + 1) if k < len(neg) else int(neg[-1])


def model_card(name, meta):
    sel = meta["selected"]
    return f"""# {name} — paper 003's boosted CNN-feature verifier (issue 12)

- **File**: `{name}.vdm` (format version 4, the boosted kind, docs/model-format.md; {meta['bytes']} bytes, CRC-32 of
  bytes [16, end) {meta['crc32']}). No C array is committed.
- **Network** (embedded version-3 CNN, input 64×64, per-crop percentile stretch 10‰–990‰, min range 16):
  Conv_1, Conv_2 (5×5, op 7) → Maxpool_1 → Conv_3, Conv_4, Conv_5 (5×5) → Maxpool_2 → 1×1 head;
  **{meta['filters']} filters per layer** (the paper has 60), padding 2, ReLU; {meta['macs'] / 1e6:.1f} M multiply-adds per crop.
- **Features**: maps {meta['maps']} as (tensor, channel): tensor 3 = Maxpool_1, 5 = Conv_4, 6 = Conv_5, each 32×32;
  {meta['n_features']} int8 features. Ranking by mean val-vehicle activation (paper Table 2 on our network):
  Maxpool_1 {sel['Maxpool_1']}, Conv_4 {sel['Conv_4']}, Conv_5 {sel['Conv_5']} (the paper's 45 / 38 / 55 are its
  network's indices).
- **Classifier**: scikit-learn AdaBoost, **SAMME**, decision stumps (depth-1 trees), trained on the train rows;
  {meta['n_stumps']} stumps (prefix chosen on val), int8 thresholds, int16 votes Q{meta['q']}; accept threshold
  {meta['threshold']} (val FPPW ≤ 5 %).
- **Training**: `python3 -m vdtools.training.boost_train train --filters {meta['filters']} --epochs 3 --max-train 12000`, then
  `python3 -m vdtools.training.boost_train export --filters {meta['filters']} --stumps 300` (docs/training.md); CNN epoch {meta['epoch']}, val loss {meta['val_loss']:.3f}, val accuracy
  {100 * meta['val_acc']:.1f} % (the CNN's own classifier head).
- **Data**: the 64×64 crop set of `vdtools.data.dataset` (train split only; val for every choice). Results on the
  test split: docs/results/boost.md. C `vd_boost_score` equals the integer reference on every test crop
  (`tests/python/test_boost_parity.py`).
"""


# ------------------------------------------------------------------ main

def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("step", choices=("train", "export", "all", "time"))
    ap.add_argument("--filters", type=int, default=8)
    ap.add_argument("--epochs", type=int, default=4)
    ap.add_argument("--max-train", type=int, default=None)
    ap.add_argument("--stumps", type=int, default=300)
    ap.add_argument("--per-layer", type=int, default=1, help="maps per layer (paper: 1, i.e. 1440 features)")
    ap.add_argument("--name", default="vd_boost")
    ap.add_argument("--tag", default="", help="suffix of the cached checkpoint / tensors (parallel runs)")
    ap.add_argument("--out", default=str(clib.REPO / "models"))
    ap.add_argument("--time-filters", type=int, nargs="+", default=[8, 60], help="time: filter counts")
    ap.add_argument("--time-steps", type=int, default=3, help="time: batches timed per filter count")
    a = ap.parse_args(argv)
    if a.step == "time":   # no data set needed; writes docs/results/boost_train_time.json (boost_eval renders it)
        res = time_train(a.time_filters, a.time_steps)
        out = clib.REPO / "docs" / "results" / "boost_train_time.json"
        out.write_text(json.dumps(res, indent=1) + "\n")
        log("wrote", out, res["rows"])
        return
    CACHE.mkdir(parents=True, exist_ok=True)
    ds = load_crops()
    log("crops", {s: int((ds["split"] == s).sum()) for s in ("train", "val", "test")})
    ckp = CACHE / f"cnn_f{a.filters}{a.tag}.pt"
    if a.step in ("train", "all"):
        train(ds, a.filters, a.epochs, out=ckp, max_train=a.max_train)
    if a.step == "train":
        return
    import torch
    ck = torch.load(ckp, weights_only=False)
    cnn, qi = quantise(ck, ds, a.name)
    np.savez_compressed(CACHE / "cnn_desc.npz", blob=np.frombuffer(V.pack(cnn), np.uint8))
    tp = CACHE / f"tensors_f{a.filters}{a.tag}.npz"
    if tp.exists() and tp.stat().st_mtime > ckp.stat().st_mtime:
        with np.load(tp) as z:
            T = {int(k[1:]): z[k] for k in z.files}
    else:
        log("int8 tensors of every crop (C)")
        T = tensors_c(cnn, ds["X"])
        np.savez(tp, **{f"t{k}": v for k, v in T.items()})   # ~1.3 GB: compression costs minutes
    sel, act = select_maps(T, ds, qi["zp"])
    log("selected maps (val vehicles, mean activation order):", sel)
    maps = [(LAYER_T[n], c) for n in LAYER_T for c in sel[n][:a.per_layer]]
    Fm = feature_matrix(T, maps)
    tr, va, te = (ds["split"] == s for s in ("train", "val", "test"))
    y = ds["y"].astype(np.int64)
    log(f"AdaBoost (SAMME, depth-1 trees) x{a.stumps} on {int(tr.sum())} rows x {Fm.shape[1]} features")
    t0 = time.time()
    clf = adaboost(a.stumps).fit(Fm[tr], y[tr])
    log(f"fit {time.time() - t0:.0f} s, {len(clf.estimators_)} stumps")
    map_len = [T[t].shape[1] * T[t].shape[2] for t, _ in maps]
    st, q = int_stumps(clf, maps, map_len)
    offs = np.r_[0, np.cumsum(map_len)][:-1]
    sv = staged_int_scores(st, offs, Fm[va])
    from vdtools.metrics.det import det_curve, miss_at
    best = None
    for n in range(10, len(st) + 1, 10):
        f, m = det_curve(sv[n - 1], y[va])
        key = (miss_at(f, m, 1e-2), miss_at(f, m, 1e-1))
        if best is None or key < best[0]:
            best = (key, n)
    n = best[1]
    thr = pick_threshold(sv[n - 1], y[va], 0.05)
    log(f"stumps chosen on val: {n} (val miss @1e-2 {best[0][0]:.3f}, @1e-1 {best[0][1]:.3f}); Q{q}; "
        f"threshold {thr} (val FPPW <= 5 %)")
    desc = dict(name=a.name[:16], cnn=cnn, maps=maps, stumps=st[:n], threshold=thr)
    blob = B.pack(desc)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / f"{a.name}.vdm").write_bytes(blob)
    meta = dict(filters=a.filters, epoch=ck["epoch"], val_loss=ck["val_loss"], val_acc=ck["val_acc"],
                selected=sel, activation=act, maps=maps, n_stumps=n, q=q, threshold=thr,
                bytes=len(blob), crc32=f"0x{int.from_bytes(blob[12:16], 'little'):08X}",
                macs=R.macs(cnn, SIDE, SIDE), n_features=int(Fm.shape[1]))
    (CACHE / f"{a.name}.json").write_text(json.dumps(meta, indent=1))
    (out / f"{a.name}.md").write_text(model_card(a.name, meta))
    log("wrote", out / f"{a.name}.vdm", meta["bytes"], "bytes", meta["crc32"])


if __name__ == "__main__":
    main()
