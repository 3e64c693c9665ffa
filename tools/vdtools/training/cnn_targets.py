# SPDX-License-Identifier: MIT
"""Training crops and CenterNet targets of the CNN detector (cnn_train), numpy and OpenCV only, so that
tests run them without PyTorch: the .vdm input normalisation, AGC-like augmentation, the crop with its
rule for vehicles the crop cuts (split_cut), and the heatmap / size / offset targets."""
import math

import cv2
import numpy as np

from vdtools.data import cnn_data as CD
from vdtools.formats import cnn_ref
from vdtools.metrics.evaluate import iou

STRIDE = 4
CROP = 192
MIN_VISIBLE = 0.6           # a crop-cut vehicle with less of its area inside is an ignore region (split_cut)
SCALE = (0.6, 1.4)          # random rescale of the half-resolution frame (MSRS test cars are smaller than train)
SMALL_SCALE = (0.3, 0.6)    # cnn_train --small: the rescale that makes cars 10-30 px, as a wider lens shows them
PASTE_MAX = 3               # vehicles pasted into one frame (paste)
PASTE_TRIES = 10            # random spots tried per pasted vehicle
PASTE_MARGIN = 0.25         # context around a pasted vehicle, of its width / height
OBLIQUE_MAX_DEG = 40        # "oblique" drone views (frame_weights): the weakest angles (docs/results/detector.md)
NORM = dict(norm_lo_permille=10, norm_hi_permille=995, norm_min_range=48)


# ---------------------------------------------------------------- input normalisation

def stretch(img, lo_pm=NORM["norm_lo_permille"], hi_pm=NORM["norm_hi_permille"], min_range=NORM["norm_min_range"]):
    """The .vdm input_norm 1 percentile stretch (integer; the C module and cnn_ref do the same)."""
    n = img.size
    cum = np.cumsum(np.bincount(img.ravel(), minlength=256))
    lo = int(np.argmax(cum > (n * lo_pm) // 1000))
    k = (n * hi_pm) // 1000
    hi = int(np.argmax(cum > k)) if cum[-1] > k else 255
    r = max(hi - lo, min_range)
    p = img.astype(np.int64) - lo
    out = np.where(p <= 0, 0, np.minimum(255, (p * 510 + r) // (2 * r)))
    return out.astype(np.uint8)


def equalise(img):
    """The .vdm input_norm 2 histogram equalisation (integer; the C module and cnn_ref do the same): each grey
    level goes to the mid-rank of its pixels, round(255 * (2 * below + at) / (2 n)). Any strictly increasing
    tone curve of the camera leaves the result unchanged, which the percentile stretch (gain and offset only)
    does not: the other camera of docs/results/cameras.md differs from ours mostly in its AGC curve."""
    return cnn_ref.equalise_lut(img).astype(np.uint8)[img]


NORMS = {"stretch": stretch, "equalise": equalise}      # cnn_train --norm; the .vdm input_norm 1 and 2
NORM_CODE = {"stretch": 1, "equalise": 2}


def normalise(img, norm="stretch"):
    """img through the network's input normalisation (NORMS)."""
    return NORMS[norm](img)


# ---------------------------------------------------------------- augmentation and targets

def photometric(img, rng):
    """AGC-like changes on a uint8 half-resolution frame (before the stretch, as a camera would)."""
    x = img.astype(np.float32) / 255.0
    if rng.random() < 0.8:
        g = math.exp(rng.uniform(-0.5, 0.5))
        x = np.clip(x, 1e-4, 1) ** g                       # gamma
    if rng.random() < 0.8:
        x = x * rng.uniform(0.6, 1.4) + rng.uniform(-0.25, 0.25)   # gain / offset
    if rng.random() < 0.3:
        k = int(rng.choice([3, 5]))
        x = cv2.GaussianBlur(x, (k, k), rng.uniform(0.5, 1.5))
    if rng.random() < 0.5:
        x = x + rng.normal(0, rng.uniform(0.005, 0.03), x.shape).astype(np.float32)
    return np.clip(np.round(x * 255), 0, 255).astype(np.uint8)


def camera_shift(img, rng):
    """Another camera's picture of the same scene, on a uint8 half-resolution frame (cnn_train --camera): a
    different AGC tone curve (histogram equalisation, CLAHE, an S-curve, or a brighter gamma with the top
    clipped), then with probability 1/2 another texture (edge-preserving denoise, then an unsharp mask).
    Why: a user's camera differs from MSRS and HIT-UAV mostly in its AGC curve and its image processing (the
    car-mounted FLIR of docs/results/cameras.md is brighter, harder-curved and sharper); the AGC-like changes
    of photometric() are gentle affine/gamma ones and never change the local contrast or texture."""
    kind = int(rng.integers(4))
    x = img
    if kind == 0:                                   # global histogram equalisation, partly blended
        a = rng.uniform(0.5, 1.0)
        x = (1 - a) * x.astype(np.float32) + a * cv2.equalizeHist(x).astype(np.float32)
    elif kind == 1:                                 # local AGC (CLAHE)
        t = int(rng.choice([4, 8]))
        x = cv2.createCLAHE(clipLimit=float(rng.uniform(1.5, 4.0)), tileGridSize=(t, t)).apply(x).astype(np.float32)
    elif kind == 2:                                 # hard S-curve about a random mid level
        k, c = rng.uniform(4.0, 10.0), rng.uniform(0.3, 0.7)
        f = 1.0 / (1.0 + np.exp(-k * (np.arange(256) / 255.0 - c)))
        lut = (f - f[0]) / (f[-1] - f[0]) * 255.0
        x = lut[x].astype(np.float32)
    else:                                           # brighter, top clipped
        g = rng.uniform(0.35, 0.7)
        x = 255.0 * np.minimum(1.0, rng.uniform(1.0, 1.3) * (x / 255.0) ** g).astype(np.float32)
    x = np.clip(np.round(x), 0, 255).astype(np.uint8)
    if rng.random() < 0.5:
        x = cv2.bilateralFilter(x, 5, float(rng.uniform(15, 50)), 3.0)
        xf = x.astype(np.float32)
        xf = xf + rng.uniform(0.5, 1.5) * (xf - cv2.GaussianBlur(xf, (0, 0), rng.uniform(0.8, 1.5)))
        x = np.clip(np.round(xf), 0, 255).astype(np.uint8)
    return x


def paste(img, boxes, ign, donors, rng, n_max=PASTE_MAX, tries=PASTE_TRIES, keep_row=False):
    """Copy-paste augmentation on a half-resolution frame (cnn_train --paste): 1..n_max vehicles cut from
    other training frames of the same family (donors: frames with vehicles), each with a margin of
    PASTE_MARGIN of its size around it, rescaled by 0.8-1.25, mean-matched to the spot it lands on, blended
    in with a feathered edge, at a random spot where it touches no vehicle or ignore region (keep_row: at
    its own height in the frame, for road-level frames, whose cars stand on the road below the horizon of
    one fixed camera mount; drone views take any spot). Returns (img, boxes, ign) with the pasted vehicles
    appended to boxes. Why: the road-level training set has 603 cars
    in scenes of a few drives; the network fits them (train AP 81) far better than unseen scenes (val AP
    40), and pasting puts the same cars on other backgrounds."""
    img = img.astype(np.float32)
    H, W = img.shape
    boxes = [tuple(b) for b in np.asarray(boxes, np.float64).reshape(-1, 4)]
    for _ in range(int(rng.integers(1, n_max + 1))):
        d = donors[int(rng.integers(len(donors)))]
        src = CD.half(d.img).astype(np.float32)
        x, y, w, h = (d.boxes[int(rng.integers(len(d.boxes)))] * 0.5).tolist()
        mx, my = PASTE_MARGIN * w + 1, PASTE_MARGIN * h + 1
        x0, y0 = int(max(0, x - mx)), int(max(0, y - my))
        x1, y1 = int(min(src.shape[1], math.ceil(x + w + mx))), int(min(src.shape[0], math.ceil(y + h + my)))
        s = float(rng.uniform(0.8, 1.25))
        pw, ph = max(2, int(round((x1 - x0) * s))), max(2, int(round((y1 - y0) * s)))
        if pw >= W or ph >= H:
            continue
        patch = cv2.resize(src[y0:y1, x0:x1], (pw, ph), interpolation=cv2.INTER_LINEAR)
        nb = ((x - x0) * s, (y - y0) * s, w * s, h * s)     # the vehicle inside the patch
        for _t in range(tries):
            px, py = int(rng.integers(0, W - pw + 1)), int(rng.integers(0, H - ph + 1))
            if keep_row:
                py = int(np.clip(round((y0 + y1 - ph) / 2), 0, H - ph))
            box = (px + nb[0], py + nb[1], nb[2], nb[3])
            spot_box = (px, py, pw, ph)
            if all(iou(spot_box, tuple(b)) == 0.0 for b in list(boxes) + ign.reshape(-1, 4).tolist()):
                break
        else:
            continue
        spot = img[py:py + ph, px:px + pw]
        ring = np.concatenate([patch[0], patch[-1], patch[:, 0], patch[:, -1]])
        patch = patch + (float(spot.mean()) - float(ring.mean()))
        fy = np.minimum(np.arange(ph), np.arange(ph)[::-1]).astype(np.float32)
        fx = np.minimum(np.arange(pw), np.arange(pw)[::-1]).astype(np.float32)
        feather = max(1.0, 0.5 * min(mx, my) * s)
        a = np.clip(np.minimum(fy[:, None], fx[None, :]) / feather, 0, 1)
        img[py:py + ph, px:px + pw] = a * patch + (1 - a) * spot
        boxes.append(box)
    return (np.clip(np.round(img), 0, 255).astype(np.uint8), np.array(boxes, np.float32).reshape(-1, 4), ign)


def sample(fr, rng, crop=CROP, augment=True, cut_ignore=False, donors=None, paste_p=0.0, others=False,
           invert_p=0.0, inv_rng=None, camera_p=0.0, small_p=0.0, cam_rng=None, norm="stretch"):
    """One training crop: (stretched uint8 crop, boxes (N,4) in crop pixels, ignore boxes). cut_ignore: the
    split_cut rule for vehicles the crop cuts (cnn_train --cut-ignore); off, every vehicle whose centre is in
    the crop is a positive clipped to it and the others are background (the shipped models' recipe).
    donors, paste_p: copy-paste augmentation (paste) with probability paste_p. others: also return the
    frame's persons and bicycles (K, 5: box in crop pixels, class) by the positives' rule (cnn_train --aux);
    they draw no random numbers, so the crops are those of a run without them. invert_p: probability that
    the frame's polarity is inverted (255 - v, before the photometric changes; cnn_train --invert), drawn
    from inv_rng so that rng's crops stay those of a run without it. camera_p: probability of camera_shift
    (cnn_train --camera), small_p: probability that the rescale is drawn from SMALL_SCALE (--small), both
    drawn from cam_rng, so that rng's draws stay those of a run without them. norm: the network's input
    normalisation (NORMS), on the whole half-resolution frame as in the detector."""
    img = CD.half(fr.img)
    boxes = fr.boxes * 0.5
    ign = fr.ignore * 0.5
    fo = fr.others
    oth = fo[:, :4] * 0.5
    if augment and donors and rng.random() < paste_p:
        img, boxes, ign = paste(img, boxes, ign, donors, rng, keep_row=CD.family(fr) == "msrs")
    if augment and invert_p > 0 and inv_rng.random() < invert_p:
        img = 255 - img
    if augment and camera_p > 0 and cam_rng.random() < camera_p:
        img = camera_shift(img, cam_rng)
    if augment:
        img = photometric(img, rng)
    img = normalise(img, norm)
    s = rng.uniform(SCALE[0], SCALE[1]) if augment else 1.0
    if augment and small_p > 0 and cam_rng.random() < small_p:
        s = cam_rng.uniform(SMALL_SCALE[0], SMALL_SCALE[1])
    if s != 1.0:
        img = cv2.resize(img, (int(round(img.shape[1] * s)), int(round(img.shape[0] * s))),
                         interpolation=cv2.INTER_LINEAR if s > 1 else cv2.INTER_AREA)
        boxes, ign, oth = boxes * s, ign * s, oth * s
    if min(img.shape) < crop:   # black padding: what the network's zero padding shows at a frame edge
        img = np.pad(img, ((0, max(0, crop - img.shape[0])), (0, max(0, crop - img.shape[1]))))
    H, W = img.shape
    # crops centred on a vehicle half of the time (MSRS has many frames without one)
    if len(boxes) and rng.random() < 0.5:
        b = boxes[rng.integers(len(boxes))]
        cx, cy = b[0] + b[2] / 2 + rng.uniform(-crop / 3, crop / 3), b[1] + b[3] / 2 + rng.uniform(-crop / 3, crop / 3)
        x0, y0 = int(np.clip(cx - crop / 2, 0, W - crop)), int(np.clip(cy - crop / 2, 0, H - crop))
    else:
        x0, y0 = int(rng.integers(0, W - crop + 1)), int(rng.integers(0, H - crop + 1))
    img = img[y0:y0 + crop, x0:x0 + crop]
    def shift(bb):
        bb = bb.copy()
        if len(bb):
            bb[:, 0] -= x0
            bb[:, 1] -= y0
        return bb
    boxes, ign, oth = shift(boxes), shift(ign), shift(oth)
    if augment and rng.random() < 0.5:
        img = img[:, ::-1]
        for bb in (boxes, ign, oth):
            if len(bb):
                bb[:, 0] = crop - bb[:, 0] - bb[:, 2]
    pos, cut = split_cut(boxes, crop, MIN_VISIBLE if cut_ignore else 0.0)
    if not cut_ignore:
        cut = cut[:0]
    out = (np.ascontiguousarray(img), pos, np.concatenate([clip_boxes(ign, crop), cut]))
    if not others:
        return out
    kept = [np.append(b, c) for box, c in zip(oth, fo[:, 4])          # the positives' rule, in order
            for b in split_cut(box[None], crop, 0.0)[0]]
    return out + (np.array(kept, np.float32).reshape(-1, 5),)


def clip_boxes(bb, crop):
    """Boxes clipped to the crop; those with less than 1 px left on a side go."""
    out = []
    for x, y, w, h in bb:
        x1, y1 = min(crop, x + w), min(crop, y + h)
        x, y = max(0.0, x), max(0.0, y)
        if x1 - x >= 1 and y1 - y >= 1:
            out.append((x, y, x1 - x, y1 - y))
    return np.array(out, np.float32).reshape(-1, 4)


def split_cut(boxes, crop, min_visible=MIN_VISIBLE):
    """(positives, ignore regions) of the vehicles after cropping. A vehicle keeps its place as a positive
    (clipped to the crop) when its centre is inside the crop and at least min_visible of its area is;
    a vehicle the crop cuts more than that becomes an ignore region over its visible part. The network
    sees whole frames at run time, where only the frame edge cuts a vehicle and the annotation is cut there
    too: a crop-cut car is neither a vehicle with that box nor background, and training it as either
    taught the network low scores and part boxes on close road cars (docs/training.md)."""
    pos, cut = [], []
    for x, y, w, h in boxes.reshape(-1, 4).tolist():
        cl = clip_boxes(np.array([[x, y, w, h]], np.float32), crop)
        if not len(cl):
            continue
        cx, cy = x + w / 2, y + h / 2
        vis = float(cl[0, 2] * cl[0, 3]) / max(w * h, 1e-6)
        if 0 <= cx < crop and 0 <= cy < crop and vis >= min_visible:
            pos.append(cl[0])
        else:
            cut.append(cl[0])
    return np.array(pos, np.float32).reshape(-1, 4), np.array(cut, np.float32).reshape(-1, 4)


def _centre_gaussian(x, y, w, h, xs, ys, stride):
    """(cx, cy) centre in cells, (ix, iy) its cell and the box's elliptic Gaussian on the grid (xs, ys): TTFNet's
    sigma = 0.54 * side / 6 in cells, at least 0.5."""
    g = xs.shape[0]
    cx, cy = (x + w / 2) / stride, (y + h / 2) / stride
    ix, iy = min(g - 1, int(cx)), min(g - 1, int(cy))
    sx, sy = max(0.5, 0.54 * w / stride / 6), max(0.5, 0.54 * h / stride / 6)
    return cx, cy, ix, iy, np.exp(-((xs - ix) ** 2) / (2 * sx * sx) - ((ys - iy) ** 2) / (2 * sy * sy))


def targets(boxes, ign, size, stride=STRIDE):
    """CenterNet targets on the (size/stride)^2 grid: heatmap (elliptic Gaussian, TTFNet-style sigma =
    0.54 * side / 6 in cells, at least 0.5), loss mask (0 inside ignore boxes), size/offset targets and
    their mask at the centre cell."""
    g = size // stride
    hm = np.zeros((g, g), np.float32)
    mask = np.ones((g, g), np.float32)
    reg = np.zeros((4, g, g), np.float32)
    regm = np.zeros((g, g), np.float32)
    ys, xs = np.mgrid[0:g, 0:g].astype(np.float32)
    for x, y, w, h in ign:
        mask[int(y // stride):int(math.ceil((y + h) / stride)), int(x // stride):int(math.ceil((x + w) / stride))] = 0
    for x, y, w, h in boxes:
        cx, cy, ix, iy, gau = _centre_gaussian(x, y, w, h, xs, ys, stride)
        hm = np.maximum(hm, gau)
        hm[iy, ix] = 1.0
        mask[iy, ix] = 1.0
        # size and offset are learnt at the centre cell and its 3x3 neighbours inside the box (weight = the
        # Gaussian there), so that a peak one cell off still reads a good box; offsets then span [-1, 2)
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                jy, jx = iy + dy, ix + dx
                if not (0 <= jy < g and 0 <= jx < g) or not (x <= (jx + 0.5) * stride <= x + w and
                                                            y <= (jy + 0.5) * stride <= y + h):
                    continue
                wgt = 1.0 if (dy, dx) == (0, 0) else float(gau[jy, jx])
                if wgt > regm[jy, jx]:
                    reg[:, jy, jx] = (math.log(max(w, 1.0)), math.log(max(h, 1.0)), cx - jx, cy - jy)
                    regm[jy, jx] = wgt
    return hm, mask, reg, regm


def aux_targets(others, size, n_cls=2, stride=STRIDE):
    """(n_cls, g, g) centre heatmaps of the other road users (others: (K, 5) box, class), the vehicles'
    Gaussians of targets() (the vehicles' loss mask applies: no loss inside ignore regions). cnn_train --aux
    learns them in extra head channels that the export drops: the network is told what a person or a
    bicycle is, which a vehicle-only heatmap trains only as background."""
    g = size // stride
    hm = np.zeros((n_cls, g, g), np.float32)
    ys, xs = np.mgrid[0:g, 0:g].astype(np.float32)
    for x, y, w, h, c in others.reshape(-1, 5).tolist():
        _, _, ix, iy, gau = _centre_gaussian(x, y, w, h, xs, ys, stride)
        hm[int(c)] = np.maximum(hm[int(c)], gau)
        hm[int(c), iy, ix] = 1.0
    return hm


# ---------------------------------------------------------------- frame sampling

def frame_weights(frames, oblique=1.0):
    """Sampling probabilities of one family's training frames: uniform, except drone frames at a camera
    angle of at most OBLIQUE_MAX_DEG, drawn `oblique` times as often (cnn_train --oblique)."""
    w = np.array([oblique if (v := CD.hit_view(f)) is not None and v[1] <= OBLIQUE_MAX_DEG else 1.0
                  for f in frames], np.float64)
    return w / w.sum()
