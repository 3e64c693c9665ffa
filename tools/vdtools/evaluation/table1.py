# SPDX-License-Identifier: MIT
"""Paper 001's Table 1 measured on our data in one run: four DBN depths + the compact DBN,
HOG + linear SVM, Haar + AdaBoost, LBP + AdaBoost, all trained on the same train split and measured on
the same test split (never trained on, never used for choices); a DET curve (paper 003); the float
models; with --export the .vdm models, their quantised accuracy and model cards.

    python3 -m vdtools.evaluation.table1 --mode grey --export

Writes docs/results/verifier.json (one entry per input mode; later runs of another mode are merged),
docs/results/verifier.md (rendered from the JSON), docs/results/det_verifier[_shape].png,
tools/.cache/models/*.npz, and with --export models/<name>.vdm/_vdm.c/_vdm.h/.md.
"""
import argparse
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np

from vdtools.training import baselines, dbn_train, rbm
from vdtools.bindings import clib
from vdtools.data import dataset
from vdtools.metrics import det

RESULTS = clib.REPO / "docs" / "results"
MODELS_DIR = clib.REPO / "models"
NAMES = {"grey": "vd_dbn_grey", "shape": "vd_dbn_shape"}
# The retrained compact net ships as vd_dbn_compact_w (window-trained); models/vd_dbn_compact.vdm stays the
# issue-3 compact model, which is better on the issue-3 test rows (docs/results/verifier.md, before/after).
COMPACT_NAME = "vd_dbn_compact_w"
PAPER = {"2D-DBN (one hidden layer)": 91.0, "2D-DBN (two hidden layers)": 93.8,
         "2D-DBN (three hidden layers)": 94.8, "2D-DBN (four hidden layers)": 93.6,
         "HOG + SVM": 87.6, "Haar + Adaboost": 88.4}
CITATIONS = [
    "MSRS: L. Tang et al., \"PIAFusion: A progressive infrared and visible image fusion network based on "
    "illumination aware\", Information Fusion 83-84, 2022; derived from MFNet: Q. Ha et al., \"MFNet: Towards "
    "real-time semantic segmentation for autonomous vehicles with multi-spectral scenes\", IROS 2017 "
    "(research use with citation; not redistributed).",
    "HIT-UAV: J. Suo et al., \"HIT-UAV: A high-altitude infrared thermal dataset for Unmanned Aerial "
    "Vehicle-based object detection\", Scientific Data 10:227, 2023; CC BY 4.0.",
]


def metrics(score, y, thr, ds_test=None):
    """Accuracy / TP rate / FP rate at thr (accept score >= thr), per-set TP/FP, DET points."""
    y = np.asarray(y).astype(bool)
    d = np.asarray(score) >= thr
    out = {"n": int(len(y)), "pos": int(y.sum()), "neg": int((~y).sum()), "correct": int((d == y).sum()),
           "accuracy": float((d == y).mean()), "tp_rate": float(d[y].mean()), "fp_rate": float(d[~y].mean())}
    f, m = det.det_curve(score, y)
    out["miss_at_fppw"] = {"1e-2": det.miss_at(f, m, 1e-2), "1e-1": det.miss_at(f, m, 1e-1)}
    if ds_test is not None:
        per = {}
        for name in ("msrs", "hit", "seq"):
            k = ds_test["dataset"] == name
            if k.any():
                per[name] = {"tp_rate": float(d[k & y].mean()) if (k & y).any() else None,
                             "fp_rate": float(d[k & ~y].mean()) if (k & ~y).any() else None,
                             "pos": int((k & y).sum()), "neg": int((k & ~y).sum())}
        hot = ds_test["hot"] & y
        per["hot_vehicles_tp_rate"] = float(d[hot].mean()) if hot.any() else None
        per["hot_vehicles"] = int(hot.sum())
        per["cold_vehicles_tp_rate"] = float(d[y & ~ds_test["hot"]].mean()) if (y & ~ds_test["hot"]).any() else None
        out["per_set"] = per
    return out, (f, m)


def _baselines_job(X_u8, y, split, seed):
    """One baseline run in a worker process (its own CPU while the DBNs train)."""
    t = time.time()
    res = baselines.run_all(X_u8, y, split, seed, log=None)
    return res, time.time() - t


def mined_metrics(score, thr, ds_te):
    """Figures on the issue-7 generator rows of the test split (sources window / contrast / window_pos)."""
    d = np.asarray(score) >= thr
    src = ds_te["source"]
    out = {}
    for key, s in (("window_fppw", "window"), ("contrast_fppw", "contrast"), ("window_tp", "window_pos")):
        k = src == s
        out[key] = float(d[k].mean()) if k.any() else None
        out[s + "_n"] = int(k.sum())
    k = np.isin(src, dataset.CLASSIC_SOURCES + ("window",))
    f, m = det.det_curve(np.asarray(score)[k & ((src == "window") | (ds_te["y"] == 1))],
                         ds_te["y"][k & ((src == "window") | (ds_te["y"] == 1))])
    out["miss_at_window_fppw"] = {"1e-2": det.miss_at(f, m, 1e-2), "1e-1": det.miss_at(f, m, 1e-1)}
    return out


def _row(score, y_te, thr, ds_te, classic):
    """Table 1 metrics on the classic test rows + the mined-row figures."""
    row, curve = metrics(np.asarray(score)[classic], y_te[classic], thr, dataset.subset(ds_te, classic))
    row["mined"] = mined_metrics(score, thr, ds_te)
    return row, curve


def before_rows(ds, y, te, classic, ds_te, log=print):
    """The issue-3 models (tools/.cache/models_v1: float .npz, int8 .vdm; raw input) on this test split."""
    from vdtools.formats import quantise, vdm
    out = {}
    v1 = dataset.CACHE / "models_v1"
    xt = ds["X"][te].reshape(int(te.sum()), -1)
    for name in ("vd_dbn_grey", "vd_dbn_compact"):
        if not (v1 / f"{name}.npz").exists():
            continue
        fm = quantise.load_float(str(v1 / f"{name}.npz"))
        r, _ = _row(quantise.float_forward(fm, xt), y[te], 0.5, ds_te, classic)
        r["layers"] = [fm["layers"][0][0].shape[1]] + [w.shape[0] for w, _ in fm["layers"]]
        if (v1 / f"{name}.vdm").exists():
            qm = vdm.unpack((v1 / f"{name}.vdm").read_bytes())
            r["quantised"], _ = _row(quantise.quant_forward(qm, xt), y[te], 128, ds_te, classic)
        out[name] = r
        log(f"  before: {name} acc {100 * r['accuracy']:.1f}% window FPPW {100 * r['mined']['window_fppw']:.1f}%")
    return out


def run_mode(mode, seed, do_export, quick, log=print):
    from concurrent.futures import ProcessPoolExecutor
    from vdtools.formats import quantise
    t_all = time.time()
    ds = dataset.load_or_build(mode, seed)
    counts = dataset.print_counts(ds)
    X, y, masks = dbn_train.arrays(ds)
    te = masks["test"]
    ds_te = dataset.subset(ds, te)
    classic = np.isin(ds_te["source"], dataset.CLASSIC_SOURCES)   # Table 1's test rows (as in issue 3)
    y_te = y[te]
    pre_epochs = 4 if quick else dbn_train.PRE_EPOCHS
    ft_epochs = 4 if quick else dbn_train.FT_EPOCHS
    rows, curves, timings, nets = {}, {}, {}, {}

    # The baselines train in two worker processes (raw input, and the same normalised input the DBN
    # gets) while the DBNs train here.
    norm = dbn_train.norm_spec()
    x_norm = quantise.normalise_input(norm, ds["X"].reshape(len(ds["X"]), -1)).reshape(ds["X"].shape)
    pool = ProcessPoolExecutor(max_workers=2)
    jobs = {"raw": pool.submit(_baselines_job, ds["X"], y, ds["split"], seed)}
    if norm["input_norm"] != "none":
        jobs["norm"] = pool.submit(_baselines_job, x_norm, y, ds["split"], seed)

    t = time.time()
    log(f"[{mode}] pre-training the 4-layer stack {dbn_train.DEPTHS[4]} (shared by depths 1-4) ...")
    stack = dbn_train.pretrain(X[masks["train"]], dbn_train.DEPTHS[4], seed, pre_epochs)
    timings["pretrain_stack_s"] = time.time() - t
    labels = {1: "DBN 1 hidden layer (576)", 2: "DBN 2 hidden layers (576-256)",
              3: "DBN 3 hidden layers (576-256-64)", 4: "DBN 4 hidden layers (576-256-64-16)"}
    for depth in (1, 2, 3, 4):
        t = time.time()
        net, hist = dbn_train.finetune(stack[:depth], X, y, masks, mode, seed, ft_epochs, desc=f"finetune d{depth}")
        timings[f"finetune_d{depth}_s"] = time.time() - t
        va = float(np.mean((net.predict_proba(X[masks["val"]]) >= 0.5) == (y[masks["val"]] == 1)))
        nets[depth] = (net, va, hist)
        rows[labels[depth]], curves[labels[depth]] = _row(net.predict_proba(X[te]), y_te, 0.5, ds_te, classic)
        rows[labels[depth]].update({"val_accuracy": va, "layers": [1024] + dbn_train.DEPTHS[depth] + [1],
                                    "epochs_finetune": len(hist)})
    t = time.time()
    log(f"[{mode}] compact DBN {dbn_train.COMPACT} ...")
    cstack = dbn_train.pretrain(X[masks["train"]], dbn_train.COMPACT, seed, pre_epochs)
    cnet, chist = dbn_train.finetune(cstack, X, y, masks, mode, seed, ft_epochs, desc="finetune compact")
    timings["compact_s"] = time.time() - t
    clabel = f"DBN compact ({'-'.join(map(str, dbn_train.COMPACT))})"
    cva = float(np.mean((cnet.predict_proba(X[masks["val"]]) >= 0.5) == (y[masks["val"]] == 1)))
    rows[clabel], curves[clabel] = _row(cnet.predict_proba(X[te]), y_te, 0.5, ds_te, classic)
    rows[clabel].update({"val_accuracy": cva, "layers": [1024] + dbn_train.COMPACT + [1], "epochs_finetune": len(chist)})

    t = time.time()
    log(f"[{mode}] waiting for the baselines ...")
    for kind, job in jobs.items():
        base, secs = job.result()
        timings[f"baselines_{kind}_s"] = secs
        for name, r in base.items():
            label = name + (" (normalised input)" if kind == "norm" else "")
            rows[label], curves[label] = _row(r["score"], y_te, r["threshold"], ds_te, classic)
            rows[label]["params"] = r["params"]
    pool.shutdown()
    timings["baselines_wait_s"] = time.time() - t
    timings["baselines_s"] = max(timings.get("baselines_raw_s", 0.0), timings.get("baselines_norm_s", 0.0))

    best_depth = max(nets, key=lambda d: (nets[d][1], -d))   # chosen on VAL accuracy, never on test
    models = {}
    for name, (net, label, hist) in {NAMES[mode]: (nets[best_depth][0], labels[best_depth], nets[best_depth][2]),
                                     **({COMPACT_NAME: (cnet, clabel, chist)} if mode == "grey" else {})}.items():
        path = net.save_npz((dataset.CACHE / "quick" if quick else dbn_train.MODELS) / f"{name}.npz", meta={
            "name": name, "label": label, "mode": mode, "sizes": net.sizes, "seed": seed,
            "dataset_fingerprint": dataset.fingerprint(ds), "recipe": dbn_train.recipe(), "history": hist,
            "test": rows[label]})
        models[name] = {"label": label, "float_npz": str(path.relative_to(clib.REPO)), "float": rows[label]}
        if do_export and not quick:
            try:
                models[name].update(export_model(path, name, ds, X, y, te, classic, ds_te))
            except Exception as e:  # keep the table; the float model can be exported again by hand
                log(f"  export of {name} failed: {e!r}")
                models[name]["export_error"] = repr(e)
    before = before_rows(ds, y, te, classic, ds_te, log) if mode == "grey" else {}

    out_dir = dataset.CACHE / "quick" if quick else RESULTS
    png = out_dir / ("det_verifier.png" if mode == "grey" else f"det_verifier_{mode}.png")
    out_dir.mkdir(parents=True, exist_ok=True)
    det.plot(curves, png, title=f"DET, {mode} samples, test split ({int(y_te[classic].sum())} vehicles, "
                                f"{int((y_te[classic] == 0).sum())} non-vehicle windows)")
    timings["total_s"] = time.time() - t_all
    return {"mode": mode, "seed": seed, "quick": quick, "dataset": {
        "cache": str(dataset.cache_path(mode, seed).relative_to(clib.REPO)), "fingerprint": dataset.fingerprint(ds),
        "meta": ds["meta"], "counts": counts}, "recipe": dbn_train.recipe(), "best_depth": best_depth,
        "rows": rows, "models": models, "before": before, "det_png": str(png.relative_to(clib.REPO)),
        "timings": timings}


def export_model(npz, name, ds, X, y, te, classic, ds_te):
    """Quantise + export through helper dbn-c's tools; quantised metrics on the test split; the C
    library's scores compared with the Python integer reference on every test sample."""
    from vdtools.formats import export, quantise
    fm = quantise.load_float(str(npz))
    qm, blob = export.export(fm, name, MODELS_DIR, source=npz.name)
    xt = ds["X"][te].reshape(int(te.sum()), -1)
    sq = quantise.quant_forward(qm, xt)
    qrow, _ = _row(sq, y[te], 128, ds_te, classic)
    rep = quantise.accuracy_report(fm, qm, xt[classic], y[te][classic])
    out = {"vdm": f"models/{name}.vdm", "vdm_bytes": len(blob),
           "weight_bytes_int8": int(sum(L["w"].size for L in qm["layers"])),
           "quantised": qrow, "agreement_float_vs_quant": rep["agreement"],
           "max_abs_prob_err": rep["max_abs_prob_err"], "summary": export.summary(qm, blob)}
    try:
        from vdtools.bindings import dbn as vd_dbn
        sc = vd_dbn.CModel(blob).classify(xt)
        out["c_bit_exact"] = {"samples": int(len(xt)), "equal": int((sc == np.asarray(sq)).sum())}
    except Exception as e:  # shared build without dbn.c
        out["c_bit_exact"] = {"error": str(e)}
    return out


# ---------------------------------------------------------------- reports

def _pct(v):
    return "–" if v is None else f"{100 * v:.1f}%"


# Interpretation of the grey run of this commit (edit together with the run it describes).
READING = [
    "- **What changed since issue 3** (grey): the DBN input is the per-sample min-max stretch that "
    "`vd_dbn_classify` applies (.vdm version 2), training adds hard negatives of the issue-7 window and "
    "contrast generators and each vehicle's best window as a positive, CD-1 runs 10 epochs on 12 000 rows "
    "(was 6 on 6000) and fine-tuning uses every training row with early stopping on val (was 6000 rows, "
    "≤ 12 epochs). The issue-3 test rows are unchanged, so the before/after table compares like with like.",
    "- **The full model got better on every threshold-free figure and in accuracy**: accuracy 76.3 → 78.8 %, FP rate "
    "10.8 → 6.2 %, miss rate at FPPW 10⁻¹ 50.0 → 38.2 %, ROC AUC 0.79 → 0.84, and on the window rows "
    "FPPW 36.3 → 6.1 % (AUC 0.62 → 0.85). Its TP rates at p ≥ 0.5 fell: 52.8 → 51.4 % on the issue-3 "
    "rows and 46.0 → 33.2 % on the vehicles' best windows: with about twice as many negatives the nets are "
    "more conservative at 0.5; the DET curves compare them at every threshold, and the detector's "
    "`score_thr` is the knob (at the old model's window FPPW the new one misses far fewer vehicles).",
    "- **Still not better than the hand-made features in accuracy** at threshold 0.5: Haar + AdaBoost "
    "(raw) 80.7 %, HOG + linear SVM 79.0 % vs the best DBN 78.8 %. HOG + SVM accepts many more "
    "vehicles (TP 93 %) at a 4.6× higher FP rate; on the window rows it is the strongest (FPPW 5.9 %, "
    "miss 4 % at window FPPW 10⁻¹). The normalised input helps HOG a little (+0.6 points), leaves LBP "
    "as it is (LBP codes are invariant to a monotonic stretch up to ties) and hurts Haar + AdaBoost "
    "(−4.3 points: its stumps threshold absolute Haar responses, which the stretch rescales per sample).",
    "- **The val/test gap remains**: the exported 2-layer net has 90.1 % on the val split's issue-3 rows "
    "(87.3 % on all val rows) and 78.8 % on test. The normalisation removed brightness as a cue (a "
    "brighter copy of a sample scores the same, tested) but the test groups (the HIT-UAV sequence flight, "
    "unseen MSRS drives) still differ from the training groups in content; more data from more drives "
    "is the next lever, not more epochs (early stopping chose epochs 2–21).",
    "- **Compact model**: the retrained compact net (1024-60-16-1: 60-16 beat 48-16 on val, 62 416 int8 "
    "weights) is better on the window rows (FPPW 48.5 → 15.0 %, ROC AUC 0.57 → 0.75) but **worse on the "
    "issue-3 test rows** (accuracy 73.0 → 71.3 %, AUC 0.77 → 0.71): 60 hidden units cannot absorb the "
    "harder negatives as well as 576-256. So `models/vd_dbn_compact.vdm` stays the issue-3 model "
    "(re-exported as version 2, input_norm 0, same CRC and scores) and the retrained one ships as "
    "`models/vd_dbn_compact_w.vdm` for detectors with window/contrast sources.",
    "- Operating point and system view: the detector's final TP/FP rates also depend on the candidate "
    "stage (docs/results/candidates.md), the window pre-filter and temporal confirmation "
    "(docs/results/detector.md).",
]


def render_md(res):
    L = ["<!-- generated by python3 -m vdtools.evaluation.table1; edit the generator, not this file -->",
         "# Verifier results: paper 001's Table 1 measured on our data", "",
         # Notes written after a run live in a hand-written file, so re-rendering keeps them.
         "> **Hand-written updates since this run** (paper 003's comparison, the retrained `vd_dbn_grey`, the "
         "grown test split; they supersede figures below where they say so): "
         "[verifier_updates.md](verifier_updates.md).", "",
         "32×32 samples, vehicle / not vehicle, on the **test split** (frame groups never used in training, "
         "never used for any choice: depth, SVM C and early stopping use the val split). "
         "Threshold 0.5 on p(vehicle) (SVM: decision 0). TP rate = accepted vehicles / vehicles, "
         "FP rate = accepted non-vehicle windows / non-vehicle windows (= FPPW at that threshold).", ""]
    for mode, r in res["runs"].items():
        c = r["dataset"]["counts"]
        L += [f"## Input mode `{mode}`" + (" (QUICK smoke run, not a result)" if r.get("quick") else ""), "",
              f"Test split: {c['test']['pos']} vehicles, {c['test']['neg']} non-vehicle windows "
              f"({c['test']['groups']} frame groups; MSRS {c['test']['msrs'][1]}/{c['test']['msrs'][0]}, "
              f"HIT-UAV {c['test']['hit'][1]}/{c['test']['hit'][0]}, HIT-UAV sequence {c['test']['seq'][1]}/"
              f"{c['test']['seq'][0]} pos/neg). Train: {c['train']['pos']} / {c['train']['neg']} "
              f"(with augmentation), val: {c['val']['pos']} / {c['val']['neg']}.", "",
              "| classifier | correct | accuracy | TP rate | FP rate | miss @ FPPW 1e-2 | miss @ 1e-1 | "
              "TP MSRS | TP HIT-UAV | TP seq | TP hot vehicles | val acc | **window FPPW** | contrast FPPW | "
              "TP window-found vehicles |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
        for name, m in r["rows"].items():
            p = m.get("per_set", {})
            g = lambda k: _pct(p.get(k, {}).get("tp_rate")) if isinstance(p.get(k), dict) else "–"
            mm = m.get("mined", {})
            L.append(f"| {name} | {m['correct']}/{m['n']} | {_pct(m['accuracy'])} | {_pct(m['tp_rate'])} | "
                     f"{_pct(m['fp_rate'])} | {_pct(m['miss_at_fppw']['1e-2'])} | {_pct(m['miss_at_fppw']['1e-1'])} | "
                     f"{g('msrs')} | {g('hit')} | {g('seq')} | {_pct(p.get('hot_vehicles_tp_rate'))} | "
                     f"{_pct(m.get('val_accuracy', m.get('params', {}).get('val_acc')))} | "
                     f"{_pct(mm.get('window_fppw'))} | {_pct(mm.get('contrast_fppw'))} | {_pct(mm.get('window_tp'))} |")
        if any("mined" in m for m in r["rows"].values()):
            c0 = next(m["mined"] for m in r["rows"].values() if "mined" in m)
            L += ["", f"The first eleven columns are on the issue-3 test rows (unchanged: {c['test']['pos'] - c['test'].get('window_pos', 0)} "
                  f"vehicles, {c['test']['neg'] - c0['window_n'] - c0['contrast_n']} non-vehicle windows). The last three are the "
                  f"issue-7 generator rows of the same test frames: **window FPPW** = accepted / {c0['window_n']} sliding "
                  f"windows (IoU < 0.2 with every vehicle, pre-filtered like the detector, half from each frame's most "
                  f"structured windows), contrast FPPW = accepted / {c0['contrast_n']} contrast components, TP "
                  f"window-found = accepted / {c0['window_pos_n']} "
                  f"best-matching windows (IoU ≥ 0.5) of the test vehicles, i.e. the vehicle as a window presents it."]
        L += ["", f"Best depth by val accuracy: {r['best_depth']} hidden layer(s). "
              f"DET curve: [{r['det_png'].split('/')[-1]}]({r['det_png'].split('/')[-1]}).", ""]
        if r["models"]:
            L += ["Exported models (float vs int8 on the same test split; C = `vd_dbn_classify` through the shared "
                  "build, compared with the Python integer reference):", "",
                  "| model | layers | float acc / TP / FP | int8 acc / TP / FP | Δ acc (points) | .vdm bytes | "
                  "int8 weight bytes | C bit-exact |", "|---|---|---|---|---|---|---|---|"]
            for name, m in r["models"].items():
                f = m["float"]
                q = m.get("quantised")
                ce = m.get("c_bit_exact", {})
                L.append(f"| `{name}` | {'-'.join(map(str, f['layers']))} | {_pct(f['accuracy'])} / "
                         f"{_pct(f['tp_rate'])} / {_pct(f['fp_rate'])} | " +
                         (f"{_pct(q['accuracy'])} / {_pct(q['tp_rate'])} / {_pct(q['fp_rate'])} | "
                          f"{100 * (q['accuracy'] - f['accuracy']):+.2f} | {m['vdm_bytes']} | {m['weight_bytes_int8']} | "
                          + (f"{ce['equal']}/{ce['samples']}" if "equal" in ce else "n/a") + " |"
                          if q else "not exported | – | – | – | – |"))
            L.append("")
        if r.get("before"):
            L += ["Before / after (issue-3 models: raw input, 6 CD-1 epochs on 6000 rows, no mined negatives; "
                  "re-measured here on the same test rows, plus the window rows they never saw):", "",
                  "| model | shipped as default | layers | float acc / TP / FP | int8 acc / TP / FP | window FPPW (float / int8) | "
                  "contrast FPPW | TP window-found |", "|---|---|---|---|---|---|---|---|"]
            for name, new in (("vd_dbn_grey", "vd_dbn_grey"), ("vd_dbn_compact", COMPACT_NAME)):
                pairs = [(f"before: `{name}` (issue 3)", r["before"].get(name))]
                if new in r["models"]:
                    nm = r["models"][new]
                    pairs.append((f"after: `{new}`", dict(nm["float"], quantised=nm.get("quantised"))))
                for tag, b in pairs:
                    if not b:
                        continue
                    q = b.get("quantised") or {}
                    qs = (f"{_pct(q.get('accuracy'))} / {_pct(q.get('tp_rate'))} / {_pct(q.get('fp_rate'))}"
                          if q else "–")
                    L.append(f"| {tag} | {'default' if tag.startswith('after: `vd_dbn_grey') or tag == 'before: `vd_dbn_compact` (issue 3)' else '–'} | {'-'.join(map(str, b.get('layers', [])))} | "
                             f"{_pct(b['accuracy'])} / {_pct(b['tp_rate'])} / {_pct(b['fp_rate'])} | {qs} | "
                             f"{_pct(b['mined']['window_fppw'])} / {_pct(q.get('mined', {}).get('window_fppw'))} | "
                             f"{_pct(b['mined']['contrast_fppw'])} | {_pct(b['mined']['window_tp'])} |")
            L.append("")
        t = r["timings"]
        L += [f"Run time: {t['total_s']:.0f} s (pre-training {t['pretrain_stack_s']:.0f} s, baselines "
              f"{t['baselines_s']:.0f} s" + (" in two worker processes alongside the DBN training" if "baselines_raw_s" in t
                                             else "") + f") on a shared 2-core machine. Sampler: "
              f"{r['dataset']['meta']['sampler']}, candidate stage: {r['dataset']['meta']['candidates']}"
              + (f"; DBN input normalisation: {r['recipe'].get('input_norm', 'none')}"
                 + (f" (min range {r['recipe']['norm_min_range']})" if r['recipe'].get('input_norm', 'none') != 'none'
                    else "") if "input_norm" in r.get("recipe", {}) else "") + ".", ""]
    L += ["## Reading the numbers", "",
          "- The best classifier by test accuracy is " + "; ".join(
              f"`{mode}`: {max(r['rows'], key=lambda k: r['rows'][k]['accuracy'])} "
              f"({100 * max(m['accuracy'] for m in r['rows'].values()):.1f}%)" for mode, r in res["runs"].items()) + ".",
          *READING,
          "- Quantisation (int8 weights, Q8 activations) changes accuracy by well under 0.5 points, and the C "
          "inference equals the Python integer reference on every test sample.", ""]
    L += ["## Paper 001, Table 1 (its own FIR data: 2700 training, 500 test samples)", "",
          "| classifier | correct rate |", "|---|---|"]
    L += [f"| {k} | {v:.1f}% |" for k, v in PAPER.items()]
    L += ["", "Not comparable number for number: different camera, scenes and negatives (ours include the hot "
          "non-vehicles the candidate stage really produces: people, bicycles, lamps, warm road), and a test "
          "split made of unseen drives/flights.", "",
          "## Reproduce", "", "```"] + sorted({r.get("command", res.get("command", "")) for r in res["runs"].values()}) + ["```", "",
          "Recipe, data set construction and what differs from the paper: [docs/training.md](../training.md).", "",
          "## Data", ""] + [f"- {c}" for c in CITATIONS] + [""]
    return "\n".join(L)


def _synth_groups(run):
    return sorted(g for g in run["dataset"]["meta"].get("groups", {}).get("train", []) if g.startswith("synth-"))


def model_card(name, run, m):
    f = m["float"]
    q = m.get("quantised")
    c = run["dataset"]["counts"]
    ce = m.get("c_bit_exact", {})
    lines = [f"# Model card: `{name}`", "",
             f"- **Task**: vehicle / not-vehicle verification of a 32×32 candidate sample (paper 001 §4 DBN).",
             f"- **Input mode**: `{run['mode']}` ({'grey-level crop' if run['mode'] == 'grey' else 'binary shape mask from the refine stage'}"
             f", resampled by `vd_resample_u8`), input x = "
             + ("stretched pixel / 255: `vd_dbn_classify` applies the per-sample min-max stretch of .vdm format "
                f"version 2 (header input_norm 1, min range {run['recipe']['norm_min_range']}; docs/fixed-point.md "
                "\"dbn\"), so callers pass the raw resampled bytes."
                if run.get("recipe", {}).get("input_norm", "none") != "none" else "pixel / 255 (no normalisation)."),
             f"- **Architecture**: {'-'.join(map(str, f['layers']))} (sigmoid units; the 2-unit softmax label layer "
             "folded into one sigmoid unit = p(vehicle)); score = Q8 probability, vehicle if score ≥ 128.",
             f"- **Files**: `models/{name}.vdm` ({m.get('vdm_bytes', '?')} bytes, int8 weights "
             f"{m.get('weight_bytes_int8', '?')} bytes), " + (f"`models/{name}_vdm.c` / `_vdm.h` (const arrays for flash). "
             if (MODELS_DIR / f"{name}_vdm.c").exists() and name == "vd_dbn_compact" else
             f"C arrays for flash not committed: `python3 -m vdtools.formats.export --c-from-vdm ../models/{name}.vdm --out ../models`. ") +
             f"Export summary: {m.get('summary', '')}.",
             "- **Format**: `.vdm` version 2 (docs/model-format.md), header input_norm "
             + ("1 (min-max stretch)" if run.get("recipe", {}).get("input_norm", "none") != "none" else
                "0 (none); trained in issue 3 and re-exported unchanged for version 2 (only the version field "
                "differs from the version-1 blob; same CRC, same scores)") + ".",
             "- **Training data**: MSRS road-level frames (car) and HIT-UAV drone frames (Car, OtherVehicle); "
             "negatives = hot-spot candidates of the C candidate stage not overlapping a vehicle + random windows "
             "of vehicle size" + (" + hard negatives of the issue-7 generators (sliding windows pre-filtered like the "
                                  "detector, contrast components; IoU < 0.2) + the best window of each vehicle as a "
                                  "positive" if run["dataset"]["meta"].get("mined") else "")
             + ("; plus, in the train split only, synthetic frames of `vdtools.data.clip` (seeds "
                + ", ".join(g[len("synth-"):] for g in _synth_groups(run)) + ", never the bundled demo clip's seed 1; "
                "8-bit and 16-bit-mapped-to-grey frames, sampled with the same rules)"
                if _synth_groups(run) else "") + " (docs/training.md).",
             f"- **Split** (by frame group, seed {run['seed']}): train {c['train']['pos']} pos / {c['train']['neg']} neg "
             f"({c['train']['groups']} groups, with augmentation), val {c['val']['pos']} / {c['val']['neg']}, "
             f"test {c['test']['pos']} / {c['test']['neg']} ({c['test']['groups']} groups incl. the whole HIT-UAV "
             f"sequence-0_100). Data set fingerprint {run['dataset']['fingerprint']}.",
             "", "## Metrics on the test split", "",
             "| | accuracy | TP rate | FP rate | window FPPW | contrast FPPW | TP window-found vehicles |",
             "|---|---|---|---|---|---|---|",
             f"| float | {_pct(f['accuracy'])} | {_pct(f['tp_rate'])} | {_pct(f['fp_rate'])} | "
             f"{_pct(f.get('mined', {}).get('window_fppw'))} | {_pct(f.get('mined', {}).get('contrast_fppw'))} | "
             f"{_pct(f.get('mined', {}).get('window_tp'))} |"]
    if q:
        lines.append(f"| int8 (.vdm) | {_pct(q['accuracy'])} | {_pct(q['tp_rate'])} | {_pct(q['fp_rate'])} | "
                     f"{_pct(q.get('mined', {}).get('window_fppw'))} | {_pct(q.get('mined', {}).get('contrast_fppw'))} | "
                     f"{_pct(q.get('mined', {}).get('window_tp'))} |")
        lines += ["", "Accuracy / TP / FP on the issue-3 test rows; window / contrast FPPW and TP window-found on the "
                  "issue-7 generator rows of the same test frames (docs/results/verifier.md)."]
        lines += ["", f"Quantised − float accuracy: {100 * (q['accuracy'] - f['accuracy']):+.2f} points; decisions "
                  f"agree on {100 * m['agreement_float_vs_quant']:.2f}% of samples. C `vd_dbn_classify` equals the "
                  f"Python integer reference on " + (f"{ce['equal']}/{ce['samples']}" if 'equal' in ce else "n/a")
                  + " test samples."]
    p = f.get("per_set", {})
    lines += ["", "Per source (float TP rate / FP rate): " + "; ".join(
        f"{k} {_pct(v['tp_rate'])} / {_pct(v['fp_rate'])}" for k, v in p.items() if isinstance(v, dict)) + ".",
        "", "## Limits", "",
        "- Trained on AGC-scaled 8-bit video of two public sets, not on a radiometric automotive camera: "
        "retrain on the target camera before relying on it.",
        "- MSRS has unlabelled distant cars and cold parked cars; HIT-UAV is a drone view. See "
        "docs/results/verifier.md for the whole table and the DET curve.",
        "", "## Reproduce", "", "```", run.get("command", ""), "```", "",
        "## Data citations", ""] + [f"- {x}" for x in CITATIONS] + [""]
    return "\n".join(lines)


COMMITTED = {"grey": ("vd_dbn_grey", "vd_dbn_compact", "vd_dbn_compact_w"), "shape": ("vd_dbn_shape",)}


def committed_rows(modes=("grey", "shape"), seed=0, log=print):
    """The committed models/*.vdm (int8, the integer reference equal to vd_dbn_classify) on the current
    test split, built alone (no training: tools/.cache/dataset_<mode>_s<seed>_v<N>_test.npz, ~1 min).
    Same metrics as the Table 1 rows: issue-3 rows (accuracy / TP / FP / per set) and the mined rows."""
    import struct
    from vdtools.formats import quantise, vdm
    out = {}
    for mode in modes:
        ds = dataset.load_or_build_split("test", mode, seed)
        classic = np.isin(ds["source"], dataset.CLASSIC_SOURCES)
        y = ds["y"].astype(np.int64)
        xt = ds["X"].reshape(len(ds["X"]), -1)
        counts = {"frames": int(len(set(ds["frame"].tolist()))), "groups": int(len(set(ds["group"].tolist())))}
        for name in ("msrs", "hit", "seq"):
            k = classic & (ds["dataset"] == name)
            counts[name] = [int((k & (y == 1)).sum()), int((k & (y == 0)).sum())]   # pos, neg
        counts.update({s: int((ds["source"] == s).sum()) for s in ("window", "contrast", "window_pos")})
        models = {}
        for name in COMMITTED[mode]:
            blob = (MODELS_DIR / f"{name}.vdm").read_bytes()
            r, _ = _row(quantise.quant_forward(vdm.unpack(blob), xt), y, 128, ds, classic)
            r["crc32"] = "0x%08X" % struct.unpack_from("<I", blob, 12)[0]
            models[name] = r
            mm = r["mined"]
            log(f"  {mode} {name} {r['crc32']}: acc {100 * r['accuracy']:.1f}% TP {100 * r['tp_rate']:.1f}% "
                f"FP {100 * r['fp_rate']:.1f}% window FPPW {_pct(mm['window_fppw'])} contrast FPPW "
                f"{_pct(mm['contrast_fppw'])} TP window-found {_pct(mm['window_tp'])}")
        out[mode] = {"counts": counts, "models": models}
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description="Paper 001 Table 1 on our data: DBN depths vs HOG/Haar/LBP baselines.")
    ap.add_argument("--mode", default=None, help="grey, shape or grey,shape (default grey; with --committed both)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--export", action="store_true", help="quantise + export models/<name>.vdm and model cards")
    ap.add_argument("--quick", action="store_true", help="4 epochs everywhere (smoke test; results not kept)")
    ap.add_argument("--render", action="store_true", help="only re-render verifier.md from verifier.json")
    ap.add_argument("--committed", metavar="JSON", help="no training: score the committed models/*.vdm (int8) on "
                    "the current test split (built alone, about a minute) and write the figures to JSON")
    a = ap.parse_args(argv)
    if a.committed:
        res = committed_rows(a.mode.split(",") if a.mode else ("grey", "shape"), a.seed)
        res["command"] = "cd tools && VD_LIB=../build/libvd.so python3 -m vdtools.evaluation.table1 " + \
            " ".join(argv if argv is not None else sys.argv[1:])
        Path(a.committed).write_text(json.dumps(res, indent=1, default=float) + "\n")
        return
    a.mode = a.mode or "grey"
    if a.render:
        res = json.loads((RESULTS / "verifier.json").read_text())
        (RESULTS / "verifier.md").write_text(render_md(res))
        if a.export:   # --render --export: the model cards too
            for r in res["runs"].values():
                for name, m in r["models"].items():
                    if "quantised" in m:
                        (MODELS_DIR / f"{name}.md").write_text(model_card(name, r, m))
        return
    cmd = "cd tools && VD_LIB=../build/libvd.so python3 -m vdtools.evaluation.table1 " + " ".join(argv if argv is not None else sys.argv[1:])
    jpath = RESULTS / "verifier.json"
    res = {"runs": {}}
    for mode in a.mode.split(","):
        r = run_mode(mode, a.seed, a.export, a.quick)
        (dataset.CACHE / f"table1_{mode}_last.json").write_text(json.dumps(r, indent=1, default=float))
        r["command"] = cmd
        r["versions"] = {"python": platform.python_version(), "numpy": np.__version__}
        res["runs"][mode] = r
        if a.export:
            for name, m in r["models"].items():
                (MODELS_DIR / f"{name}.md").write_text(model_card(name, r, m))
        for name, m in r["rows"].items():
            print(f"  {name:38} {m['correct']:5}/{m['n']:<5} acc {100 * m['accuracy']:5.1f}%  "
                  f"TP {100 * m['tp_rate']:5.1f}%  FP {100 * m['fp_rate']:5.1f}%")
        for name, m in r["models"].items():
            if "quantised" in m:
                print(f"  {name}: float {100 * m['float']['accuracy']:.2f}% int8 {100 * m['quantised']['accuracy']:.2f}% "
                      f"({m['vdm_bytes']} B) C bit-exact {m['c_bit_exact']}")
    if jpath.exists() and not a.quick:   # merge with the other mode's entry, read as late as possible
        old = json.loads(jpath.read_text())
        res["runs"] = {**old.get("runs", {}), **res["runs"]}
    res["command"] = cmd
    out_dir = RESULTS if not a.quick else dataset.CACHE / "quick"
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "verifier.json").write_text(json.dumps(res, indent=1, default=float))
    (out_dir / "verifier.md").write_text(render_md(res))
    print(f"wrote {out_dir / 'verifier.md'} and verifier.json")


if __name__ == "__main__":
    main()
