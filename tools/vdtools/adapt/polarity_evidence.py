# SPDX-License-Identifier: MIT
"""Could vd_fir_demo choose a camera's polarity (white-hot or black-hot, `--cnn-polarity`) by itself, with the
rating its --cnn-full-res auto measurement computes (mean box score + flip agreement / 4, vdtools.adapt.measure)?

On a split of ../shared/data, per family and camera change (cnn_eval's, '+'-joined), every frame is measured at
half resolution as it is and inverted (255 - v): the shipped pair's boxes of the frame and its mirror image above
the header threshold. Per scene group (a HIT-UAV flight, an MSRS group) and for the whole split, the margin is
rating(as it is) - rating(inverted): every frame of ../shared/data is white-hot, so a rule "black-hot when the
inverted frames rate higher by more than m" is wrong on a group whose margin is below -m. Groups under 16 frames
are left out of the counts (the demo decides nothing on fewer: DEMO_AUTORES_MIN_FRAMES).

    python3 -m vdtools.adapt.polarity_evidence --split val --out ../docs/results/polarity_val.json
    python3 -m vdtools.adapt.polarity_evidence --split train --shifts none,down33,equalize --out …_train.json

--recordings: the rule over the resolutions too, on recordings as the demo meets them (resolution_evidence's:
each scene group of at least 16 frames, its first 32 frames in name order, as they are and under camera changes):
per recording the rating at each resolution of --resolutions, as it is and inverted. The rule "black-hot when
the highest rating of the inverted frames, over the resolutions, is above the highest of the frames as they
are" is wrong on a white-hot recording whose margin max(as is) - max(inverted) is below 0 and, the frames of a
black-hot camera being these frames inverted, misses that camera's recording for the same margin (up to the
rounding of the 2x2 mean, which the detector's cfg.cnn_invert applies after, these frames before).

    python3 -m vdtools.adapt.polarity_evidence --recordings --split val --out ../docs/results/polarity_res_val.json
"""
import argparse
import json
from pathlib import Path

import numpy as np

from vdtools.adapt import measure as M
from vdtools.adapt import window_evidence as W
from vdtools.adapt import resolution_evidence as R
from vdtools.adapt.resolution_evidence import MODELS, shifted
from vdtools.bindings import clib
from vdtools.bindings.detector import CNN_RES_NAMES
from vdtools.data import cnn_data as CD
from vdtools.evaluation import fleet
from vdtools.metrics.evaluate import first_highest

SHIFTS = ("none", "down50", "down33", "equalize")


def rating(models, frames, thr, res):
    """The demo's rating of frames at cfg.cnn_res res (mean box score + agreement / 4; 0 without a box), with
    the mean score and the agreement it comes from, and the number of boxes (frames and mirror images)."""
    runs = M.flip_runs(models, frames, res)
    m = dict(agreement=M.flip_agreement(models, frames, thr, runs=runs),
             score=M.mean_box_score(models, frames, thr, runs=runs),
             boxes=sum(1 for r in runs for _, _, d, _ in r for _, sc in d if sc >= thr))
    m["rating"] = R.rate(m, M.AGREE_WEIGHT)
    return m


def margins(row):
    """max over the resolutions of the rating as it is - the same inverted, and the configuration of the
    highest rating of all (resolution, 'inverted' or 'as is'; ties to as is and to the lower cfg.cnn_res)."""
    res = [r for r in CNN_RES_NAMES if r in row["as_is"]]
    a = [row["as_is"][r]["rating"] for r in res]
    b = [row["inverted"][r]["rating"] for r in res]
    best = first_highest(a + b)
    return max(a) - max(b), (res[best % len(res)], "inverted" if best >= len(res) else "as is")


def recordings(a, thr):
    frames = CD.load_frames(a.data, splits=(a.split,))
    groups = {}
    for f in sorted(frames, key=lambda f: (f.dataset, Path(f.path).name)):
        if CD.family(f) in W.FAMILIES:
            groups.setdefault((CD.family(f), f.group), []).append(f)
    rows = {}
    res = a.resolutions.split(",")
    for (fam, group), fs in sorted(groups.items()):
        if len(fs) < R.MIN_FRAMES:
            continue
        for shift in a.shifts.split(","):
            part = shifted(fs[:R.WINDOW], shift)
            row = dict(frames=len(part), vehicles=int(sum(len(f.boxes) for f in part)),
                       as_is={r: rating(MODELS, part, thr, CNN_RES_NAMES.index(r)) for r in res},
                       inverted={r: rating(MODELS, M.inverted(part), thr, CNN_RES_NAMES.index(r)) for r in res})
            row["margin"], row["choice"] = margins(row)
            key = f"{a.split} {fam} {group} {shift}"
            rows[key] = row
            print(f"{key}: {len(part)} frames; rating as is " + " / ".join(
                f"{row['as_is'][r]['rating']:.3f}" for r in res) + ", inverted " + " / ".join(
                f"{row['inverted'][r]['rating']:.3f}" for r in res) + f" ({'/'.join(res)}); margin "
                f"{row['margin']:+.3f}, choice {row['choice'][0]} {row['choice'][1]}", flush=True)
    return rows


def render_recordings(rows):
    """Per camera change: recordings, how many the rule would turn black-hot (wrong: all are white-hot), the
    smallest margin, and the resolutions chosen."""
    per = {}
    for k, v in rows.items():
        p = per.setdefault(k.split(" ")[-1], [0, 0, [], {}])
        p[0] += 1
        p[1] += v["margin"] < 0
        p[2].append(v["margin"])
        p[3][v["choice"][0]] = p[3].get(v["choice"][0], 0) + 1
    lines = ["| camera change | recordings | rated higher inverted | smallest margin | resolution of the highest rating |",
             "|---|---:|---:|---:|---|"]
    for sh, p in per.items():
        lines.append(f"| {sh} | {p[0]} | {p[1]} | {min(p[2]):+.3f} | "
                     + ", ".join(f"{r} {n}" for r, n in sorted(p[3].items())) + " |")
    return "\n".join(lines)


def figure(rows, path, margin):
    """Each recording x camera change's margin (best rating as it is - best inverted), by split and whether it
    has vehicles, against the rule's margin: a point left of -margin is a white-hot recording the rule turns, one
    left of +margin a black-hot recording (the same frames inverted) it leaves as it is."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    splits = sorted({k.split(" ")[0] for k in rows}, key=lambda x: ("train", "val", "test").index(x))
    fig, ax = plt.subplots(figsize=(9, 2.6))
    rng = np.random.default_rng(0)
    for i, sp in enumerate(splits):
        for veh, mk in ((True, "o"), (False, "x")):
            m = [v["margin"] for k, v in rows.items() if k.startswith(sp + " ") and (v["vehicles"] > 0) == veh]
            if m:
                ax.scatter(m, i + rng.uniform(-0.25, 0.25, len(m)), s=10, marker=mk, alpha=0.6,
                           label=f"{sp}{'' if veh else ', no vehicle'} ({len(m)})")
    for x, ls in ((margin, "--"), (-margin, ":")):
        ax.axvline(x, color="k", lw=0.8, ls=ls)
    ax.set_yticks(range(len(splits)))
    ax.set_yticklabels(splits)
    ax.set_xlabel("best rating as they are - best rating inverted (over half, full, quarter)")
    ax.legend(fontsize=7, loc="upper right", ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--split", choices=("train", "val", "test"))
    ap.add_argument("--shifts", default=",".join(SHIFTS))
    ap.add_argument("--data", default=str(clib.DATA_DIR))
    ap.add_argument("--out", help="JSON: per shift and family, every group's margin and the counts")
    ap.add_argument("--recordings", action="store_true", help="the rule over the resolutions, per recording")
    ap.add_argument("--resolutions", default="half,full,quarter", help="with --recordings: of half,full,quarter")
    ap.add_argument("--render", nargs="+", metavar="JSON", help="print the table of --recordings --out files")
    ap.add_argument("--figure", metavar="PNG", help="with --render: the margins against the rule's")
    a = ap.parse_args(argv)
    if a.render:
        rows = R.load_rows(a.render)
        print(render_recordings(rows))
        if a.figure:
            figure(rows, a.figure, fleet.AUTO_INVERT_MARGIN)
        return 0
    if not a.split:
        ap.error("--split train|val|test (or --render)")
    thr = M.header_threshold(MODELS)
    if a.recordings:
        rows = recordings(a, thr)
        if a.out:
            Path(a.out).write_text(json.dumps(rows, indent=1) + "\n")
        print(render_recordings(rows))
        return 0
    frames = [f for f in CD.load_frames(a.data, splits=(a.split,)) if CD.family(f) in W.FAMILIES]
    frames.sort(key=lambda f: (CD.family(f), Path(f.path).name))
    rows = []
    for shift in a.shifts.split(","):
        for fam in W.FAMILIES:
            fs = [f for f in frames if CD.family(f) == fam]
            if not fs:
                continue
            part = shifted(fs, shift)
            white = W.flip_counts(*M.flip_runs(MODELS, part, False), thr)
            black = W.flip_counts(*M.flip_runs(MODELS, M.inverted(part), False), thr)
            groups = {}
            for i, f in enumerate(fs):
                groups.setdefault(str(f.group), []).append(i)
            margins = {g: round(W.rating(white, idx) - W.rating(black, idx), 4) for g, idx in groups.items()}
            big = {g: m for g, m in margins.items() if len(groups[g]) >= fleet.AUTO_MIN_FRAMES}
            whole = list(range(len(fs)))
            row = dict(shift=shift, family=fam, frames=len(fs), groups=len(groups), groups_16=len(big),
                       inverted_higher_16=sorted(g for g, m in big.items() if m < 0),
                       smallest_margin_16=min(big.values()) if big else None,
                       whole_split=[round(W.rating(white, whole), 4), round(W.rating(black, whole), 4)],
                       margins={g: [len(groups[g]), m] for g, m in sorted(margins.items())})
            rows.append(row)
            print(f"{a.split} {shift} {fam}: {len(big)} groups of >= {fleet.AUTO_MIN_FRAMES} frames, inverted rated "
                  f"higher in {len(row['inverted_higher_16'])} {row['inverted_higher_16']}; smallest margin "
                  f"{row['smallest_margin_16']}; whole split white-hot {row['whole_split'][0]:.3f}, inverted "
                  f"{row['whole_split'][1]:.3f}", flush=True)
    if a.out:
        Path(a.out).write_text(json.dumps(dict(split=a.split, rows=rows), indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
