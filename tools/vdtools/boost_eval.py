# SPDX-License-Identifier: MIT
"""Paper 003's comparison on our data (docs/results/boost.md): DET curves (miss rate against false
positives per window, log axes) on the test split of the 64x64 crop set (vdtools.boost_train) for

  boosted CNN features   models/vd_boost.vdm: integer scores (== vd_boost_score, the parity test)
  DBN                    models/vd_dbn_grey.vdm, int8 (== vd_dbn_classify) on the same rects cut at 32x32
  HOG + SVM, Haar + AdaBoost, LBP + AdaBoost   vdtools.baselines on the same rects at 32x32, trained on
                         the same train rows (C of the SVM on val)

plus the miss rate at 1e-4 / 1e-3 / 1e-2 FPPW, and paper §3.3-3.4's feature-set experiments in short
form (experiment 1: 1 / 2 / 3 maps per layer; experiment 2: every one-map-per-layer combination of the
top-3 maps), each trained with --exp-stumps stumps on --exp-train train rows and read on the test split.

    cd tools && python3 -m vdtools.boost_eval [--experiments]
"""
import argparse
import itertools
import json
import time
from pathlib import Path

import numpy as np

from . import boost_train as BT
from . import boost_vdm as B
from . import clib
from .det import det_curve, miss_at, plot

RESULTS = clib.REPO / "docs" / "results"
TARGETS = (1e-4, 1e-3, 1e-2, 1e-1)


def recut(ds, side):
    """uint8 [N, side, side] of every row's rect cut from its frame by the C resampler (mirrored rows
    mirrored again, as the data set builder does)."""
    from . import dataset, samples
    p = BT.CACHE / f"recut{side}.npz"
    if p.exists():
        with np.load(p) as z:
            return z["X"]
    paths = {f.name: f.path for f in dataset.all_frames(clib.DATA_DIR, synth=True)}
    out = np.empty((len(ds["y"]), side, side), np.uint8)
    cur, img = None, None
    for i, (fr, r, src) in enumerate(zip(ds["frame"], ds["rect"], ds["source"])):
        if fr != cur:
            cur, img = fr, dataset.read_frame(paths[fr])
        s = samples.sample32(img, tuple(int(v) for v in r), "grey", side)
        out[i] = s[:, ::-1] if src == "box_flip" else s
    # jittered rows are mirrored on odd jitter index: recover it from the 64x64 row itself
    jit = np.nonzero(ds["source"] == "box_jitter")[0]
    if len(jit):
        import cv2
        for i in jit:
            a = cv2.resize(ds["X"][i], (side, side), interpolation=cv2.INTER_AREA).astype(np.int32)
            if np.abs(a - out[i][:, ::-1]).sum() < np.abs(a - out[i]).sum():
                out[i] = out[i][:, ::-1]
    np.savez_compressed(p, X=out)
    return out


def rates(scores, y):
    f, m = det_curve(scores, y)
    return {f"miss@{t:g}": miss_at(f, m, t) for t in TARGETS}, (f, m)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--model", default=str(clib.REPO / "models" / "vd_boost.vdm"))
    ap.add_argument("--filters", type=int, default=8)
    ap.add_argument("--experiments", action="store_true")
    ap.add_argument("--exp-stumps", type=int, default=100)
    ap.add_argument("--exp-train", type=int, default=8000)
    ap.add_argument("--no-baselines", action="store_true")
    ap.add_argument("--tag", default="")
    a = ap.parse_args(argv)
    t0 = time.time()
    ds = BT.load_crops()
    y = ds["y"].astype(np.int64)
    split = ds["split"]
    te = split == "test"
    out = {"test": {"pos": int((y[te] == 1).sum()), "neg": int((y[te] == 0).sum()),
                    "neg_window": int(((ds["source"] == "window") & te).sum())}}
    with np.load(BT.CACHE / f"tensors_f{a.filters}{a.tag}.npz") as z:
        T = {int(k[1:]): z[k] for k in z.files}
    blob = Path(a.model).read_bytes()
    d = B.unpack(blob)
    Fm = BT.feature_matrix(T, d["maps"])
    s_boost = B.score_features(d, Fm[te])
    curves, table = {}, {}
    table["boosted CNN features (int8)"], curves["boosted CNN features"] = rates(s_boost, y[te])
    BT.log("boosted", table["boosted CNN features (int8)"])

    X32 = recut(ds, 32)
    from . import quantise, vdm
    qm = vdm.unpack((clib.REPO / "models" / "vd_dbn_grey.vdm").read_bytes())
    s_dbn = quantise.quant_forward(qm, X32[te].reshape(int(te.sum()), -1))
    table["DBN vd_dbn_grey (int8)"], curves["DBN (vd_dbn_grey)"] = rates(s_dbn, y[te])
    BT.log("dbn", table["DBN vd_dbn_grey (int8)"])
    if not a.no_baselines:
        from . import baselines
        res = baselines.run_all(X32, y, split, 0, log=BT.log)
        for k, v in res.items():
            table[k], curves[k] = rates(v["score"], y[te])
            BT.log(k, table[k])
    RESULTS.mkdir(parents=True, exist_ok=True)
    plot(curves, RESULTS / "det_boost.png", title="DET: 64x64 test crops (paper 003 protocol)")
    out["table"] = table

    out["speed"] = speed(blob, ds["X"][te])
    BT.log("speed", out["speed"])
    if a.experiments:
        out["experiments"] = experiments(ds, T, y, split, a.exp_stumps, a.exp_train, ckpt=BT.CACHE / f"cnn_f{a.filters}{a.tag}.pt")
    out["seconds"] = round(time.time() - t0)
    (RESULTS / "boost.json").write_text(json.dumps(out, indent=1))
    BT.log("wrote", RESULTS / "boost.json")


def speed(blob, X, n=300, reps=3):
    """Median over reps of the mean wall time of vd_boost_score per 64x64 crop (one thread, ctypes call
    included), the CNN's multiply-adds and the model bytes."""
    from . import cnn_ref as R
    m = B.CBoost(blob)
    d = B.unpack(blob)
    X = X[:n]
    ts = []
    for _ in range(reps):
        t = time.perf_counter()
        for x in X:
            m.score(x)
        ts.append((time.perf_counter() - t) / len(X))
    return {"us_per_crop": round(1e6 * float(np.median(ts)), 1), "macs": int(R.macs(d["cnn"], BT.SIDE, BT.SIDE)),
            "stumps": int(len(d["stumps"])), "model_bytes": len(blob), "workspace_bytes": int(m.ws_bytes)}


def experiments(ds, T, y, split, n_stumps, n_train, seed=0, ckpt=None):
    """Paper §3.3 (1 / 2 / 3 maps per layer) and §3.4 (the 27 one-map-per-layer combinations of the top 3)."""
    import torch
    ck = torch.load(ckpt, weights_only=False)
    zp = {t: -128 for t in BT.LAYER_T.values()}
    sel, _ = BT.select_maps(T, ds, zp)
    rng = np.random.default_rng(seed)
    tr = np.nonzero(split == "train")[0]
    tr = np.sort(rng.choice(tr, min(n_train, len(tr)), replace=False))
    te = split == "test"
    names = list(BT.LAYER_T)

    def run(maps):
        Fm = BT.feature_matrix(T, maps)
        clf = BT.adaboost(n_stumps, seed).fit(Fm[tr], y[tr])
        s = clf.decision_function(Fm[te])
        r, _ = rates(s, y[te])
        return {k: round(v, 4) for k, v in r.items()}

    res = {"train_rows": int(len(tr)), "stumps": n_stumps, "selected": sel, "epoch": ck["epoch"]}
    e1 = {}
    for k in (1, 2, 3):
        maps = [(BT.LAYER_T[n], c) for n in names for c in sel[n][:k]]
        e1[f"{k} per layer ({sum(T[t].shape[1] * T[t].shape[2] for t, _ in maps)} features)"] = run(maps)
        BT.log("exp1", k, e1[list(e1)[-1]])
    res["experiment1"] = e1
    e2 = {}
    for combo in itertools.product(range(3), repeat=3):
        maps = [(BT.LAYER_T[n], sel[n][i]) for n, i in zip(names, combo)]
        key = " ".join(f"{n}#{sel[n][i]}" for n, i in zip(names, combo))
        e2[key] = run(maps)
        BT.log("exp2", key, e2[key])
    res["experiment2"] = e2
    return res


if __name__ == "__main__":
    main()
