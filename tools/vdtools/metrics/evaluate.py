# SPDX-License-Identifier: MIT
"""Evaluation of detections against ground truth: the paper's Table 2 figures.

The same rules as vd_fir_demo --eval (tools/demo/eval.c), so the two can be
checked against each other and Python experiments report comparable numbers:

- ground truth: COCO-like JSON (boxes under "annotations" or, HIT-UAV's quirk,
  "annotation"; images with "filename" or "file_name") or a YOLO label folder
  (class xc yc w h, normalised; names from classes.txt beside or above it);
- vehicle classes: the given ids/names, else every category named car,
  othervehicle, vehicle, truck, bus or van (HIT-UAV: 1 Car, 3 OtherVehicle; the
  bundled clip: 1 Car), else 1 (COCO-like) / 2 (YOLO: MSRS car);
- ignore regions: categories named DontCare/ignore and iscrowd boxes;
- matching per frame: detections by score (descending, stable); each takes the
  unmatched vehicle box of highest IoU if IoU >= 0.5 (true positive); an
  unmatched detection with IoU >= 0.5 with an ignore region, or at least half
  inside one, is not counted; any other is a false positive;
- TP rate = matched vehicles / vehicles (recall), FP rate = false positives /
  counted detections (1 - precision), FPPI = false positives / frames.
  COCO-like: frames absent from "images" are not evaluated; YOLO: a frame
  without a label file has no objects.

    python3 -m vdtools.metrics.evaluate DETECTIONS.jsonl ANNOTATIONS [--classes 1,3]
"""
import argparse
import json
from pathlib import Path

VEHICLE_NAMES = {"car", "othervehicle", "other vehicle", "vehicle", "truck", "bus", "van"}
IGNORE_NAMES = {"dontcare", "dont care", "ignore"}


def iou(a, b):
    ax, ay, aw, ah = a
    bx, by, bw, bh = b
    if aw <= 0 or ah <= 0 or bw <= 0 or bh <= 0:
        return 0.0
    ix = min(ax + aw, bx + bw) - max(ax, bx)
    iy = min(ay + ah, by + bh) - max(ay, by)
    if ix <= 0 or iy <= 0:
        return 0.0
    inter = ix * iy
    return inter / (aw * ah + bw * bh - inter)


def rating_of(score, agreement, weight):
    """The rating of a mean box score and the flip agreement of the same boxes: score + weight x agreement, None
    without a box (score None). What --cnn-full-res auto compares (tools/demo/common/flipagree.c
    demo_autores_rating; vdtools.adapt.measure, vdtools.evaluation.fleet.auto_resolution)."""
    return None if score is None else score + weight * agreement


def first_highest(values):
    """The index of the highest value, ties to the lowest index; None counts 0 (a resolution without a box is no
    evidence for it). The choice of --cnn-full-res auto among ratings (tools/demo/common/flipagree.c
    demo_autores_decide; vdtools.evaluation.fleet.auto_resolution, vdtools.adapt.resolution_evidence)."""
    vals = [0.0 if v is None else v for v in values]
    return max(range(len(vals)), key=lambda k: (vals[k], -k))


def one_to_one(a, b, thr=0.5):
    """(matched, |a| + |b|) of two box lists [(x, y, w, h)], matched greedily one to one: each box of a in turn
    takes the unused box of b with the largest IoU (ties: the later one), counted when IoU >= thr; None when
    both lists are empty. The flip agreement of vd-adapt and vd_fir_demo --cnn-full-res auto (flipagree.c)."""
    if not a and not b:
        return None
    used, m = set(), 0
    for x in a:
        best = max(((iou(x, y), j) for j, y in enumerate(b) if j not in used), default=(0.0, None))
        if best[1] is not None and best[0] >= thr:
            used.add(best[1])
            m += 1
    return m, len(a) + len(b)


def _pick(classes, cats, fallback):
    if classes:
        out = []
        for tok in str(classes).split(","):
            tok = tok.strip()
            if tok.isdigit():
                out.append(int(tok))
            else:
                ids = [i for i, n in cats.items() if n.lower() == tok.lower()]
                if not ids:
                    raise ValueError(f"no class named {tok!r}")
                out.append(ids[-1])
        return set(out)
    picked = {i for i, n in cats.items() if n.lower() in VEHICLE_NAMES}
    return picked or {fallback}


class GroundTruth:
    """Boxes per frame name: {name: [(x, y, w, h, vehicle, ignore), ...]} in pixels
    (YOLO: normalised, scaled by the frame size in `boxes`)."""

    def __init__(self, path, classes=None):
        path = Path(path)
        self.yolo = path.is_dir()
        self.images = {}
        if self.yolo:
            cats = {}
            for cand in (path / "classes.txt", path.parent / "classes.txt"):
                if cand.is_file():
                    for k, line in enumerate(cand.read_text().splitlines()):
                        parts = line.split(None, 1)
                        if len(parts) == 2 and parts[0].isdigit():
                            cats[int(parts[0])] = parts[1].strip()
                        elif line.strip():
                            cats[k] = line.strip()
                    break
            self.classes = _pick(classes, cats, 2)
            for f in sorted(path.glob("*.txt")):
                if f.name == "classes.txt":
                    continue
                boxes = []
                for line in f.read_text().splitlines():
                    if not line.strip():
                        continue
                    c, xc, yc, w, h = line.split()[:5]
                    c, xc, yc, w, h = int(c), float(xc), float(yc), float(w), float(h)
                    boxes.append((xc - w / 2, yc - h / 2, w, h, c in self.classes, False))
                self.images[f.stem] = boxes
        else:
            doc = json.loads(path.read_text())
            cats = {c["id"]: c["name"] for c in doc.get("categories", []) if "id" in c and "name" in c}
            ignore = {i for i, n in cats.items() if n.lower() in IGNORE_NAMES}
            self.classes = _pick(classes, cats, 1)
            anns = doc.get("annotations", doc.get("annotation"))
            ids = {}
            for im in doc["images"]:
                name = Path(im.get("filename", im.get("file_name"))).name
                ids[im["id"]] = name
                self.images.setdefault(name, [])
            for a in anns:
                name = ids.get(a["image_id"])
                if name is None:
                    continue
                ign = a["category_id"] in ignore or bool(a.get("iscrowd", 0))
                veh = not ign and a["category_id"] in self.classes
                self.images[name].append(tuple(a["bbox"]) + (veh, ign))

    def boxes(self, frame_name, width, height):
        """The frame's boxes in pixels, or None when it is not annotated."""
        name = Path(frame_name).name
        if self.yolo:
            b = self.images.get(Path(name).stem, [])
            return [(x * width, y * height, w * width, h * height, v, i) for x, y, w, h, v, i in b]
        return self.images.get(name)


def match_frame(dets, gts):
    """dets: [(box, score)], gts: [(x, y, w, h, vehicle, ignore)] -> (tp, fp, ignored, n_vehicles)."""
    flags, _ = match_flags(dets, gts)
    tp = sum(1 for _, f in flags if f == 1)
    fp = sum(1 for _, f in flags if f == 0)
    return tp, fp, len(flags) - tp - fp, sum(1 for g in gts if g[4])


def evaluate_jsonl(jsonl, annotations, classes=None):
    """Evaluates a vd_fir_demo --json file; returns the same keys as --eval-out."""
    gt = GroundTruth(annotations, classes)
    tot = dict(frames=0, frames_not_annotated=0, vehicles=0, detections=0, ignored_detections=0, tp=0, fp=0)
    for line in Path(jsonl).read_text().splitlines():
        rec = json.loads(line)
        boxes = gt.boxes(rec["frame"], rec["width"], rec["height"])
        if boxes is None:
            tot["frames_not_annotated"] += 1
            continue
        tot["frames"] += 1
        tp, fp, ign, nv = match_frame([(d["box"], d["score"]) for d in rec["detections"]], boxes)
        tot["tp"] += tp
        tot["fp"] += fp
        tot["ignored_detections"] += ign
        tot["detections"] += tp + fp
        tot["vehicles"] += nv
    r = lambda a, b: a / b if b else 0.0
    tot.update(fn=tot["vehicles"] - tot["tp"], tp_rate=r(tot["tp"], tot["vehicles"]),
               fp_rate=r(tot["fp"], tot["detections"]), precision=r(tot["tp"], tot["detections"]),
               recall=r(tot["tp"], tot["vehicles"]), fppi=r(tot["fp"], tot["frames"]),
               classes=sorted(gt.classes))
    return tot


def main(argv=None):
    ap = argparse.ArgumentParser(description="Table 2 figures of a vd_fir_demo --json file")
    ap.add_argument("jsonl")
    ap.add_argument("annotations")
    ap.add_argument("--classes")
    a = ap.parse_args(argv)
    print(json.dumps(evaluate_jsonl(a.jsonl, a.annotations, a.classes), indent=1))


if __name__ == "__main__":
    main()


def inside_share(a, b):
    """Share of box a's area (x, y, w, h) that lies inside box b; 0 for an empty a."""
    ix = min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0])
    iy = min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1])
    return ix * iy / (a[2] * a[3]) if ix > 0 and iy > 0 and a[2] > 0 and a[3] > 0 else 0.0


def match_flags(dets, gts):
    """The rules of match_frame, per detection: dets [(box, score)], gts [(x, y, w, h, vehicle, ignore)]
    -> ([(score, flag)] with flag 1 = TP, 0 = FP, None = ignored), list of matched gt indices."""
    order = sorted(range(len(dets)), key=lambda i: (-dets[i][1], i))
    used = [False] * len(gts)
    out = []
    for i in order:
        box, score = dets[i]
        best, best_k = 0.0, -1
        for k, g in enumerate(gts):
            if not g[4] or used[k]:
                continue
            v = iou(box, g[:4])
            if v >= 0.5 and v > best:
                best, best_k = v, k
        if best_k >= 0:
            used[best_k] = True
            out.append((score, 1))
            continue
        ignored = False
        for g in gts:
            if not g[5]:
                continue
            if iou(box, g[:4]) >= 0.5 or inside_share(box, g[:4]) >= 0.5:
                ignored = True
                break
        out.append((score, None if ignored else 0))
    return out, [k for k in range(len(gts)) if used[k]]


def average_precision(frames):
    """AP@0.5 over frames [(dets, gts)] with the matching rules above (all detections of all frames
    pooled by score; all-point interpolated precision, as PASCAL VOC 2010+). Returns (ap, recall, precision)
    arrays for the PR curve."""
    flags = []
    n_pos = 0
    for dets, gts in frames:
        f, _ = match_flags(dets, gts)
        flags += [(s, t) for s, t in f if t is not None]
        n_pos += sum(1 for g in gts if g[4])
    if n_pos == 0:
        return float("nan"), [], []
    return ap_from_flags(flags, n_pos)


def ap_from_flags(flags, n_pos):
    """AP@0.5 of pooled [(score, 1 = TP / 0 = FP)] (ignored detections left out) over n_pos vehicles, as
    average_precision: (ap, recall, precision); ties keep the given order."""
    if n_pos == 0:
        return float("nan"), [], []
    flags = sorted(flags, key=lambda st: -st[0])
    tp = fp = 0
    rec, prec = [], []
    for _, t in flags:
        tp += t
        fp += 1 - t
        rec.append(tp / n_pos)
        prec.append(tp / (tp + fp))
    # all-point interpolation: precision envelope, summed over recall steps
    env = list(prec)
    for i in range(len(env) - 2, -1, -1):
        env[i] = max(env[i], env[i + 1])
    ap, last_r = 0.0, 0.0
    for r, p in zip(rec, env):
        ap += (r - last_r) * p
        last_r = r
    return ap, rec, prec
