# SPDX-License-Identifier: MIT
"""Test-split frame lists for vd_fir_demo --input, and the source-configuration evaluation of
docs/results/detector.md.

The split is vdtools.data.dataset.assign_splits (seed 0: groups MSRS number // 40, HIT-UAV T_H_A
flight; the sequence-0_100 flight is test only), i.e. the frames the verifier never trained on.

    python3 -m vdtools.evaluation.splits --lists out/splits
        writes msrs_night.txt, msrs_day.txt, hit.txt, hit_night.txt, hit_day.txt, seq.txt
        (absolute frame paths, one per line) and prints the annotation path of each.
    python3 -m vdtools.evaluation.splits --lists out/splits --run --demo build/tools/vd_fir_demo \\
        --model models/vd_dbn_grey.vdm --out docs/results/detector.json [--sets msrs_night,seq] [--configs ...]
        runs the demo with --eval for every set x source configuration (CONFIGS) and collects the
        Table 2 figures, frames/s and the median stage times into one JSON file.
    python3 -m vdtools.evaluation.splits --lists out/splits --figures docs/results/figures --demo ... --model ...
        the annotated frames of docs/results/detector.md (ground truth drawn in cyan, 320 px wide).
    python3 -m vdtools.evaluation.splits --lists out/splits --ceiling --out docs/results/detector.json
        candidate recall (the TP-rate ceiling) of the same configurations, through the C detector
        without a model (VD_LIB).
"""
import argparse
import json
import re
import shlex
import subprocess
import sys
import time
from pathlib import Path

from vdtools.bindings import clib
from vdtools.data import dataset as D

SETS = ("msrs_night", "msrs_day", "hit", "hit_night", "hit_day", "seq")
# Per set: annotations (relative to the data dir) and the window preset (docs/demo.md --window-preset).
ANNOTATIONS = {"msrs": "msrs/labels", "hit": "hit-uav/frames/annotations.json",
               "seq": "hit-uav/sequence-0_100/annotations.json"}
PRESET = {"msrs": "msrs", "hit": "hit", "seq": "hit"}
# Source configurations: demo flags. "hotspot150" is paper 001's constant threshold (the library default);
# "hotspot", "+contrast", "+window" and "all" use the adaptive p99, "hotspot150+contrast" and "all150" the
# constant 150. Measured (docs/results/detector.md, "Which hot-spot threshold"): the constant 150 is the
# better hot-spot threshold on the HIT-UAV drone frames, the adaptive p99 on dark MSRS road frames.
CONFIGS = {
    "hotspot150": ["--sources", "hotspot", "--thr-mode", "constant"],
    "hotspot": ["--sources", "hotspot", "--thr-mode", "adaptive"],
    "hotspot+contrast": ["--sources", "hotspot,contrast", "--thr-mode", "adaptive"],
    "hotspot+window": ["--sources", "hotspot,window", "--thr-mode", "adaptive", "--max-candidates", "256",
                       "--max-detections", "64"],
    "all": ["--sources", "all", "--thr-mode", "adaptive", "--max-candidates", "256", "--max-detections", "64"],
    # the same with the paper's constant 150 for the hot spots (issue 11 item 4: which threshold for which data)
    "hotspot150+contrast": ["--sources", "hotspot,contrast", "--thr-mode", "constant"],
    "all150": ["--sources", "all", "--thr-mode", "constant", "--max-candidates", "256", "--max-detections", "64"],
}


def family(name):
    return "msrs" if name.startswith("msrs") else ("seq" if name == "seq" else "hit")


def test_frames(data_dir):
    """{set name: [frame paths]} of the test split."""
    frames = D.all_frames(data_dir)
    split = D.assign_splits(frames)
    out = {s: [] for s in SETS}
    for f in frames:
        if split[f.group] != "test":
            continue
        if f.dataset == "msrs":
            out["msrs_night" if Path(f.name).stem.endswith("N") else "msrs_day"].append(f.path)
        elif f.dataset == "hit":
            out["hit"].append(f.path)
            out["hit_night" if f.name.split("_")[0] == "1" else "hit_day"].append(f.path)
        else:
            out["seq"].append(f.path)
    return {k: sorted(v) for k, v in out.items()}


def write_lists(data_dir, lists_dir):
    lists_dir = Path(lists_dir)
    lists_dir.mkdir(parents=True, exist_ok=True)
    paths = {}
    for name, files in test_frames(data_dir).items():
        p = lists_dir / f"{name}.txt"
        p.write_text("".join(f"{Path(f).resolve()}\n" for f in files))
        paths[name] = (p, len(files))
    return paths


def demo_command(demo, list_path, data_dir, name, config, model, extra=()):
    fam = family(name)
    cmd = [str(demo), "--input", str(list_path), "--eval", str(Path(data_dir) / ANNOTATIONS[fam]),
           "--model", str(model), "--temporal", "off", "--quiet"]
    cmd += CONFIGS[config]
    if "window" in config or config.startswith("all"):
        cmd += ["--window-preset", PRESET[fam]]
    return cmd + list(extra)


def parse_summary(text):
    """Figures of the demo's closing summary."""
    r = {}
    m = re.search(r"(\d+) frames, (\d+) detections; ([\d.]+) fps \(detector\)", text)
    if m:
        r["frames"], r["detections"], r["fps"] = int(m.group(1)), int(m.group(2)), float(m.group(3))
    m = re.search(r"median time per frame \(ms\):(.*)", text)
    if m:
        r["median_ms"] = {k: float(v) for k, v in re.findall(r"(\w+) ([\d.]+)", m.group(1))}
    m = re.search(r"TP rate ([\d.]+)%\s+FP rate ([\d.]+)%\s+precision ([\d.]+)%\s+recall ([\d.]+)%\s+FPPI ([\d.]+)"
                  r"\s+\(TP (\d+), FP (\d+), FN (\d+)\)", text)
    if m:
        keys = ("tp_rate", "fp_rate", "precision", "recall", "fppi", "tp", "fp", "fn")
        r.update({k: (int(v) if k in ("tp", "fp", "fn") else float(v)) for k, v in zip(keys, m.groups())})
    return r


def detector_kwargs(name, config):
    """vdtools.bindings.detector keywords equal to the demo flags of CONFIGS[config] on set `name`."""
    flags = CONFIGS[config]
    kw = dict(max_width=640, max_height=512, sources=flags[flags.index("--sources") + 1],
              thr_mode=flags[flags.index("--thr-mode") + 1])
    if "--max-candidates" in flags:
        kw["max_candidates"] = int(flags[flags.index("--max-candidates") + 1])
    if "window" in kw["sources"] or kw["sources"] == "all":
        kw["windows"] = dict(preset_name=PRESET[family(name)])
    return kw


def candidate_recall(data_dir, name, config):
    """Ceiling of the TP rate: the fraction of test-split vehicles with IoU >= 0.5 with at least one
    candidate of the merged list the detector verifies (its budget, pre-filter and merge included:
    the C detector without a model, no suppression)."""
    import cv2
    from vdtools.bindings.detector import Detector
    from vdtools.evaluation.recall import iou_matrix
    kw = detector_kwargs(name, config)
    kw["max_candidates"] = kw.get("max_candidates", 64)
    det = Detector(max_detections=kw["max_candidates"], nms_iou_q15=32768, **kw)
    frames = {str(Path(f.path).resolve()): f for f in D.all_frames(data_dir)}
    hit = total = 0
    for path in test_frames(data_dir)[name]:
        fr = frames[str(Path(path).resolve())]
        img = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
        dets, _ = det.run(img)
        total += len(fr.vehicles)
        if fr.vehicles and dets:
            hit += int((iou_matrix(fr.vehicles, [d["box"] for d in dets]) >= 0.5).any(axis=1).sum())
    return hit / max(total, 1), total


# Figures of docs/results/detector.md: (file name, set, configuration); test-split frames.
FIGURES = (("01171N.png", "msrs_night", "hotspot"), ("01171N.png", "msrs_night", "hotspot+window"),
           ("1_70_30_0_04313.jpg", "hit", "hotspot"), ("1_70_30_0_04313.jpg", "hit", "hotspot+contrast"),
           ("1_70_30_0_04313.jpg", "hit", "all"))


def figures(data_dir, demo, model, out_dir, width=320):
    """Runs the demo (--out) on each FIGURES frame, draws the ground truth (cyan, 1 px) over its
    annotated PNG and writes it downscaled to `width` px as <out_dir>/<set>_<stem>_<config>.png."""
    import tempfile
    import cv2
    frames = {Path(f.path).name: f for f in D.all_frames(data_dir)}
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for fname, name, config in FIGURES:
        fr = frames[fname]
        with tempfile.TemporaryDirectory() as tmp:
            lst = Path(tmp) / "one.txt"
            lst.write_text(f"{Path(fr.path).resolve()}\n")
            cmd = demo_command(demo, lst, data_dir, name, config, model, ["--out", tmp])
            subprocess.run(cmd, check=True, capture_output=True, text=True)
            img = cv2.imread(str(Path(tmp) / (Path(fname).stem + ".png")), cv2.IMREAD_COLOR)
        for x, y, w, h in fr.vehicles:
            cv2.rectangle(img, (x, y), (x + w - 1, y + h - 1), (255, 255, 0), 1)
        scale = width / img.shape[1]
        img = cv2.resize(img, (width, int(round(img.shape[0] * scale))), interpolation=cv2.INTER_AREA)
        p = out_dir / f"{name}_{Path(fname).stem}_{config.replace('+', '-')}.png"
        cv2.imwrite(str(p), img, [cv2.IMWRITE_PNG_COMPRESSION, 9])
        written.append((p, " ".join(shlex.quote(str(c)) for c in cmd)))
    return written


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", default=str(clib.REPO.parent / "shared" / "data"))
    ap.add_argument("--lists", required=True, help="directory for the list files")
    ap.add_argument("--run", action="store_true")
    ap.add_argument("--demo", default=str(clib.REPO / "build" / "tools" / "vd_fir_demo"))
    ap.add_argument("--model", default=str(clib.REPO / "models" / "vd_dbn_grey.vdm"))
    ap.add_argument("--sets", default=",".join(SETS))
    ap.add_argument("--configs", default=",".join(CONFIGS))
    ap.add_argument("--out", help="JSON results file (merged with an existing one)")
    ap.add_argument("--tag", default="", help="suffix of the result keys (e.g. the model name)")
    ap.add_argument("--figures", help="write the FIGURES renderings into this directory")
    ap.add_argument("--extra", default="", help="more demo flags for every run, e.g. '--score-thr 0.9'")
    ap.add_argument("--ceiling", action="store_true", help="candidate recall of each set x configuration "
                    "(no model; needs VD_LIB) into --out under key '<set>/<config>@ceiling'")
    a = ap.parse_args(argv)
    paths = write_lists(a.data, a.lists)
    for name, (p, n) in paths.items():
        print(f"{name:11s} {n:4d} frames  {p}  (annotations {Path(a.data) / ANNOTATIONS[family(name)]})")
    if a.figures:
        for p, cmd in figures(a.data, a.demo, a.model, a.figures):
            print(f"{p}  ({p.stat().st_size} bytes)  <- {cmd} (+ ground truth, downscaled)")
    if a.ceiling:
        results = json.loads(Path(a.out).read_text()) if a.out and Path(a.out).exists() else {}
        for name in a.sets.split(","):
            for config in a.configs.split(","):
                r, n = candidate_recall(a.data, name, config)
                results[f"{name}/{config}@ceiling"] = {"candidate_recall": round(100 * r, 2), "vehicles": n}
                print(f"{name}/{config}: candidate recall {100 * r:.1f}% of {n}", flush=True)
                if a.out:
                    Path(a.out).write_text(json.dumps(results, indent=1, sort_keys=True) + "\n")
    if not a.run:
        return 0
    results = {}
    if a.out and Path(a.out).exists():
        results = json.loads(Path(a.out).read_text())
    for name in a.sets.split(","):
        for config in a.configs.split(","):
            cmd = demo_command(a.demo, paths[name][0], a.data, name, config, a.model, shlex.split(a.extra))
            t = time.time()
            p = subprocess.run(cmd, capture_output=True, text=True)
            if p.returncode != 0:
                print(p.stderr, file=sys.stderr)
                return 1
            r = parse_summary(p.stdout)
            r["wall_s"] = round(time.time() - t, 1)
            r["command"] = " ".join(shlex.quote(c) for c in cmd)
            r["model"] = Path(a.model).name
            key = f"{name}/{config}{a.tag}"
            results[key] = r
            print(f"{key:40s} TP {r.get('tp_rate')}% FP {r.get('fp_rate')}% fps {r.get('fps')} ({r['wall_s']} s)",
                  flush=True)
            if a.out:
                Path(a.out).write_text(json.dumps(results, indent=1, sort_keys=True) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
