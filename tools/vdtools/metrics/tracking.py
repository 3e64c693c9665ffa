# SPDX-License-Identifier: MIT
"""Standard multi-object tracking metrics (CLEAR MOT's MOTA and ID switches, IDF1) through py-motmetrics, for
sequences whose annotations carry no object ids (HIT-UAV).

Ground-truth identities: each frame's vehicle boxes are linked to the previous frame's after compensating
the camera's motion (the drone moves 10-60 px between the frames of a sequence): the shift that the most box
pairs agree on (every pair of similar size proposes its centre displacement; a pair agrees when, shifted, it
overlaps with IoU >= 0.3), then greedy IoU >= 0.3 on the shifted boxes. Hypotheses: the detections with their
track ids (the JSON Lines "track"); a detection without a track (temporal analysis off) is its own identity.
Distance: 1 - IoU, pairs with IoU < 0.5 never match (the AP rule). Ignored ground truth (DontCare, persons)
is left out of both sides: a detection on an ignore region is dropped before matching.

The counts are additive over sequences (summed, then MOTA = 1 - (misses + false positives + switches) /
objects, IDF1 = 2 IDTP / (2 IDTP + IDFP + IDFN)), so a shard, a recording and a group are reported alike.
"""
import numpy as np

from vdtools.metrics.evaluate import inside_share, iou

COUNTS = ("num_objects", "num_misses", "num_false_positives", "num_switches", "idtp", "idfp", "idfn")


def _shift(b, dx, dy):
    return (b[0] + dx, b[1] + dy, b[2], b[3])


def _centre(b):
    return (b[0] + b[2] / 2.0, b[1] + b[3] / 2.0)


def camera_shift(prev, cur, thr=0.3):
    """(dx, dy) that the most boxes of prev, shifted, overlap a box of cur with (IoU >= thr); (0, 0) if none."""
    best, bshift = 0, (0.0, 0.0)
    for p in prev:
        for c in cur:
            if not (0.5 <= c[2] / max(p[2], 1) <= 2 and 0.5 <= c[3] / max(p[3], 1) <= 2):
                continue
            dx, dy = _centre(c)[0] - _centre(p)[0], _centre(c)[1] - _centre(p)[1]
            n = sum(1 for q in prev if any(iou(_shift(q, dx, dy), k) >= thr for k in cur))
            if n > best or (n == best and abs(dx) + abs(dy) < abs(bshift[0]) + abs(bshift[1])):
                best, bshift = n, (dx, dy)
    return bshift if best else (0.0, 0.0)


def gt_tracks(frames_boxes, thr=0.3):
    """Per frame: GT track ids (1..) parallel to its vehicle boxes, linked across the camera's motion."""
    ids, nxt, prev = [], 1, []
    for boxes in frames_boxes:
        cur = [0] * len(boxes)
        dx, dy = camera_shift([p[0] for p in prev], boxes, thr) if prev and boxes else (0.0, 0.0)
        pairs = sorted(((iou(_shift(p[0], dx, dy), b), i, j) for i, b in enumerate(boxes) for j, p in enumerate(prev)),
                       reverse=True)
        used_i, used_j = set(), set()
        for v, i, j in pairs:
            if v < thr or i in used_i or j in used_j:
                continue
            cur[i] = prev[j][1]
            used_i.add(i)
            used_j.add(j)
        for i in range(len(cur)):
            if not cur[i]:
                cur[i] = nxt
                nxt += 1
        ids.append(cur)
        prev = list(zip(boxes, cur))
    return ids


def _ignored(box, ignore):
    return any(iou(box, g) >= 0.5 or inside_share(box, g) >= 0.5 for g in ignore)


def sequence_counts(frames, keep=None):
    """MOT counts of one sequence (tracker reset before it). frames: [(vehicles [(x, y, w, h)], ignore boxes,
    detections [{"box", "track"}])] in time order; keep(det) -> bool selects the hypotheses (default all)."""
    import motmetrics as mm
    acc = mm.MOTAccumulator(auto_id=True)
    gids = gt_tracks([f[0] for f in frames])
    fresh = 10 ** 9   # ids of detections without a track: one identity each
    for (veh, ign, dets), g in zip(frames, gids):
        hyp, hid = [], []
        for d in dets:
            if keep is not None and not keep(d):
                continue
            if _ignored(tuple(d["box"]), ign) and not any(iou(tuple(d["box"]), v) >= 0.5 for v in veh):
                continue
            hyp.append(tuple(d["box"]))
            if d.get("track") is None:
                fresh += 1
                hid.append(fresh)
            else:
                hid.append(int(d["track"]))
        dist = np.full((len(veh), len(hyp)), np.nan)
        for i, v in enumerate(veh):
            for j, h in enumerate(hyp):
                o = iou(v, h)
                if o >= 0.5:
                    dist[i, j] = 1.0 - o
        acc.update(g, hid, dist)
    mh = mm.metrics.create()
    s = mh.compute(acc, metrics=list(COUNTS), name="s")
    return {k: int(s[k].iloc[0]) for k in COUNTS}


def add_counts(a, b):
    return {k: a.get(k, 0) + b.get(k, 0) for k in COUNTS}


def scores(c):
    """MOTA, IDF1 and ID switches of summed counts (None without objects / identities)."""
    n = c.get("num_objects", 0)
    mota = 1.0 - (c["num_misses"] + c["num_false_positives"] + c["num_switches"]) / n if n else None
    den = 2 * c.get("idtp", 0) + c.get("idfp", 0) + c.get("idfn", 0)
    return dict(mota=mota, idf1=2 * c["idtp"] / den if den else None, id_switches=c.get("num_switches", 0))
