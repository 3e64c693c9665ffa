# SPDX-License-Identifier: MIT
"""Trains DBN verifiers on the cached 32x32 data set and writes float models (.npz, as vdtools/formats/quantise.py defines)
to tools/.cache/models/.

    python3 -m vdtools.training.dbn_train --mode grey --layers 576,256,64        # one model
    python3 -m vdtools.training.dbn_train --mode grey --layers 60,16 --name vd_dbn_compact

Recipe (paper 001 section 4, paper 000 section 3; what differs and why is in docs/training.md):
greedy CD-1 pre-training of each layer (momentum 0.5 for the first epochs then THETA, learning rate
ALPHA for the first RBM and ALPHA_UPPER above it, weight decay WD, minibatch 64), then back-propagation
of the softmax cross-entropy (momentum 0.9, learning rate FT_LR, early stopping on the val split),
then the 2-unit softmax is folded into one sigmoid unit.
"""
import argparse
import json
import time

import numpy as np

from vdtools.bindings import clib
from vdtools.data import dataset
from vdtools.formats import quantise
from vdtools.training import rbm

MODELS = dataset.CACHE / "models"
ALPHA = 0.1          # paper: 0.4; at 0.4 98 % of the 576 first-layer units saturate (1024 real-valued inputs)
ALPHA_UPPER = 0.1
THETA = 0.75         # paper 001 (000 uses 0.8)
WD = 2e-4
PRE_EPOCHS = 10
FT_EPOCHS = 30
FT_LR = 0.05
FT_PATIENCE = 5
BATCH = 64
PRE_MAX_ROWS = 12000  # CD-1 on a random 12000 training rows (CPU budget; unsupervised, labels unused)
FT_MAX_ROWS = 0       # back-propagation on every training row (0 = no cap)
# Per-sample input normalisation (docs/fixed-point.md "dbn"): the integer min-max stretch that
# vd_dbn_classify applies, keyed by the .vdm header; "none" reproduces the issue-3 models.
INPUT_NORM = "minmax"
NORM_MIN_RANGE = 16
DEPTHS = {1: [576], 2: [576, 256], 3: [576, 256, 64], 4: [576, 256, 64, 16]}
COMPACT = [60, 16]   # 62 416 int8 weights (< 64 KiB); 60-16 beat 48-16 on VAL accuracy (82.0 % vs 80.8 %)


def norm_spec(norm=None):
    norm = INPUT_NORM if norm is None else norm
    return {"input_norm": norm, "norm_min_range": NORM_MIN_RANGE if norm != "none" else 0}


def arrays(ds, norm=None):
    """(X float32 [N, 1024] = normalised pixel / 255, y, split masks)."""
    x = quantise.normalise_input(norm_spec(norm), ds["X"].reshape(len(ds["X"]), -1))
    X = x.astype(np.float32) / np.float32(255.0)
    masks = {s: ds["split"] == s for s in dataset.SPLITS}
    return X, ds["y"].astype(np.int64), masks


def pretrain(X, sizes, seed=0, epochs=PRE_EPOCHS, max_rows=PRE_MAX_ROWS, progress=True, log=print):
    """Pre-trains a stack on (at most max_rows random rows of) X."""
    if max_rows and len(X) > max_rows:
        X = X[np.sort(np.random.default_rng(seed).choice(len(X), max_rows, replace=False))]
    return rbm.pretrain_stack(X, sizes, epochs=epochs, lr=ALPHA, lr_upper=ALPHA_UPPER, momentum=THETA,
                              weight_decay=WD, batch=BATCH, seed=seed, progress=progress, log=log)


def finetune(rbms, X, y, masks, mode, seed=0, epochs=FT_EPOCHS, progress=True, log=print, desc="finetune",
             norm=None):
    net = rbm.DBN.from_rbms(rbms, X.shape[1], np.random.default_rng(seed + 1), mode, **norm_spec(norm))
    tr, va = masks["train"].copy(), masks["val"]
    idx = np.flatnonzero(tr)
    if FT_MAX_ROWS and len(idx) > FT_MAX_ROWS:   # same subset for every depth (seeded)
        tr[:] = False
        tr[np.random.default_rng(seed + 7).choice(idx, FT_MAX_ROWS, replace=False)] = True
    hist = net.finetune(X[tr], y[tr], X[va], y[va], epochs=epochs, lr=FT_LR, momentum=0.9, weight_decay=1e-4,
                        batch=BATCH, seed=seed, patience=FT_PATIENCE, progress=progress, desc=desc, log=log)
    return net, hist


def recipe():
    return {"alpha": ALPHA, "alpha_upper": ALPHA_UPPER, "theta": THETA, "momentum_warmup": "0.5 for 5 epochs",
            "weight_decay": WD, "pre_epochs": PRE_EPOCHS, "ft_epochs_max": FT_EPOCHS, "ft_lr": FT_LR,
            "ft_momentum": 0.9, "ft_patience": FT_PATIENCE, "batch": BATCH, "pre_max_rows": PRE_MAX_ROWS,
            "ft_max_rows": FT_MAX_ROWS, **norm_spec()}


def main(argv=None):
    ap = argparse.ArgumentParser(description="Train one DBN verifier (float .npz in tools/.cache/models/).")
    ap.add_argument("--mode", choices=("grey", "shape"), default="grey")
    ap.add_argument("--layers", default="576,256,64", help="hidden layer sizes, comma separated")
    ap.add_argument("--name", default=None, help="file stem (default dbn_<mode>_<layers>)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--pre-epochs", type=int, default=PRE_EPOCHS)
    ap.add_argument("--ft-epochs", type=int, default=FT_EPOCHS)
    ap.add_argument("--norm", choices=("none", "minmax"), default=INPUT_NORM, help="per-sample input normalisation")
    a = ap.parse_args(argv)
    sizes = [int(v) for v in a.layers.split(",") if v]
    ds = dataset.load_or_build(a.mode, a.seed)
    dataset.print_counts(ds)
    X, y, masks = arrays(ds, a.norm)
    t0 = time.time()
    rbms = pretrain(X[masks["train"]], sizes, a.seed, a.pre_epochs)
    net, hist = finetune(rbms, X, y, masks, a.mode, a.seed, a.ft_epochs, norm=a.norm)
    masks["test"] &= np.isin(ds["source"], dataset.CLASSIC_SOURCES)   # Table 1's test rows
    p = net.predict_proba(X[masks["test"]])
    yt = y[masks["test"]]
    m = {"test_acc": float(np.mean((p >= 0.5) == (yt == 1))), "tp_rate": float(np.mean(p[yt == 1] >= 0.5)),
         "fp_rate": float(np.mean(p[yt == 0] >= 0.5))}
    name = a.name or f"dbn_{a.mode}_{'-'.join(map(str, sizes))}"
    path = net.save_npz(MODELS / f"{name}.npz", meta={"sizes": sizes, "mode": a.mode, "seed": a.seed,
                                                      "dataset": str(dataset.cache_path(a.mode, a.seed)),
                                                      "fingerprint": dataset.fingerprint(ds), "recipe": recipe(),
                                                      "history": hist, "test": m, "seconds": time.time() - t0})
    print(f"{name}: test acc {m['test_acc']:.4f} TP {m['tp_rate']:.4f} FP {m['fp_rate']:.4f} -> {path}")
    print(f"export: python3 -m vdtools.formats.export {path.relative_to(clib.REPO / 'tools')} --name {name}")


if __name__ == "__main__":
    main()
