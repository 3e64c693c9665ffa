# SPDX-License-Identifier: MIT
"""Which frames of a recording vd_fir_demo's --cnn-full-res auto should measure: its first 32 (the rule until
2026-11-30), or N spread over it (the middle frame of each of N equal parts; N = 64 since then:
vdtools.evaluation.fleet.auto_sample, tools/demo/common/flipagree.c demo_autores_sample). The rule itself (rating =
mean box score + flip agreement / 4, vdtools.adapt.resolution_evidence) is unchanged; only its window is.

On a split of ../shared/data (chosen on train and val; test only to report, once), per family (drone view, road
level) and camera change, every frame is measured once at both resolutions: the shipped pair's boxes with flip
passes (AP@0.5) and the rating's counts (boxes of the frame and its mirror image above the header threshold).
From those, two kinds of recordings are scored:

- scene recordings: each scene group with at least 16 frames (a HIT-UAV flight, an MSRS group of 40 numbers);
- the family's whole split as one folder, in name order (the form of a held-out set: `vd_fir_demo --input DIR`);
- multi-scene sets, the form of a held-out set or a user's folder of frames from many places: 2-8 scene groups
  of one family drawn at random (fixed seed), all their frames in name order, at least 40 frames.

A window chooses right when the resolution it rates higher has the higher AP@0.5 over the whole recording (what
the demo's run on it scores); a wrong choice costs the AP difference. The window 'all' (every frame) is the
reference a window of 32 can at best reach.

    python3 -m vdtools.adapt.window_evidence --split val --out val.json [--cache val.pkl]
    python3 -m vdtools.adapt.window_evidence --render val.json train.json
"""
import argparse
import json
import pickle
import random
from pathlib import Path

from vdtools.adapt import measure as M
from vdtools.adapt.resolution_evidence import MODELS, shifted
from vdtools.bindings import clib
from vdtools.data import cnn_data as CD
from vdtools.evaluation import cnn_eval as CE
from vdtools.evaluation import fleet

SHIFTS = ("none", "down50", "down33", "equalize", "equalize+down50")
FAMILIES = ("hit", "msrs")
FIRST, MIN_FRAMES = 32, fleet.AUTO_MIN_FRAMES   # the window until 2026-11-30: a recording's first 32 frames
SPREAD = (16, 24, 32, 48, 64, 96)                    # spread windows compared (64: fleet.AUTO_SPREAD_FRAMES)
DRAWS, MIN_SET_FRAMES, GROUPS = 200, 40, (2, 8)


def flip_counts(ra, rb, thr):
    """Per frame of M.flip_runs' two runs: qsum (the score_q8 sum of the boxes >= thr of the frame and its mirror
    image) and m (one_to_one of the two: matched, boxes; None without a box), the counts rating() pools."""
    per = []
    for fa, fb in zip(ra, rb):
        a = [x for x in fa[2] if x[1] >= thr]
        b = [x for x in fb[2] if x[1] >= thr]
        per.append(dict(qsum=sum(M.score_q8(s) for _, s in a + b),
                        m=M.one_to_one([x[0] for x in a], [x[0] for x in b], M.AGREE_IOU)))
    return per


def collect(frames, shift, thr):
    """{(shift, family, 'half'|'full'): [per frame in name order: name, group, dets, gts (for AP@0.5), qsum (the
    score_q8 sum of the boxes >= thr of the frame and its mirror image) and m (one_to_one of the two: matched,
    boxes; None without a box)]}."""
    out = {}
    for fam in FAMILIES:
        fs = [f for f in frames if CD.family(f) == fam]
        if not fs:
            continue
        part = shifted(fs, shift)
        for res in ("half", "full"):
            full = res == "full"
            det = M.detections(MODELS, part, full_res=full)
            counts = flip_counts(*M.flip_runs(MODELS, part, full), thr)
            out[(shift, fam, res)] = [dict(c, name=Path(f.path).name, group=str(f.group), dets=det[i][2],
                                           gts=det[i][3]) for i, (f, c) in enumerate(zip(fs, counts))]
            print(f"{shift} {fam} {res}: {len(fs)} frames", flush=True)
    return out


def rating(per, idx):
    """The rule's rating over frames idx (0 without a box: no evidence), as flipagree.c pools it."""
    m = b = q = 0
    for i in idx:
        if per[i]["m"] is not None:
            m, b, q = m + per[i]["m"][0], b + per[i]["m"][1], q + per[i]["qsum"]
    return M.rating_of(q / (255.0 * b), 2 * m / b) if b else 0.0


def ap(per, idx):
    return CE.average_precision([(per[i]["dets"], per[i]["gts"]) for i in idx])[0]


def windows(n):
    """Positions (in the recording) each window measures."""
    out = {"first 32": list(range(min(n, FIRST)))}
    out.update({f"spread {w}": fleet.auto_sample(n, w) for w in SPREAD})
    out["all"] = list(range(n))
    return out


def recordings(res, seed=0):
    """[(kind, shift, family, groups, frame indices)]: scene recordings, the family's whole split as one folder
    (what the demo meets on a held-out set) and multi-scene sets (the same draws for every camera change of a
    family)."""
    out = []
    for shift, fam in sorted({(s, f) for s, f, _ in res}):
        per = res[(shift, fam, "half")]
        groups = {}
        for i, p in enumerate(per):
            groups.setdefault(p["group"], []).append(i)
        out += [("scene", shift, fam, [g], idx) for g, idx in groups.items() if len(idx) >= MIN_FRAMES]
        out.append(("whole split", shift, fam, sorted(groups), list(range(len(per)))))
        rng, names, seen = random.Random(seed * 1000 + sum(map(ord, fam))), list(groups), set()
        for _ in range(DRAWS):
            pick = sorted(rng.sample(names, rng.randint(GROUPS[0], min(GROUPS[1], len(names)))))
            idx = sorted(i for g in pick for i in groups[g])
            if len(idx) >= MIN_SET_FRAMES and tuple(pick) not in seen:
                seen.add(tuple(pick))
                out.append(("multi-scene", shift, fam, pick, idx))
    return out


def score(res, recs):
    """Per recording: AP@0.5 at each resolution over all its frames and each window's ratings."""
    rows = []
    for kind, shift, fam, groups, idx in recs:
        H, F = res[(shift, fam, "half")], res[(shift, fam, "full")]
        ah, af = ap(H, idx), ap(F, idx)
        if ah != ah or af != af:   # no vehicle: no AP
            continue
        r = {w: [rating(H, [idx[i] for i in pos]), rating(F, [idx[i] for i in pos])]
             for w, pos in windows(len(idx)).items()}
        rows.append(dict(kind=kind, shift=shift, family=fam, groups=groups, frames=len(idx), ap=[ah, af], rating=r))
    return rows


def summary(rows):
    """{kind: {family: {window: dict(right, n, lost)}}}: a window is right when full rates higher exactly
    where full has the higher AP (at least MIN_FRAMES frames measured); lost = AP points of wrong choices."""
    out = {}
    for row in rows:
        best_full = row["ap"][1] > row["ap"][0]
        for w, (h, f) in row["rating"].items():
            full = len(windows(row["frames"])[w]) >= MIN_FRAMES and f > h
            fam = out.setdefault(row["kind"], {}).setdefault(row["family"], {})
            s = fam.setdefault(w, dict(right=0, n=0, lost=0.0))
            s["right"] += full == best_full
            s["n"] += 1
            s["lost"] += 100 * abs(row["ap"][1] - row["ap"][0]) * (full != best_full)
    return out


PHASES = (0.1, 0.3, 0.5, 0.7, 0.9)


def phase_loss(res, recs):
    """{size: AP points lost on the multi-scene sets, averaged over PHASES}: a spread window of `size` frames at
    positions int((k + u) n / size), u the phase (0.5 is the shipped sample's middle of each part), so that where a
    sample happens to fall in each part does not decide between two sizes."""
    out = {}
    for kind, shift, fam, groups, idx in recs:
        if kind != "multi-scene":
            continue
        H, F = res[(shift, fam, "half")], res[(shift, fam, "full")]
        ah, af = ap(H, idx), ap(F, idx)
        if ah != ah or af != af:
            continue
        n = len(idx)
        for w in SPREAD:
            for u in PHASES:
                sub = [idx[i] for i in (range(n) if n <= w else (int((k + u) * n / w) for k in range(w)))]
                wrong = (rating(F, sub) > rating(H, sub)) != (af > ah)
                out[w] = out.get(w, 0.0) + 100 * abs(af - ah) * wrong / len(PHASES)
    return out


def render(reports):
    ws = list(reports[0]["summary"].values())[0]
    ws = list(list(ws.values())[0])
    lines = ["| split | recordings | family | " + " | ".join(ws) + " |", "|---|---|---|" + "---:|" * len(ws)]
    for rep in reports:
        for kind, fams in rep["summary"].items():
            for fam, w in fams.items():
                lines.append(f"| {rep['split']} | {kind} | {fam} | "
                             + " | ".join(f"{w[k]['right']} / {w[k]['n']} ({w[k]['lost']:.0f})" for k in ws) + " |")
    lines.append("")
    lines.append("(right / recordings (AP@0.5 points lost to wrong choices))")
    if all("phase_loss" in r for r in reports):
        lines += ["", "| multi-scene sets, AP points lost averaged over the sample's phase | "
                  + " | ".join(f"spread {w}" for w in SPREAD) + " |", "|---|" + "---:|" * len(SPREAD)]
        for r in reports:
            lines.append(f"| {r['split']} | " + " | ".join(f"{r['phase_loss'][str(w)]:.0f}" for w in SPREAD) + " |")
    return "\n".join(lines)


def main(argv=None):
    ap_ = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap_.add_argument("--split", choices=("train", "val", "test"))
    ap_.add_argument("--shifts", default=",".join(SHIFTS), help="comma-separated camera changes (cnn_eval's, "
                     "joined by '+'; default " + ",".join(SHIFTS) + ")")
    ap_.add_argument("--data", default=str(clib.DATA_DIR))
    ap_.add_argument("--cache", help="pickle of the per-frame measures: read when it exists, else written")
    ap_.add_argument("--out", help="JSON: every recording's figures and the summary")
    ap_.add_argument("--render", nargs="+", metavar="JSON", help="print the table of one or more --out files")
    a = ap_.parse_args(argv)
    if a.render:
        print(render([json.loads(Path(p).read_text()) for p in a.render]))
        return 0
    if not a.split:
        ap_.error("--split train|val|test (or --render)")
    shifts = a.shifts.split(",")
    if a.cache and Path(a.cache).exists():
        with open(a.cache, "rb") as fh:
            res = pickle.load(fh)
        res = {k: v for k, v in res.items() if k[0] in shifts}
    else:
        thr = M.header_threshold(MODELS)
        frames = [f for f in CD.load_frames(a.data, splits=(a.split,)) if CD.family(f) in FAMILIES]
        frames.sort(key=lambda f: (CD.family(f), Path(f.path).name))
        res = {}
        for shift in shifts:
            res.update(collect(frames, shift, thr))
        if a.cache:
            with open(a.cache, "wb") as fh:
                pickle.dump(res, fh)
    recs = recordings(res)
    rows = score(res, recs)
    rep = dict(split=a.split, shifts=shifts, draws=DRAWS, summary=summary(rows),
               phase_loss={str(w): v for w, v in phase_loss(res, recs).items()}, recordings=rows)
    if a.out:   # one line per recording, figures to 4 places: the record stays small enough to commit
        r4 = lambda v: [round(x, 4) for x in v]
        lines = [json.dumps(dict(row, ap=r4(row["ap"]), rating={k: r4(v) for k, v in row["rating"].items()}))
                 for row in rows]
        head = json.dumps({k: v for k, v in rep.items() if k != "recordings"}, indent=1)
        Path(a.out).write_text(head[:-2] + ',\n "recordings": [\n' + ",\n".join(lines) + "\n ]\n}\n")
    print(render([rep]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
