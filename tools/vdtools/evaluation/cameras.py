# SPDX-License-Identifier: MIT
"""Proxies for "a camera the networks never saw" (docs/results/cameras.md): the detector's CNN source (a
network or the pair, fused flip passes, through the C library) on one split's frames as they are and as
other cameras would show them (cnn_eval.PERTURB / RESCALE: other AGC curves, contrast, blur, noise,
sharpening, smaller cars), AP@0.5 and TP / FP at one operating point per data set family.

    VD_LIB=../build/libvd.so python3 -m vdtools.evaluation.cameras --model ../models/vd_cnn.vdm \\
        --model2 ../models/vd_cnn2.vdm --split val --out cams.json

Why a proxy at all: the real other camera of the issue (a car-mounted FLIR Tau2) is not ours to have; a
user's camera never is. The synthetic changes are a proxy that a training augmentation of the same kind
(cnn_train --camera) can fit, so docs/results/cameras.md reads each lever on the changes it does not model
as well (gamma, contrast, blur, noise are the old augmentation's; equalize, clahe, bright, sharpen, down50 the
new one's).
"""
import argparse
import json
from pathlib import Path

from vdtools.bindings import clib
from vdtools.data import cnn_data as CD
from vdtools.evaluation import cnn_eval as E

SHIFTS = ["none"] + sorted(E.PERTURB) + sorted(E.RESCALE)


def measure(model, model2, frames, shifts=SHIFTS, thr=None):
    """{shift: {family: dict(ap, ap_out, tp_rate, fp_rate, n_vehicles)}} at thr (default: the operating point of
    the pair, i.e. model2's header threshold, or model's alone). ap ranks every box, ap_out the boxes >= thr (the
    detector's output at thr: what the other camera's AP 2.3 of issue 34 measured)."""
    first = E.Int8(model, "c", flip=True)
    pred = first if model2 is None else E.Pair(first, E.Int8(model2, "c", flip=True))
    hdr = (pred.nets[1] if model2 else first).desc
    if thr is None:
        thr = E.score_of_logit(hdr, hdr["score_threshold_q"]) / 32768.0
    out = {}
    for name in shifts:
        fs = frames if name == "none" else E.perturb(frames, name)
        rep = E.figures(E.run(pred, fs), [thr])
        out[name] = {fam: dict(ap=v["ap"], ap_out=v["at"][thr]["ap_out"], tp_rate=v["at"][thr]["tp_rate"],
                               fp_rate=v["at"][thr]["fp_rate"], n_vehicles=v["n_vehicles"]) for fam, v in rep.items()}
        print(name + ": " + ", ".join(f"{f} AP {100 * v['ap']:.1f} (output {100 * v['ap_out']:.1f}) "
                                      f"TP {100 * v['tp_rate']:.1f} % "
                                      f"FP {100 * v['fp_rate']:.1f} %" for f, v in out[name].items()), flush=True)
    return thr, out


def render(reports):
    """A markdown table of reports {label: measure()'s JSON}: one row per camera change, per report the
    drone / road AP@0.5 of every box, of the output when the report has it (reports before 2026-12-01 do not), and
    TP / FP at its threshold."""
    labels = list(reports)
    shifts = [s for s in SHIFTS if all(s in r["shifts"] for r in reports.values())]
    head = "| change | " + " | ".join(f"{k}: drone AP, TP/FP | {k}: road AP, TP/FP" for k in labels) + " |"
    rows = [head, "|---|" + "---:|" * (2 * len(labels))]
    for s in shifts:
        cells = []
        for k in labels:
            for fam in ("hit", "msrs"):
                v = reports[k]["shifts"][s].get(fam)
                out_ap = "" if v is None or "ap_out" not in v else f" (output {100 * v['ap_out']:.1f})"
                cells.append("–" if v is None else
                             f"{100 * v['ap']:.1f}{out_ap}, {100 * v['tp_rate']:.0f} / {100 * v['fp_rate']:.0f} %")
        rows.append(f"| {s} | " + " | ".join(cells) + " |")
    return "\n".join(rows)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--render", nargs="+", metavar="LABEL=JSON", help="print the markdown table of reports "
                    "written by --out, and nothing else")
    ap.add_argument("--model")
    ap.add_argument("--model2", help="the pair's second network")
    ap.add_argument("--split", default="val", choices=("val", "test"))
    ap.add_argument("--thr", type=float, help="score threshold (default: the header's, as the detector)")
    ap.add_argument("--shift", action="append", choices=SHIFTS, help="only these (repeatable)")
    ap.add_argument("--data", default=str(clib.REPO.parent / "shared" / "data"))
    ap.add_argument("--out", help="JSON report")
    a = ap.parse_args(argv)
    if a.render:
        print(render({k: json.loads(Path(v).read_text()) for k, v in (r.split("=", 1) for r in a.render)}))
        return
    if not a.model:
        ap.error("--model is required (or --render)")
    frames = CD.load_frames(a.data, splits=(a.split,))
    thr, res = measure(a.model, a.model2, frames, a.shift or SHIFTS, a.thr)
    if a.out:
        Path(a.out).write_text(json.dumps(dict(model=a.model, model2=a.model2, split=a.split, thr=thr,
                                               shifts=res), indent=1) + "\n")


if __name__ == "__main__":
    main()
