# SPDX-License-Identifier: MIT
"""The evidence for the unlabelled resolution rule (vdtools.adapt.measure.choose_resolution, vd_fir_demo
--cnn-full-res auto), on recordings as the demo meets them: each scene group of ../shared/data's train or val
split with at least 16 frames (a HIT-UAV flight, an MSRS group of 40 numbers) is one recording, its first 32
frames in name order (the demo's window, tools/demo/common/flipagree.h), as they are and under camera changes
(cnn_eval.PERTURB / RESCALE, chained with '+'). Per recording: the shipped pair's AP@0.5 at half and at full
resolution on those frames (the truth) against what each unlabelled measure would choose: the flip
agreement, the mean box score and the rating (mean score + w x agreement). The rule is chosen on train and
val; the test split is run once afterwards, to report it (docs/results/cameras.md, "The rule of 2026-11-30").

    python3 -m vdtools.adapt.resolution_evidence --split val --out val.json
    python3 -m vdtools.adapt.resolution_evidence --split train --out train.json
    python3 -m vdtools.adapt.resolution_evidence --render val.json train.json
"""
import argparse
import json
from pathlib import Path

from vdtools.adapt import measure as M
from vdtools.bindings import clib
from vdtools.bindings.detector import CNN_RES_NAMES
from vdtools.data import cnn_data as CD
from vdtools.evaluation import cnn_eval as CE
from vdtools.metrics.evaluate import first_highest

SHIFTS = ("none", "down50", "down33", "equalize", "equalize+down50")
WINDOW, MIN_FRAMES = 32, 16   # tools/demo/common/flipagree.h DEMO_AUTORES_MAX_FRAMES / _MIN_FRAMES
MODELS = [str(clib.REPO / "models" / "vd_cnn.vdm"), str(clib.REPO / "models" / "vd_cnn2.vdm")]


def load_rows(paths):
    """The rows of one or more --out files, merged (their keys name split, family, group and change)."""
    rows = {}
    for p in paths:
        rows.update(json.loads(Path(p).read_text()))
    return rows


def shifted(frames, shift):
    for name in ([] if shift == "none" else shift.split("+")):
        frames = CE.perturb(frames, name)
    return frames


def measures(models, frames, thr, full_res):
    """AP@0.5 (fused flip passes, every peak), the flip agreement and the mean box score (None: no box)."""
    runs = M.flip_runs(models, frames, full_res)
    return dict(ap=M.figures(M.detections(models, frames, full_res=full_res), thr)["ap"],
                agreement=M.flip_agreement(models, frames, thr, runs=runs),
                score=M.mean_box_score(models, frames, thr, runs=runs))


def rate(m, weight):
    """A resolution's measure under a rule: weight None is the flip agreement alone, 0 the mean box score
    alone, else mean score + weight x agreement; no box rates 0 (no evidence)."""
    if m["score"] is None:
        return 0.0
    return m["agreement"] if weight is None else M.rating_of(m["score"], m["agreement"], weight)


def resolutions(row):
    """The resolutions a row measured, in cfg.cnn_res order (half first: it wins ties)."""
    return [r for r in CNN_RES_NAMES if r in row]


def choose_res(row, weight):
    """The resolution the rule would take: the highest rate, ties to the earlier (half first)."""
    res = resolutions(row)
    return res[first_highest([rate(row[r], weight) for r in res])]


def best_res(row):
    """The resolution of the highest AP@0.5 (ties to the earlier)."""
    res = resolutions(row)
    return res[first_highest([row[r]["ap"] for r in res])]


def choose(row, weight):
    """Half / full only: True for full (the rule of --cnn-full-res auto)."""
    return rate(row["full"], weight) > rate(row["half"], weight)


def rule_name(w):
    return "flip agreement" if w is None else ("mean box score" if w == 0 else f"score + {w:g} x agreement")


def with_vehicles(rows):
    """The recordings with a vehicle (an AP at every resolution measured; NaN without)."""
    return {k: v for k, v in rows.items() if all(v[r]["ap"] == v[r]["ap"] for r in resolutions(v))}


def summary(rows, weights=(None, 0.0, 0.0625, 0.125, 0.25, 0.5)):
    """Per rule: recordings chosen right, mean AP@0.5 of the chosen resolution, AP points lost to wrong
    choices, and the same per camera change. Recordings without a vehicle (no AP) are left out."""
    rows = with_vehicles(rows)
    out = {}
    for w in weights:
        right, ap, lost, per = 0, 0.0, 0.0, {}
        for k, v in rows.items():
            pick, best = choose_res(v, w), best_res(v)
            got = v[pick]["ap"]
            loss = v[best]["ap"] - got
            right += pick == best
            ap += got
            lost += loss
            sh = k.split(" ")[-1]
            p = per.setdefault(sh, [0, 0, 0.0])
            p[0] += pick == best
            p[1] += 1
            p[2] += loss
        out[rule_name(w)] = dict(right=right, n=len(rows), mean_ap=ap / max(len(rows), 1), lost=lost, per_shift=per)
    return out


def render(rows):
    s = summary(rows)
    shifts = list(next(iter(s.values()))["per_shift"])
    lines = ["| rule | right | mean AP@0.5 of the choice | AP points lost | " + " | ".join(shifts) + " |",
             "|---|---:|---:|---:|" + "---|" * len(shifts)]
    for name, v in s.items():
        lines.append(f"| {name} | {v['right']} / {v['n']} | {100 * v['mean_ap']:.1f} | {100 * v['lost']:.0f} | "
                     + " | ".join(f"{p[0]}/{p[1]} ({100 * p[2]:.0f})" for p in v["per_shift"].values()) + " |")
    return "\n".join(lines)


def figure(rows, path, weight=0.25):
    """Two panels, the agreement alone and the rating: per recording the measure's full - half against AP@0.5's
    full - half. A point in the upper right or lower left is a right choice; the size of a wrong one's AP
    difference is what it cost."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    rows = with_vehicles(rows)
    shifts = sorted({k.split(" ")[-1] for k in rows}, key=lambda x: SHIFTS.index(x) if x in SHIFTS else 99)
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.2), sharey=True)
    for ax, w in zip(axes, (None, weight)):
        for sh in shifts:
            pts = [(rate(v["full"], w) - rate(v["half"], w), 100 * (v["full"]["ap"] - v["half"]["ap"]))
                   for k, v in rows.items() if k.endswith(" " + sh)]
            ax.scatter([p[0] for p in pts], [p[1] for p in pts], s=12, label=sh)
        ax.axhline(0, color="grey", lw=0.8)
        ax.axvline(0, color="grey", lw=0.8)
        right = sum(choose(v, w) == (v["full"]["ap"] > v["half"]["ap"]) for v in rows.values())
        ax.set_title(f"{rule_name(w)}: {right} / {len(rows)} right")
        ax.set_xlabel("measure, full - half")
    axes[0].set_ylabel("AP@0.5 points, full - half")
    axes[1].legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--split", choices=("train", "val", "test"),
                    help="train / val: where the rule is chosen; test: only to report, once, the rule chosen there")
    ap.add_argument("--shifts", default=",".join(SHIFTS), help="comma-separated camera changes, "
                    "each one of cnn_eval's or several joined by '+' (default: " + ",".join(SHIFTS) + ")")
    ap.add_argument("--resolutions", default="half,full", help="comma-separated, of half,full,quarter (cfg.cnn_res); "
                    "the rule takes the highest rating among them")
    ap.add_argument("--data", default=str(clib.DATA_DIR))
    ap.add_argument("--out", help="JSON of the figures per set")
    ap.add_argument("--render", nargs="+", metavar="JSON", help="print the table of one or more --out files")
    ap.add_argument("--figure", metavar="PNG", help="with --render: the scatter of the agreement and the rating")
    a = ap.parse_args(argv)
    if a.render:
        rows = load_rows(a.render)
        print(render(rows))
        if a.figure:
            figure(rows, a.figure)
        return 0
    if not a.split:
        ap.error("--split train|val|test (or --render)")
    thr = M.header_threshold(MODELS)
    frames = CD.load_frames(a.data, splits=(a.split,))
    groups = {}
    for f in sorted(frames, key=lambda f: (f.dataset, Path(f.path).name)):
        if CD.family(f) in ("msrs", "hit"):
            groups.setdefault((CD.family(f), f.group), []).append(f)
    rows = {}
    for (fam, group), fs in sorted(groups.items()):
        if len(fs) < MIN_FRAMES:
            continue
        for shift in a.shifts.split(","):
            part = shifted(fs[:WINDOW], shift)
            row = {res: measures(MODELS, part, thr, CNN_RES_NAMES.index(res)) for res in a.resolutions.split(",")}
            row["frames"], row["vehicles"] = len(part), int(sum(len(f.boxes) for f in part))
            key = f"{a.split} {fam} {group} {shift}"
            rows[key] = row
            res = a.resolutions.split(",")
            print(f"{key}: {len(part)} frames, {row['vehicles']} vehicles, AP " + " ".join(
                f"{r} {100 * row[r]['ap']:.1f}" for r in res) + "; score " + " / ".join(
                f"{row[r]['score'] or 0:.3f}" for r in res) + ", agreement " + " / ".join(
                f"{100 * (row[r]['agreement'] or 0):.1f}" for r in res), flush=True)
    if a.out:
        Path(a.out).write_text(json.dumps(rows, indent=1) + "\n")
    print(render(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
