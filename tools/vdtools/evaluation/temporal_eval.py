# SPDX-License-Identifier: MIT
"""Temporal analysis on real video: the HIT-UAV sequence-0_100 flight (91 frames in time order, test only)
through vd_fir_demo with --temporal on and off (docs/results/detector.md, "Temporal analysis").

Reports per run: detections, share by state (new / confirmed / recovered), distinct track ids, TP and FP
rates (the demo's matching rules), and track-id switches. The annotations carry no object ids, so ground-
truth tracks are built by linking each frame's vehicle boxes to the previous frame's by greedy IoU >= 0.3
(the flight moves slowly between samples); a switch is a ground-truth track whose matched detection
changes track id between two consecutive frames in which it is matched.

    python3 -m vdtools.evaluation.temporal_eval --demo build/tools/vd_fir_demo --model models/vd_cnn.vdm [--extra "..."]
"""
import argparse
import json
import shlex
import subprocess
from pathlib import Path

from vdtools.bindings import clib
from vdtools.data import dataset as D
from vdtools.metrics.evaluate import iou, match_flags


def gt_tracks(frames):
    """Per frame: list of GT track ids (parallel to frame.vehicles)."""
    ids, nxt, prev = [], 1, []
    for fr in frames:
        cur = [0] * len(fr.vehicles)
        pairs = sorted(((iou(b, p[0]), i, j) for i, b in enumerate(fr.vehicles) for j, p in enumerate(prev)),
                       reverse=True)
        used_i, used_j = set(), set()
        for v, i, j in pairs:
            if v < 0.3 or i in used_i or j in used_j:
                continue
            cur[i] = prev[j][1]
            used_i.add(i)
            used_j.add(j)
        for i in range(len(cur)):
            if not cur[i]:
                cur[i] = nxt
                nxt += 1
        ids.append(cur)
        prev = list(zip(fr.vehicles, cur))
    return ids


def _repo_relative(arg):
    p = Path(arg)
    return str(p.relative_to(clib.REPO)) if p.is_absolute() and p.is_relative_to(clib.REPO) else arg


def run(demo, model, data_dir, temporal, extra=(), tmp="out/temporal_eval"):
    _, seq = D.load_hit(data_dir)
    seq = sorted(seq, key=lambda f: f.name)
    tmp = Path(tmp)
    tmp.mkdir(parents=True, exist_ok=True)
    lst = tmp / "seq.txt"
    lst.write_text("".join(f"{Path(f.path).resolve()}\n" for f in seq))
    js = tmp / f"seq_{temporal}.jsonl"
    cmd = [str(demo), "--input", str(lst), "--model", str(model), "--temporal", temporal, "--json", str(js),
           "--quiet"] + list(extra)
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    recs = {Path(json.loads(l)["frame"]).name: json.loads(l) for l in js.read_text().splitlines()}
    gid = gt_tracks(seq)
    n = dict(detections=0, new=0, confirmed=0, recovered=0, tp=0, fp=0, vehicles=0, confirmed_tp=0, confirmed_fp=0)
    tracks, last = set(), {}
    switches = 0
    for fr, ids in zip(seq, gid):
        dets = recs[fr.name]["detections"]
        n["detections"] += len(dets)
        for d in dets:
            n[d["state"]] = n.get(d["state"], 0) + 1
            if d["track"] is not None:
                tracks.add(d["track"])
        gts = [tuple(b) + (True, False) for b in fr.vehicles] + [tuple(b) + (False, True) for b in fr.ignore]
        flags, _ = match_flags([(tuple(d["box"]), d["score"]) for d in dets], gts)
        n["tp"] += sum(1 for _, f in flags if f == 1)
        n["fp"] += sum(1 for _, f in flags if f == 0)
        n["vehicles"] += len(fr.vehicles)
        # the confirmed detections alone: the high-confidence subset an application can use
        cflags, _ = match_flags([(tuple(d["box"]), d["score"]) for d in dets if d["state"] == "confirmed"], gts)
        n["confirmed_tp"] += sum(1 for _, f in cflags if f == 1)
        n["confirmed_fp"] += sum(1 for _, f in cflags if f == 0)
        # track of the detection matched to each GT box (best IoU >= 0.5)
        for b, g in zip(fr.vehicles, ids):
            best = max(((iou(tuple(d["box"]), b), d["track"]) for d in dets), default=(0, None),
                       key=lambda t: t[0])
            if best[0] >= 0.5 and best[1] is not None:
                if g in last and last[g] != best[1]:
                    switches += 1
                last[g] = best[1]
    n["track_ids"] = len(tracks)
    n["id_switches"] = switches
    n["gt_tracks"] = len({g for ids in gid for g in ids})
    n["tp_rate"] = n["tp"] / max(n["vehicles"], 1)
    n["fp_rate"] = n["fp"] / max(n["tp"] + n["fp"], 1)
    n["confirmed_share"] = n["confirmed"] / max(n["detections"], 1)
    n["confirmed_tp_rate"] = n["confirmed_tp"] / max(n["vehicles"], 1)
    n["confirmed_fp_rate"] = n["confirmed_fp"] / max(n["confirmed_tp"] + n["confirmed_fp"], 1)
    # recorded relative to the repository: the record must not carry this machine's paths
    n["command"] = " ".join(shlex.quote(_repo_relative(c)) for c in cmd)
    return n


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--demo", default=str(clib.REPO / "build" / "tools" / "vd_fir_demo"))
    ap.add_argument("--model", default=str(clib.REPO / "models" / "vd_cnn.vdm"))
    ap.add_argument("--data", default=str(clib.REPO.parent / "shared" / "data"))
    ap.add_argument("--extra", default="", help="more demo flags, e.g. \"--cnn-thr 0.3\"")
    ap.add_argument("--out", help="JSON record")
    a = ap.parse_args(argv)
    res = {t: run(a.demo, a.model, a.data, t, shlex.split(a.extra)) for t in ("off", "on")}
    for t, n in res.items():
        print(f"temporal {t}: {n['detections']} detections (new {n['new']}, confirmed {n['confirmed']}, "
              f"recovered {n['recovered']}), {n['track_ids']} track ids, {n['id_switches']} id switches "
              f"({n['gt_tracks']} GT tracks); TP {100 * n['tp_rate']:.1f} % FP {100 * n['fp_rate']:.1f} %; "
              f"confirmed only: TP {100 * n['confirmed_tp_rate']:.1f} % FP {100 * n['confirmed_fp_rate']:.1f} %")
    if a.out:
        Path(a.out).write_text(json.dumps(res, indent=1) + "\n")


if __name__ == "__main__":
    main()
