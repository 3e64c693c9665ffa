# SPDX-License-Identifier: MIT
"""Short real sequences in the HIT-UAV drone frames (issue 38): within a flight (`T_H_A` of
`T_H_A_W_ID.jpg`), frames whose index ID differs by <= max_gap (default 10) from the previous frame of the
flight form one sequence (consecutive views of one pass, a few source frames apart). A flight keeps its
split (vdtools.data.dataset.assign_splits), so every sequence has the split of its flight.

    python3 -m vdtools.data.sequences                       # per split: flights, sequences, frames, gaps
    python3 -m vdtools.data.sequences --split val --list    # one line per sequence: id, frames, index gaps
    python3 -m vdtools.data.sequences --split val --manifest out/seq-val
        writes out/seq-val/manifest.jsonl (one recording per sequence, for vdtools.evaluation.fleet
        --shard-frames 0: the tracker starts afresh on each) and out/seq-val/lists/<id>.lst

Sequences shorter than --min-len (default 2) are left out and counted as singletons. The flight
`sequence-0_100` (../shared/data/hit-uav/sequence-0_100, test only) is one sequence of its own and is
listed under the split "test" as `seq-0_100` with --with-0-100.
"""
import argparse
import json
import sys
from pathlib import Path

from vdtools.bindings import clib
from vdtools.data import dataset as D

MAX_GAP = 10
MIN_LEN = 2


def frame_index(name):
    """ID of `T_H_A_W_ID.jpg` (int)."""
    return int(Path(name).stem.split("_")[4])


def flight_of(name):
    return "_".join(Path(name).stem.split("_")[:3])


def find_sequences(frames, split_of=None, max_gap=MAX_GAP, min_len=MIN_LEN):
    """(sequences, singletons) of the HIT-UAV frames in `frames` (vdtools.data.dataset frames; other data sets
    are skipped). A sequence: dict(id, flight, split, frames (in index order), indices, gaps (index differences
    between consecutive frames)). split_of: {group: split} (default assign_splits(frames)). Ordered by split,
    flight, first index; singletons: the frames of runs shorter than min_len."""
    split_of = split_of if split_of is not None else D.assign_splits(frames)
    flights = {}
    for f in frames:
        if f.dataset != "hit":
            continue
        flights.setdefault(flight_of(f.name), []).append(f)
    seqs, single = [], []
    for fl in sorted(flights):
        fs = sorted(flights[fl], key=lambda f: frame_index(f.name))
        runs = [[fs[0]]]
        for f in fs[1:]:
            if frame_index(f.name) - frame_index(runs[-1][-1].name) <= max_gap:
                runs[-1].append(f)
            else:
                runs.append([f])
        for r in runs:
            if len(r) < min_len:
                single += r
                continue
            idx = [frame_index(f.name) for f in r]
            seqs.append(dict(id=f"{fl}-{idx[0]:05d}", flight=fl, split=split_of[fs[0].group], frames=r, indices=idx,
                             gaps=[b - a for a, b in zip(idx, idx[1:])]))
    order = {"train": 0, "val": 1, "test": 2}
    seqs.sort(key=lambda s: (order.get(s["split"], 3), s["flight"], s["indices"][0]))
    return seqs, single


def sequence_0_100(data_dir):
    """The shared flight sequence-0_100 as one sequence (test), or None when absent."""
    p = Path(data_dir) / "hit-uav" / "sequence-0_100" / "annotations.json"
    if not p.exists():
        return None
    _, fs = D.load_hit(data_dir)
    fs = sorted(fs, key=lambda f: f.name)
    idx = [frame_index(f.name) for f in fs]
    return dict(id="seq-0_100", flight=flight_of(fs[0].name), split="test", frames=fs, indices=idx,
                gaps=[b - a for a, b in zip(idx, idx[1:])], gt="hit-uav/sequence-0_100/annotations.json")


def load(data_dir, split=None, max_gap=MAX_GAP, min_len=MIN_LEN, with_0_100=False):
    """Sequences of ../shared/data (optionally one split) and the singletons."""
    frames = D.all_frames(data_dir, synth=False)
    seqs, single = find_sequences(frames, max_gap=max_gap, min_len=min_len)
    if with_0_100:
        s = sequence_0_100(data_dir)
        if s is not None:
            seqs.append(s)
    split_of = D.assign_splits(frames)
    if split is not None:
        seqs = [s for s in seqs if s["split"] == split]
        single = [f for f in single if split_of[f.group] == split]
    return seqs, single, split_of


def summary(seqs, single, split_of):
    """{split: dict(flights, sequences, frames, vehicles, singletons, gap histogram, lengths)}."""
    out = {}
    for s in seqs:
        r = out.setdefault(s["split"], dict(flights=set(), sequences=0, frames=0, vehicles=0, singletons=0, gaps={},
                                            min_len=None, max_len=0))
        r["flights"].add(s["flight"])
        r["sequences"] += 1
        r["frames"] += len(s["frames"])
        r["vehicles"] += sum(len(f.vehicles) for f in s["frames"])
        r["min_len"] = len(s["frames"]) if r["min_len"] is None else min(r["min_len"], len(s["frames"]))
        r["max_len"] = max(r["max_len"], len(s["frames"]))
        for g in s["gaps"]:
            r["gaps"][g] = r["gaps"].get(g, 0) + 1
    for f in single:
        sp = split_of[f.group]
        out.setdefault(sp, dict(flights=set(), sequences=0, frames=0, vehicles=0, singletons=0, gaps={}, min_len=None,
                                max_len=0))["singletons"] += 1
    for r in out.values():
        r["flights"] = len(r["flights"])
        r["gaps"] = dict(sorted(r["gaps"].items()))
    return out


def write_manifest(seqs, data_dir, out_dir):
    """out_dir/manifest.jsonl: one recording per sequence (a list file of its frame paths, read in place from
    ../shared/data, with its ground truth), for vdtools.evaluation.fleet --shard-frames 0. Returns its path."""
    data_dir, out_dir = Path(data_dir).resolve(), Path(out_dir).resolve()
    lists = out_dir / "lists"
    lists.mkdir(parents=True, exist_ok=True)
    rows = []
    for s in seqs:
        (lists / f"{s['id']}.lst").write_text("".join(f"{Path(f.path).resolve()}\n" for f in s["frames"]))
        gt = s.get("gt", "hit-uav/frames/annotations.json")
        rows.append(dict(id=s["id"], input=f"lists/{s['id']}.lst", gt=str(data_dir / gt), camera="hit-uav-seq",
                         daynight="day" if s["flight"].startswith("0_") else "night", split=s["split"],
                         flight=s["flight"]))
    m = out_dir / "manifest.jsonl"
    m.write_text("".join(json.dumps(r) + "\n" for r in rows))
    return m


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python3 -m vdtools.data.sequences", description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", default=str(clib.DATA_DIR))
    ap.add_argument("--split", choices=("train", "val", "test"), help="only this split")
    ap.add_argument("--max-gap", type=int, default=MAX_GAP, help="largest index difference within a sequence")
    ap.add_argument("--min-len", type=int, default=MIN_LEN, help="shortest sequence (frames)")
    ap.add_argument("--with-0-100", action="store_true", help="add the flight sequence-0_100 (test) as one sequence")
    ap.add_argument("--list", action="store_true", help="one line per sequence")
    ap.add_argument("--manifest", metavar="DIR", help="write DIR/manifest.jsonl for vdtools.evaluation.fleet")
    a = ap.parse_args(argv)
    seqs, single, split_of = load(a.data, a.split, a.max_gap, a.min_len, a.with_0_100)
    if a.list:
        for s in seqs:
            print(f"{s['split']:5s} {s['id']:22s} {len(s['frames']):3d} frames  "
                  f"{sum(len(f.vehicles) for f in s['frames']):4d} vehicles  gaps {s['gaps']}")
    for sp, r in sorted(summary(seqs, single, split_of).items(), key=lambda kv: ("train", "val", "test").index(kv[0])):
        print(f"{sp:5s}: {r['flights']} flights, {r['sequences']} sequences ({r['min_len']}-{r['max_len']} frames), "
              f"{r['frames']} frames, {r['vehicles']} vehicles; {r['singletons']} frames in no sequence; "
              f"index gaps {r['gaps']}")
    if a.manifest:
        print(write_manifest(seqs, a.data, a.manifest))
    return 0


if __name__ == "__main__":
    sys.exit(main())
