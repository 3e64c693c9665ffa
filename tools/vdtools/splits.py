# SPDX-License-Identifier: MIT
"""Test-split frame lists for vd_fir_demo --input, and the source-configuration evaluation of
docs/results/detector.md.

The split is vdtools.dataset.assign_splits (seed 0: groups MSRS number // 40, HIT-UAV T_H_A
flight; the sequence-0_100 flight is test only), i.e. the frames the verifier never trained on.

    python3 -m vdtools.splits --lists /tmp/vd-splits
        writes msrs_night.txt, msrs_day.txt, hit.txt, hit_night.txt, hit_day.txt, seq.txt
        (absolute frame paths, one per line) and prints the annotation path of each.
    python3 -m vdtools.splits --lists /tmp/vd-splits --run --demo build/tools/vd_fir_demo \\
        --model models/vd_dbn_grey.vdm --out docs/results/detector.json [--sets msrs_night,seq] [--configs ...]
        runs the demo with --eval for every set x source configuration (CONFIGS) and collects the
        Table 2 figures, frames/s and the median stage times into one JSON file.
"""
import argparse
import json
import re
import shlex
import subprocess
import sys
import time
from pathlib import Path

from vdtools import clib, dataset as D

SETS = ("msrs_night", "msrs_day", "hit", "hit_night", "hit_day", "seq")
# Per set: annotations (relative to the data dir) and the window preset (docs/demo.md --window-preset).
ANNOTATIONS = {"msrs": "msrs/labels", "hit": "hit-uav/frames/annotations.json",
               "seq": "hit-uav/sequence-0_100/annotations.json"}
PRESET = {"msrs": "msrs", "hit": "hit", "seq": "hit"}
# Source configurations: demo flags. "hotspot150" is paper 001's constant threshold; every other
# configuration uses the adaptive threshold (the detector's mode for AGC-scaled 8-bit video).
CONFIGS = {
    "hotspot150": ["--sources", "hotspot", "--thr-mode", "constant"],
    "hotspot": ["--sources", "hotspot", "--thr-mode", "adaptive"],
    "hotspot+contrast": ["--sources", "hotspot,contrast", "--thr-mode", "adaptive"],
    "hotspot+window": ["--sources", "hotspot,window", "--thr-mode", "adaptive", "--max-candidates", "256",
                       "--max-detections", "64"],
    "all": ["--sources", "all", "--thr-mode", "adaptive", "--max-candidates", "256", "--max-detections", "64"],
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
    if "window" in config or config == "all":
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
    a = ap.parse_args(argv)
    paths = write_lists(a.data, a.lists)
    for name, (p, n) in paths.items():
        print(f"{name:11s} {n:4d} frames  {p}  (annotations {Path(a.data) / ANNOTATIONS[family(name)]})")
    if not a.run:
        return 0
    results = {}
    if a.out and Path(a.out).exists():
        results = json.loads(Path(a.out).read_text())
    for name in a.sets.split(","):
        for config in a.configs.split(","):
            cmd = demo_command(a.demo, paths[name][0], a.data, name, config, a.model)
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
