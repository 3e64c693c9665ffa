# SPDX-License-Identifier: MIT
"""Temporal analysis on real video through vd_fir_demo with --temporal on and off (docs/results/temporal.md):
the HIT-UAV flight sequence-0_100 (91 frames in time order, test only), or the short sequences of one split
(vdtools.data.sequences: frames of one flight whose index differs by <= 10), one demo run per sequence so
the tracker starts afresh on each.

Reports per run: detections, share by state (new / confirmed / recovered), distinct track ids, AP@0.5 (all
boxes pooled, by score), TP and FP rates (the demo's matching rules) of all boxes and of the confirmed ones
alone, and the tracking metrics MOTA, IDF1 and ID switches (py-motmetrics, vdtools.metrics.tracking: ground-
truth identities linked across the camera's motion) of all boxes and of the confirmed ones.

    python3 -m vdtools.evaluation.temporal_eval [--demo build/tools/vd_fir_demo] [--extra "..."]
    python3 -m vdtools.evaluation.temporal_eval --sequences val [--out FILE]
"""
import argparse
import json
import shlex
import subprocess
from pathlib import Path

from vdtools.bindings import clib
from vdtools.data import dataset as D
from vdtools.metrics import tracking as T
from vdtools.metrics.evaluate import ap_from_flags, match_flags


def _repo_relative(arg):
    p = Path(arg)
    return str(p.relative_to(clib.REPO)) if p.is_absolute() and p.is_relative_to(clib.REPO) else arg


def _run_demo(demo, frames, js, temporal, extra, model=None):
    lst = js.with_suffix(".lst")
    lst.write_text("".join(f"{Path(f.path).resolve()}\n" for f in frames))
    cmd = [str(demo), "--input", str(lst), "--temporal", temporal, "--json", str(js), "--quiet"]
    if model:
        cmd += ["--model", str(model)]
    cmd += list(extra)
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    recs = {}
    for line in js.read_text().splitlines():
        r = json.loads(line)
        recs[r["frame"]] = r["detections"]
    return recs, cmd


def gts_of(fr):
    """A sequence frame's ground truth for match_flags: vehicles, then ignore regions."""
    return [tuple(b) + (True, False) for b in fr.vehicles] + [tuple(b) + (False, True) for b in fr.ignore]


def evaluate(sequences):
    """Figures of [(frames, {frame name: detections})] (one entry per sequence, tracker reset before each)."""
    n = dict(sequences=len(sequences), frames=0, detections=0, new=0, confirmed=0, recovered=0, tp=0, fp=0,
             vehicles=0, confirmed_tp=0, confirmed_fp=0, track_ids=0)
    ap_flags, cap_flags = [], []
    mot_all, mot_conf = {}, {}
    for frames, recs in sequences:
        tracks = set()
        mot_frames = []
        for fr in frames:
            dets = recs[fr.name]
            n["frames"] += 1
            n["detections"] += len(dets)
            for d in dets:
                n[d["state"]] = n.get(d["state"], 0) + 1
                if d["track"] is not None:
                    tracks.add(d["track"])
            gts = gts_of(fr)
            flags, _ = match_flags([(tuple(d["box"]), d["score"]) for d in dets], gts)
            n["tp"] += sum(1 for _, f in flags if f == 1)
            n["fp"] += sum(1 for _, f in flags if f == 0)
            ap_flags += [(s, f) for s, f in flags if f is not None]
            n["vehicles"] += len(fr.vehicles)
            # the confirmed detections alone: the high-confidence subset an application acts on
            cflags, _ = match_flags([(tuple(d["box"]), d["score"]) for d in dets if d["state"] == "confirmed"], gts)
            n["confirmed_tp"] += sum(1 for _, f in cflags if f == 1)
            n["confirmed_fp"] += sum(1 for _, f in cflags if f == 0)
            cap_flags += [(s, f) for s, f in cflags if f is not None]
            mot_frames.append(([tuple(b) for b in fr.vehicles], [tuple(b) for b in fr.ignore], dets))
        n["track_ids"] += len(tracks)
        mot_all = T.add_counts(mot_all, T.sequence_counts(mot_frames))
        mot_conf = T.add_counts(mot_conf, T.sequence_counts(mot_frames, lambda d: d["state"] == "confirmed"))
    n["ap50"] = ap_from_flags(ap_flags, n["vehicles"])[0]
    n["confirmed_ap50"] = ap_from_flags(cap_flags, n["vehicles"])[0]
    n["tp_rate"] = n["tp"] / max(n["vehicles"], 1)
    n["fp_rate"] = n["fp"] / max(n["tp"] + n["fp"], 1)
    n["confirmed_share"] = n["confirmed"] / max(n["detections"], 1)
    n["confirmed_tp_rate"] = n["confirmed_tp"] / max(n["vehicles"], 1)
    n["confirmed_fp_rate"] = n["confirmed_fp"] / max(n["confirmed_tp"] + n["confirmed_fp"], 1)
    n["mot"] = dict(T.scores(mot_all), counts=mot_all)
    n["mot_confirmed"] = dict(T.scores(mot_conf), counts=mot_conf)
    return n


def run(demo, temporal, sequences, extra=(), model=None, tmp="out/temporal_eval"):
    """Runs the demo on each sequence [(id, frames)] and evaluates; returns the figures and the command of the
    first run (the others differ only in --input and --json)."""
    tmp = Path(tmp)
    tmp.mkdir(parents=True, exist_ok=True)
    done, cmd0 = [], None
    for sid, frames in sequences:
        recs, cmd = _run_demo(demo, frames, tmp / f"{sid}_{temporal}.jsonl", temporal, extra, model)
        cmd0 = cmd0 or cmd
        done.append((frames, recs))
    n = evaluate(done)
    # recorded relative to the repository: the record must not carry this machine's paths
    n["command"] = " ".join(shlex.quote(_repo_relative(c)) for c in cmd0)
    return n


def load_sequences(data_dir, split):
    """[(id, frames)]: the flight sequence-0_100 ("0_100"), or the sequences of a split ("train", "val",
    "test"; vdtools.data.sequences)."""
    if split == "0_100":
        _, seq = D.load_hit(data_dir)
        return [("seq-0_100", sorted(seq, key=lambda f: f.name))]
    from vdtools.data import sequences as S
    seqs, _, _ = S.load(data_dir, split)
    return [(s["id"], s["frames"]) for s in seqs]


def _pct(v):
    return "n/a" if v is None or v != v else f"{100 * v:.1f}"


def format_line(t, n):
    m, mc = n["mot"], n["mot_confirmed"]
    return (f"temporal {t}: {n['sequences']} sequences, {n['frames']} frames, {n['vehicles']} vehicles, "
            f"{n['detections']} detections (new {n['new']}, confirmed {n['confirmed']}, recovered {n['recovered']}), "
            f"{n['track_ids']} track ids\n"
            f"  all boxes: AP@0.5 {_pct(n['ap50'])}  TP {_pct(n['tp_rate'])} % FP {_pct(n['fp_rate'])} % "
            f"({n['tp']} / {n['fp']})  MOTA {_pct(m['mota'])}  IDF1 {_pct(m['idf1'])}  ID switches {m['id_switches']}\n"
            f"  confirmed: AP@0.5 {_pct(n['confirmed_ap50'])}  TP {_pct(n['confirmed_tp_rate'])} % "
            f"FP {_pct(n['confirmed_fp_rate'])} % ({n['confirmed_tp']} / {n['confirmed_fp']})  "
            f"MOTA {_pct(mc['mota'])}  IDF1 {_pct(mc['idf1'])}  ID switches {mc['id_switches']}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--demo", default=str(clib.REPO / "build" / "tools" / "vd_fir_demo"))
    ap.add_argument("--model", help="--model for the demo (default: the demo's own default, the CNN pair)")
    ap.add_argument("--data", default=str(clib.DATA_DIR))
    ap.add_argument("--sequences", default="0_100", choices=("0_100", "train", "val", "test"),
                    help="the flight sequence-0_100 (default) or the short sequences of a split")
    ap.add_argument("--temporal", default="off,on", help="runs, comma-separated (default off,on)")
    ap.add_argument("--extra", default="", help="more demo flags for every run, e.g. \"--cnn-thr 0.3\"")
    ap.add_argument("--extra-on", default="", help="more demo flags for the --temporal on run only")
    ap.add_argument("--tmp", default="out/temporal_eval", help="scratch directory (list files, JSON Lines)")
    ap.add_argument("--out", help="JSON record")
    a = ap.parse_args(argv)
    seqs = load_sequences(a.data, a.sequences)
    res = {}
    for t in a.temporal.split(","):
        extra = shlex.split(a.extra) + (shlex.split(a.extra_on) if t == "on" else [])
        res[t] = run(a.demo, t, seqs, extra, a.model, a.tmp)
        res[t]["sequences_of"] = a.sequences
        print(format_line(t, res[t]), flush=True)
    if a.out:
        Path(a.out).write_text(json.dumps(res, indent=1) + "\n")


if __name__ == "__main__":
    main()
