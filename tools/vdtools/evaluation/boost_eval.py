# SPDX-License-Identifier: MIT
"""Paper 003's comparison on our data (docs/results/boost.md): DET curves (miss rate against false
positives per window, log axes) on the test split of the 64x64 crop set (vdtools.training.boost_train) for

  boosted CNN features   models/vd_boost.vdm: integer scores (== vd_boost_score, the parity test)
  DBN                    models/vd_dbn_grey.vdm, int8 (== vd_dbn_classify) on the same rects cut at 32x32
  HOG + SVM, Haar + AdaBoost, LBP + AdaBoost   vdtools.training.baselines on the same rects at 32x32, trained on
                         the same train rows (C of the SVM on val)

plus the miss rate at 1e-4 / 1e-3 / 1e-2 FPPW, and paper §3.3-3.4's feature-set experiments in short
form (experiment 1: 1 / 2 / 3 maps per layer; experiment 2: every one-map-per-layer combination of the
top-3 maps), each trained with --exp-stumps stumps on --exp-train train rows and read on the test split.

    cd tools && python3 -m vdtools.evaluation.boost_eval [--experiments]
"""
import argparse
import itertools
import json
import math
import time
from pathlib import Path

import numpy as np

from vdtools.training import boost_train as BT
from vdtools.formats import boost_vdm as B
from vdtools.bindings import boost as vd_boost
from vdtools.bindings import clib
from vdtools.metrics.det import det_curve, miss_at, plot

RESULTS = clib.REPO / "docs" / "results"
TARGETS = (1e-4, 1e-3, 1e-2, 1e-1)


def recut(ds, side):
    """uint8 [N, side, side] of every row's rect cut from its frame by the C resampler (mirrored rows
    mirrored again, as the data set builder does)."""
    from vdtools.data import dataset, samples
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
    ap.add_argument("--exp-stumps", type=int, default=25)
    ap.add_argument("--exp-train", type=int, default=2000)
    ap.add_argument("--no-baselines", action="store_true")
    ap.add_argument("--tag", default="")
    ap.add_argument("--render", action="store_true", help="only rewrite boost.md from boost.json")
    a = ap.parse_args(argv)
    if a.render:
        meta = load_meta(a.model)
        (RESULTS / "boost.md").write_text(render_md(json.loads((RESULTS / "boost.json").read_text()), meta))
        return
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
    from vdtools.formats import quantise, vdm
    qm = vdm.unpack((clib.REPO / "models" / "vd_dbn_grey.vdm").read_bytes())
    s_dbn = quantise.quant_forward(qm, X32[te].reshape(int(te.sum()), -1))
    table["DBN vd_dbn_grey (int8)"], curves["DBN (vd_dbn_grey)"] = rates(s_dbn, y[te])
    BT.log("dbn", table["DBN vd_dbn_grey (int8)"])
    if not a.no_baselines:
        from vdtools.training import baselines
        bp = BT.CACHE / "baselines.json"   # independent of the CNN: computed once
        if bp.exists():
            res = {k: {"score": np.asarray(v)} for k, v in json.loads(bp.read_text()).items()}
        else:
            res = baselines.run_all(X32, y, split, 0, log=BT.log)
            bp.write_text(json.dumps({k: np.asarray(v["score"], np.float64).tolist() for k, v in res.items()}))
        for k, v in res.items():
            table[k], curves[k] = rates(v["score"], y[te])
            BT.log(k, table[k])
    RESULTS.mkdir(parents=True, exist_ok=True)
    plot(curves, RESULTS / "det_boost.png", title="DET: 64x64 test crops (paper 003 protocol)")
    out["table"] = table

    out["speed"] = speed(blob, ds["X"][te])
    out["speed"]["m7_text"] = m7_text()
    BT.log("speed", out["speed"])
    if a.experiments:
        out["experiments"] = experiments(ds, T, y, split, a.exp_stumps, a.exp_train, ckpt=BT.CACHE / f"cnn_f{a.filters}{a.tag}.pt")
    out["seconds"] = round(time.time() - t0)
    (RESULTS / "boost.json").write_text(json.dumps(out, indent=1))
    meta = load_meta(a.model)
    if (BT.CACHE / f"{Path(a.model).stem}.json").exists():   # keep --render working from a clean checkout
        (RESULTS / "boost_model.json").write_text(json.dumps(meta, indent=1) + "\n")
    (RESULTS / "boost.md").write_text(render_md(out, meta))
    BT.log("wrote", RESULTS / "boost.json")


def load_meta(model):
    """The model's export meta: boost_train's cache, else the committed docs/results/boost_model.json."""
    p = BT.CACHE / f"{Path(model).stem}.json"
    meta = json.loads((p if p.exists() else RESULTS / "boost_model.json").read_text())
    meta["name"] = Path(model).stem
    return meta


def _pct(v):
    return f"{100 * v:.1f} %"


def render_md(res, meta):
    """docs/results/boost.md from boost.json and the model's export meta (tools/.cache/p003/<name>.json)."""
    t = res["test"]
    L = ["<!-- generated by python3 -m vdtools.evaluation.boost_eval; edit the generator, not this file -->",
         "# Paper 003 on our data: boosted CNN-feature verifier vs DBN, HOG, Haar, LBP (issue 12)", "",
         f"DET protocol of paper 003 (§3.1): miss rate against false positives per window on the **test split** of "
         f"the 64×64 crop set (scene groups no model trained on; nothing chosen on it): {t['pos']} vehicles, "
         f"{t['neg']} non-vehicle windows ({t['neg_window']} of them sliding windows of the detector's generator, "
         f"60 per test frame, the rest candidate / random / contrast negatives), so 10⁻⁴ FPPW = "
         f"{int(1e-4 * t['neg'])} false positive(s). Every classifier sees the same rects: the boosted verifier "
         f"as 64×64 crops, the others as the same rects cut at 32×32 (their input). Curves: "
         f"[det_boost.png](det_boost.png); numbers: [boost.json](boost.json). Reproduce: after docs/training.md's "
         f"`boost_train` steps, `cd tools && VD_LIB=../build/libvd.so python3 -m vdtools.evaluation.boost_eval --filters 8 "
         f"--experiments` (9 min here with the baselines' scores cached in tools/.cache/p003/baselines.json; "
         f"computing them took 11 min).", "",
         "| verifier | miss @ 10⁻⁴ FPPW | miss @ 10⁻³ | miss @ 10⁻² | miss @ 10⁻¹ |", "|---|---:|---:|---:|---:|"]
    for k, v in res["table"].items():
        L.append(f"| {k} | {_pct(v['miss@0.0001'])} | {_pct(v['miss@0.001'])} | {_pct(v['miss@0.01'])} | "
                 f"{_pct(v['miss@0.1'])} |")
    L += ["", f"Boosted model: `models/{meta.get('name', 'vd_boost')}.vdm`, {meta['bytes']} bytes, CRC {meta['crc32']}; "
          f"CNN of 5 × 5×5 convolutions with **{meta['filters']} filters per layer** (not the paper's 60), "
          f"{meta['macs'] / 1e6:.1f} M multiply-adds per crop, best epoch {meta['epoch']} (val loss "
          f"{meta['val_loss']:.3f}, val accuracy {100 * meta['val_acc']:.1f} %); maps {meta['maps']} "
          f"(tensor, channel) = {meta['n_features']} features; {meta['n_stumps']} stumps (chosen on val), votes Q{meta['q']}, "
          f"threshold {meta['threshold']}.", ""]
    tab = res["table"]
    bk = next(k for k in tab if k.startswith("boosted"))
    others = {k: v for k, v in tab.items() if k != bk}
    best_o = min(others, key=lambda k: (others[k]["miss@0.0001"], others[k]["miss@0.001"]))
    d4 = tab[bk]["miss@0.0001"] - others[best_o]["miss@0.0001"]
    d3 = tab[bk]["miss@0.001"] - min(v["miss@0.001"] for v in others.values())
    won = d4 < 0 and all(tab[bk]["miss@0.0001"] < v["miss@0.0001"] for v in others.values())
    L += ["**Against the goal (miss rate at 10⁻⁴ FPPW lower than every other verifier): " +
          ("met.**" if won else
           f"missed.** The boosted verifier is {100 * d4:+.1f} points against the best other verifier "
           f"({best_o}) at 10⁻⁴ and {100 * d3:+.1f} points against the best at 10⁻³; its rank among the "
           f"{len(tab)} (1 = lowest miss rate) at 10⁻⁴ / 10⁻³ / 10⁻² / 10⁻¹ FPPW: " +
           " / ".join(str(1 + sum(v[f'miss@{t:g}'] < tab[bk][f'miss@{t:g}'] for v in others.values()))
                      for t in TARGETS) + ", while paper 003 reports its method ahead of HOG and LBP."), "",
          "Likely causes (none isolated by an experiment here except the feature-set rows below): (1) the CNN "
          "is small and short-trained: 8 filters per layer instead of 60, 3 epochs on 12 000 train crops; its own "
          "classifier head reaches " + f"{100 * meta['val_acc']:.0f} % val accuracy (a 60-filter network was not "
          "trained); (2) the paper's criterion ranks maps by mean activation, not by how well they "
          "separate vehicles from non-vehicles (per-map separation was not measured); (3) one 32×32 map per "
          "layer (3072 values, padding 2) and " + f"{meta['n_stumps']}" + " stumps, chosen on a val split of 2 940 "
          "crops; (4) at 10⁻⁴ FPPW (one false positive here) every verifier misses " +
          f"{100 * min(v['miss@0.0001'] for v in tab.values()):.1f}–{100 * max(v['miss@0.0001'] for v in tab.values()):.1f} %"
          " of the vehicles, so that reading point separates little on these thermal crops (32–64 px objects), "
          "unlike paper 003's GTI visible-light 64×64 rear views. HOG + linear SVM has the lowest miss rate at "
          "every reading point here.", ""]
    sel = meta["selected"]
    L += ["Map selection (paper §3.2, Table 2: by mean activation over the val vehicles, largest first):", "",
          "| | Maxpool_1 | Conv_4 | Conv_5 |", "|---|---:|---:|---:|"]
    for i in range(3):
        L.append(f"| Max {i + 1} | {sel['Maxpool_1'][i]} | {sel['Conv_4'][i]} | {sel['Conv_5'][i]} |")
    L.append("")
    sp = res.get("speed")
    if sp:
        L += [f"Speed (host, one thread, `vd_boost_score` through ctypes, shared loaded machine): "
              f"**{sp['us_per_crop']:.0f} µs per 64×64 crop** (features + {sp['stumps']} stumps), "
              f"{sp['macs'] / 1e6:.1f} M multiply-adds, model {sp['model_bytes']} bytes, workspace "
              f"{sp['workspace_bytes']} bytes (the CNN with every tensor kept)." +
              (" Cortex-M7 `-Os` code added: " + ", ".join(f"`{f}` {n}" for f, n in sp["m7_text"].items()) +
               " bytes of .text "
               f"(arm-none-eabi-gcc; the CONV5X5 op adds 100 bytes to `cnn.c` and the verifier switch 372 bytes to "
               f"the detector, measured against the previous commit's objects). "
               if sp.get("m7_text") else "") +
              f" No early-exit soft cascade (optional in the issue, not built): the {sp['stumps']} stump compares are "
              f"{100 * sp['stumps'] / sp['macs']:.4f} % of the {sp['macs'] / 1e6:.1f} M multiply-adds that compute the "
              "maps, so stopping early among the stumps cannot save measurable time; a cascade would have to reject "
              "before the later CNN layers.", ""]
    tp = RESULTS / "boost_train_time.json"
    if tp.exists():
        L += train_time_md(json.loads(tp.read_text()), sp)
    dp = RESULTS / "boost_detector.json"
    if dp.exists():
        det = json.loads(dp.read_text())
        L += ["## Whole detector: window source, boosted verifier vs DBN (issue 12 item 4)", "",
              "`vd_fir_demo` on the test split (270 frames), `--sources window --max-candidates 256 "
              "--max-detections 64 --temporal off`, the same windows verified by the DBN (`--model "
              "models/vd_dbn_grey.vdm`, kept at score ≥ 0.5) or by the boosted verifier (`--verifier boost`, kept at "
              "its threshold = score ≥ 0.5); AP@0.5 from the scores down to 0.05 (boosted: every window kept with "
              "`--boost-offset -16777216`, ranked by its score); `python3 -m vdtools.evaluation.cnn_eval --backend demo "
              "--paper \"...\" --split test --thr 0.5`. Frames/s: the demo's wall time over the 270 frames (PNG "
              "decoding included, shared loaded 2-core machine). The CNN source row is docs/results/detector.md's.", "",
              "| configuration | family | vehicles | AP@0.5 | TP rate | FP rate | frames/s |", "|---|---|---:|---:|---:|---:|---:|"]
        for r in det["rows"]:
            fps = f"{r['fps']:.1f}" if r.get("fps") else "–"
            L.append(f"| {r['name']} | {r['family']} | {r['n_vehicles']} | {100 * r['ap']:.1f} | {_pct(r['tp_rate'])} | "
                     f"{_pct(r['fp_rate'])} | {fps} |")
        L += ["", det.get("note", ""), ""]
    ex = res.get("experiments")
    if ex:
        L += [f"## Feature-set experiments (paper §3.3–3.4), short form", "",
              f"Each row: AdaBoost (SAMME) of {ex['stumps']} stumps trained on {ex['train_rows']} random train rows "
              f"of the listed maps, read on the test split (the same crops as above).", "",
              "Experiment 1 (maps per layer, in activation order):", "",
              "| feature set | miss @ 10⁻⁴ | miss @ 10⁻³ | miss @ 10⁻² |", "|---|---:|---:|---:|"]
        for k, v in ex["experiment1"].items():
            L.append(f"| {k} | {_pct(v['miss@0.0001'])} | {_pct(v['miss@0.001'])} | {_pct(v['miss@0.01'])} |")
        L += ["", "Experiment 2 (one map per layer: every combination of the top 3, best first by miss @ 10⁻²):", "",
              "| Maxpool_1 / Conv_4 / Conv_5 maps | miss @ 10⁻⁴ | miss @ 10⁻³ | miss @ 10⁻² |", "|---|---:|---:|---:|"]
        for k, v in sorted(ex["experiment2"].items(), key=lambda kv: (kv[1]["miss@0.01"], kv[1]["miss@0.001"])):
            L.append(f"| {k} | {_pct(v['miss@0.0001'])} | {_pct(v['miss@0.001'])} | {_pct(v['miss@0.01'])} |")
        e1 = list(ex["experiment1"].values())
        order = sorted(ex["experiment2"], key=lambda k: (ex["experiment2"][k]["miss@0.01"], ex["experiment2"][k]["miss@0.001"]))
        top = " ".join(f"{n}#{ex['selected'][n][0]}" for n in ("Maxpool_1", "Conv_4", "Conv_5"))
        L += ["", f"The paper's choice (the most activated map of each layer, {top}) ranks "
              f"{order.index(top) + 1} of {len(order)} in experiment 2 at 10⁻²; "
              f"the best combination here is {order[0]}. In experiment 1, 2 or 3 maps per layer change the miss "
              f"rate at 10⁻² by at most {100 * max(abs(v['miss@0.01'] - e1[0]['miss@0.01']) for v in e1):.1f} points "
              "against 1 map (the paper found no significant gain either). These runs are small (few stumps and "
              "rows, one seed; their spread over seeds was not measured), so small differences may not repeat; the "
              "shipped model uses the paper's choice.", ""]
        L.append("")
    return "\n".join(L) + "\n"


def train_time_md(tt, sp=None):
    """The "Why 8 filters" section from boost_train_time.json (python3 -m vdtools.training.boost_train time)."""
    r = {x["filters"]: x for x in tt["rows"]}
    a, b = r[8], r[60]
    nb = math.ceil(tt["n_train"] / tt["batch"])
    L = ["## Why 8 filters per layer (training cost measured)", "",
         f"Paper 003's network has 60 filters per layer, ours 8. Measured: one training step of `boost_train`'s "
         f"network (forward, backward, Adam; batch {tt['batch']} of random 64×64 inputs, PyTorch {tt['torch']} on "
         f"{tt['threads']} thread, median of {a['steps']} steps after one warm-up step, shared loaded 2-core "
         f"machine), extrapolated to one epoch of {tt['n_train']} crops ({nb} batches) and to the shipped schedule "
         f"({tt['epochs']} epochs; validation passes and data preparation not included). Multiply-adds: the float "
         "network's convolutions and 1-channel head (the exported int8 model's 3-channel head adds 4096). Command: "
         "`cd tools && python3 -m vdtools.training.boost_train time --time-steps 5` (writes "
         "[boost_train_time.json](boost_train_time.json)).", "",
         "| filters per layer | multiply-adds per 64×64 crop | s per batch | one epoch | shipped schedule |",
         "|---:|---:|---:|---:|---:|"]
    for x in (a, b):
        L.append(f"| {x['filters']} | {x['macs'] / 1e6:.1f} M | {x['s_per_batch']:.2f} s | "
                 f"{x['s_per_epoch'] / 60:.1f} min | {x['s_schedule'] / 60:.1f} min |")
    mr, tr = b["macs"] / a["macs"], b["s_per_batch"] / a["s_per_batch"]
    txt = (f"60 filters cost {mr:.0f}× the multiply-adds and {tr:.0f}× the training time of 8 (PyTorch uses the "
           f"core better on the wider layers): the shipped schedule would take {b['s_schedule'] / 60:.0f} min "
           f"instead of {a['s_schedule'] / 60:.1f} min. So training time alone did not rule 60 filters out (the "
           "earlier \"too slow to train here\" was not measured); the cost per candidate does")
    if sp:
        txt += (f": at the host speed measured above ({sp['us_per_crop']:.0f} µs per crop for "
                f"{sp['macs'] / 1e6:.1f} M multiply-adds) the 60-filter features would take about "
                f"{sp['us_per_crop'] * mr / 1000:.0f} ms per crop (extrapolated by multiply-adds, not measured), "
                "for every candidate window of every frame")
    L += ["", txt + ". A 60-filter network was not trained, so its miss rate here is unknown.", ""]
    return L


M7_FLAGS = ["-mcpu=cortex-m7", "-mthumb", "-mfloat-abi=soft", "-Os", "-std=c99", "-ffunction-sections", "-DNDEBUG"]


def m7_text(files=("lib/src/models/boost.c",)):
    """.text bytes of lib sources compiled for Cortex-M7 -Os (arm-none-eabi-gcc), or None without it."""
    import shutil
    import subprocess
    import tempfile
    if not shutil.which("arm-none-eabi-gcc"):
        return None
    out = {}
    with tempfile.TemporaryDirectory() as td:
        for f in files:
            o = Path(td) / (Path(f).stem + ".o")
            subprocess.run(["arm-none-eabi-gcc", *M7_FLAGS, "-I", str(clib.REPO / "lib" / "include"), "-I",
                            str(clib.REPO / "lib" / "src"), "-c", str(clib.REPO / f), "-o", str(o)], check=True)
            txt = subprocess.run(["arm-none-eabi-size", str(o)], check=True, capture_output=True, text=True).stdout
            out[f] = int(txt.splitlines()[1].split()[0])
    return out


def speed(blob, X, n=300, reps=3):
    """Median over reps of the mean wall time of vd_boost_score per 64x64 crop (one thread, ctypes call
    included), the CNN's multiply-adds and the model bytes."""
    from vdtools.formats import cnn_ref as R
    m = vd_boost.CBoost(blob)
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
