# SPDX-License-Identifier: MIT
"""Deterministic synthetic night-road FIR clip with ground truth (the bundled demo clip).

    python3 -m vdtools.data.clip --out DIR [--frames 120] [--width 640] [--height 512] [--seed 1]

writes
    DIR/u16/frame_NNNN.pgm   16-bit radiometric frames, P5 big-endian, TLinear
                              centi-kelvin: value = T[K] * 100, so 30.00 degC = 30315
    DIR/u8/frame_NNNN.pgm    8-bit frames, P5, fixed linear mapping
                              u8 = clamp(round((ck - 24315) / 40), 0, 255):
                              0 = -30 degC, 150 = 30.00 degC (paper 001's threshold),
                              255 = 72 degC, 0.4 K per grey level
    DIR/annotations.json     COCO-like ground truth in the HIT-UAV layout: "images" with
                              "filename"/"width"/"height"/"id", boxes under "annotation"
                              (HIT-UAV quirk) and, identically, under "annotations";
                              bbox = [x, y, w, h] in pixels; categories as HIT-UAV
                              (0 Person, 1 Car, 2 Bicycle, 3 OtherVehicle, 4 DontCare)
    DIR/README.txt           what the clip is

Scene (a pinhole camera 1.4 m above a straight road, ego car driving at 9 m/s,
30 frames/s, steering gently so the scene pans left and right): a cold sky with a
vertical gradient, a road warmer towards the camera with lane marks and warm
asphalt patches (below 30 degC), street lamps on poles (small hot bulbs, area
below the paper's 120 px rule), pedestrians on the pavement (tall, warm: height
over width > 1.5), and cars seen from behind (one oncoming car from the front)
at 8-60 m: a warm body whose lower part (bumper, tyres, exhaust, underbody) is
above 30 degC, cooler cabin and rear window.  Gaussian sensor noise (NETD-like),
fixed column noise and a slight optical blur.  Only numpy; the same seed gives
byte-identical files.

Ground truth: every car whose visible box is at least 12x8 pixels gets a
category-1 box (its full outline, clipped to the frame); pedestrians get
category-0 boxes; an object whose box is more than a third hidden behind
nearer objects' boxes or outside the frame becomes category 4 DontCare instead.  Cars are drawn far
to near.
"""
import argparse
import json
import math
import os
from pathlib import Path

import numpy as np

CK0 = 27315                      # 0 degC in centi-kelvin
U8_OFFSET_CK = 24315             # -30 degC -> 0
U8_STEP_CK = 40                  # 0.4 K per grey level -> 30 degC = 150

FOCAL = 640.0                    # pixels (about 53 deg horizontal field of view at 640 px)
CAM_H = 1.4                      # camera height above the road, m
SPEED = 0.3                      # ego motion per frame, m (9 m/s at 30 frames/s)

CATEGORIES = [
    {"supercategory": "Person", "id": 0, "name": "Person"},
    {"supercategory": "Vehicle", "id": 1, "name": "Car"},
    {"supercategory": "Vehicle", "id": 2, "name": "Bicycle"},
    {"supercategory": "Vehicle", "id": 3, "name": "OtherVehicle"},
    {"supercategory": "DontCare", "id": 4, "name": "DontCare"},
]


def c2ck(c):
    """degrees Celsius -> centi-kelvin (float)."""
    return CK0 + 100.0 * c


def ck_to_u8(ck):
    """The documented 8-bit mapping: round((ck - 24315) / 40) clamped to 0..255."""
    v = np.floor((np.asarray(ck, dtype=np.int64) - U8_OFFSET_CK + U8_STEP_CK // 2) / U8_STEP_CK)
    return np.clip(v, 0, 255).astype(np.uint8)


class Camera:
    def __init__(self, w, h, horizon, pan):
        self.w, self.h, self.horizon, self.pan = w, h, horizon, pan

    def project(self, X, Y, Z):
        """World (X right, Y up from road, Z ahead) -> pixel (u, v)."""
        u = self.w / 2 + self.pan + FOCAL * X / Z
        v = self.horizon - FOCAL * (Y - CAM_H) / Z
        return u, v


def fill_rect(img, x0, y0, x1, y1, value, mode="set"):
    """Sets img[y0:y1, x0:x1] (float coordinates, clipped; partial pixels rounded)."""
    h, w = img.shape
    xa, xb = max(0, int(round(x0))), min(w, int(round(x1)))
    ya, yb = max(0, int(round(y0))), min(h, int(round(y1)))
    if xa >= xb or ya >= yb:
        return
    if mode == "max":
        np.maximum(img[ya:yb, xa:xb], value, out=img[ya:yb, xa:xb])
    elif mode == "add":
        img[ya:yb, xa:xb] += value
    else:
        img[ya:yb, xa:xb] = value


def fill_ellipse(img, cx, cy, rx, ry, value, mode="set"):
    h, w = img.shape
    xa, xb = max(0, int(math.floor(cx - rx))), min(w, int(math.ceil(cx + rx)) + 1)
    ya, yb = max(0, int(math.floor(cy - ry))), min(h, int(math.ceil(cy + ry)) + 1)
    if xa >= xb or ya >= yb or rx <= 0 or ry <= 0:
        return
    yy, xx = np.mgrid[ya:yb, xa:xb]
    inside = ((xx + 0.5 - cx) / rx) ** 2 + ((yy + 0.5 - cy) / ry) ** 2 <= 1.0
    sub = img[ya:yb, xa:xb]
    if mode == "max":
        sub[inside] = np.maximum(sub[inside], value)
    else:
        sub[inside] = value


def draw_car(img, x0, y0, w, h, front, rng_temp):
    """A car outline filling [x0, x0+w) x [y0, y0+h): rear view (or front view when
    `front`).  rng_temp: per-car temperature offsets (deterministic).  Celsius values
    are converted to centi-kelvin here."""
    body_c, cabin_c, glass_c, tyre_c, hot_c, exhaust_c = rng_temp
    # cabin: upper 42 %, inset 14 % each side, with rounded top corners
    ch = 0.42 * h
    inset = 0.14 * w
    fill_rect(img, x0 + inset, y0 + 0.06 * h, x0 + w - inset, y0 + ch, c2ck(cabin_c))
    fill_ellipse(img, x0 + inset + 0.06 * w, y0 + 0.08 * h, 0.07 * w, 0.07 * h, c2ck(cabin_c))
    fill_ellipse(img, x0 + w - inset - 0.06 * w, y0 + 0.08 * h, 0.07 * w, 0.07 * h, c2ck(cabin_c))
    fill_rect(img, x0 + inset + 0.06 * w, y0, x0 + w - inset - 0.06 * w, y0 + 0.08 * h, c2ck(cabin_c))
    # window (rear or front screen): cold, reflects the sky
    fill_rect(img, x0 + inset + 0.05 * w, y0 + 0.10 * h, x0 + w - inset - 0.05 * w, y0 + ch - 0.03 * h,
              c2ck(glass_c))
    # lower body (boot lid / bonnet, bumper): warm, above 30 degC
    fill_rect(img, x0, y0 + ch, x0 + w, y0 + 0.86 * h, c2ck(body_c))
    # tyres at the two lower corners, underbody heat between them
    tw = 0.17 * w
    fill_rect(img, x0 + 0.02 * w, y0 + 0.72 * h, x0 + 0.02 * w + tw, y0 + h, c2ck(tyre_c))
    fill_rect(img, x0 + w - 0.02 * w - tw, y0 + 0.72 * h, x0 + w - 0.02 * w, y0 + h, c2ck(tyre_c))
    fill_rect(img, x0 + 0.02 * w + tw, y0 + 0.86 * h, x0 + w - 0.02 * w - tw, y0 + 0.95 * h, c2ck(hot_c))
    if front:
        # engine grille and headlights
        fill_rect(img, x0 + 0.30 * w, y0 + 0.58 * h, x0 + 0.70 * w, y0 + 0.78 * h, c2ck(hot_c))
        fill_rect(img, x0 + 0.05 * w, y0 + 0.52 * h, x0 + 0.22 * w, y0 + 0.62 * h, c2ck(hot_c - 4))
        fill_rect(img, x0 + 0.78 * w, y0 + 0.52 * h, x0 + 0.95 * w, y0 + 0.62 * h, c2ck(hot_c - 4))
    else:
        # tail lights and an exhaust pipe
        fill_rect(img, x0 + 0.04 * w, y0 + 0.48 * h, x0 + 0.18 * w, y0 + 0.60 * h, c2ck(body_c + 4))
        fill_rect(img, x0 + 0.82 * w, y0 + 0.48 * h, x0 + 0.96 * w, y0 + 0.60 * h, c2ck(body_c + 4))
        ex = x0 + 0.70 * w
        fill_ellipse(img, ex, y0 + 0.90 * h, max(1.0, 0.05 * w), max(1.0, 0.04 * h), c2ck(exhaust_c))


def draw_person(img, x0, y0, w, h, temp_c):
    """A pedestrian in [x0, x0+w) x [y0, y0+h): head, torso, legs (tall: h/w ~ 3.5)."""
    cx = x0 + w / 2
    fill_ellipse(img, cx, y0 + 0.07 * h, 0.22 * w, 0.07 * h, c2ck(temp_c + 2.5))
    fill_rect(img, x0 + 0.05 * w, y0 + 0.14 * h, x0 + 0.95 * w, y0 + 0.55 * h, c2ck(temp_c))
    fill_rect(img, x0 + 0.12 * w, y0 + 0.55 * h, x0 + 0.46 * w, y0 + h, c2ck(temp_c - 0.5))
    fill_rect(img, x0 + 0.54 * w, y0 + 0.55 * h, x0 + 0.88 * w, y0 + h, c2ck(temp_c - 0.5))


def smoothstep(a, b, t):
    t = min(1.0, max(0.0, (t - a) / (b - a)))
    return t * t * (3 - 2 * t)


# Cars: lane offset X (m), distance Z(t) (m), front (oncoming), temperatures (degC)
# body, cabin, glass, tyres, underbody/engine, exhaust.
def car_tracks(n):
    def lead(t):        # lead car in our lane: follows at 11-15 m, brakes mid clip
        return 0.0, 13.0 - 3.0 * math.sin(2 * math.pi * t / n)

    def overtaker(t):   # overtakes on the left and pulls away
        return -3.5, 9.0 + 0.22 * t

    def far_right(t):   # slow car in the right lane that we close in on
        return 3.5, 45.0 - 0.18 * t

    def oncoming(t):    # oncoming in the far-left lane, appears at frame 40
        return -7.0, 70.0 - 0.75 * (t - 40)

    def merger(t):      # changes lanes from right to ours, far ahead
        return 3.5 * (1.0 - smoothstep(20, 90, t)), 28.0 + 0.04 * t

    return [
        dict(f=lead, frames=(0, n), front=False, temps=(33.0, 21.0, 9.0, 38.0, 46.0, 75.0), w=1.80, h=1.45),
        dict(f=overtaker, frames=(0, n), front=False, temps=(32.5, 20.0, 7.0, 37.0, 44.0, 70.0), w=1.85, h=1.40),
        dict(f=far_right, frames=(0, n), front=False, temps=(34.0, 22.0, 10.0, 39.0, 48.0, 80.0), w=1.75, h=1.50),
        dict(f=oncoming, frames=(40, n), front=True, temps=(33.5, 21.0, 8.0, 38.0, 52.0, 60.0), w=1.80, h=1.35),
        dict(f=merger, frames=(0, n), front=False, temps=(33.0, 22.0, 9.0, 38.0, 47.0, 72.0), w=2.0, h=1.20),
    ]


def render(args):
    n, W, H = args.frames, args.width, args.height
    rng = np.random.default_rng(args.seed)
    col_noise = rng.normal(0.0, 6.0, size=W)                 # fixed pattern, ck
    patches = [(rng.uniform(-5, 5), rng.uniform(12, 60), rng.uniform(1.5, 4.0), rng.uniform(2, 6),
                rng.uniform(17.0, 26.0)) for _ in range(7)]  # X, Z, width, depth (m), degC
    lamps_z = np.arange(18.0, 120.0, 25.0)                    # world Z of lamps at t=0, both sides
    people = [(5.2, 16.0, 31.0), (6.0, 22.0, 30.8), (-5.6, 26.0, 31.5)]   # X, Z at t=0, degC
    cars = car_tracks(n)
    frames, anns = [], []
    ann_id = 1
    for t in range(n):
        pan = 40.0 * math.sin(2 * math.pi * t / 90.0)
        horizon = 0.37 * H + 4.0 * math.sin(2 * math.pi * t / 47.0)
        cam = Camera(W, H, horizon, pan)
        img = np.empty((H, W), dtype=np.float64)
        rows = np.arange(H, dtype=np.float64)[:, None]
        # sky: -22 degC at the top to -8 degC at the horizon
        sky = c2ck(-22.0) + (c2ck(-8.0) - c2ck(-22.0)) * np.clip(rows / max(horizon, 1.0), 0, 1)
        # ground: 6 degC at the horizon to 13 degC at the bottom row
        ground = c2ck(6.0) + (c2ck(13.0) - c2ck(6.0)) * np.clip((rows - horizon) / (H - horizon), 0, 1)
        img[:] = np.where(rows < horizon, sky, ground)
        # verge (grass) colder than the asphalt: outside |X| > 5 m
        for side in (-1, 1):
            for v in range(int(math.ceil(horizon + 1)), H):
                Z = FOCAL * CAM_H / (v + 0.5 - horizon)
                u_edge = W / 2 + pan + FOCAL * side * 5.0 / Z
                if side < 0:
                    fill_rect(img, 0, v, u_edge, v + 1, -250.0, mode="add")
                else:
                    fill_rect(img, u_edge, v, W, v + 1, -250.0, mode="add")
        travelled = SPEED * t
        # warm asphalt patches (below 30 degC; the road's stored heat)
        for X, Z0, pw, pd, tc in patches:
            Z = (Z0 - travelled) % 60.0 + 6.0
            u0, v0 = cam.project(X - pw / 2, 0.0, Z + pd)
            u1, v1 = cam.project(X + pw / 2, 0.0, Z)
            fill_rect(img, u0, v0, u1, v1, c2ck(tc), mode="max")
        # lane marks: slightly warmer paint dashes
        for X in (-1.75, 1.75):
            for k in range(12):
                Z = (k * 9.0 - travelled) % 108.0 + 5.0
                ua, va = cam.project(X - 0.07, 0.0, Z + 3.0)
                ub, vb = cam.project(X + 0.07, 0.0, Z)
                fill_rect(img, ua, va, max(ub, ua + 1), vb, 120.0, mode="add")
        # street lamps: cold pole, hot bulb 0.3 x 0.12 m at 6 m
        for Zl in lamps_z:
            Z = (Zl - travelled) % 100.0 + 10.0
            for X in (-6.5, 6.5):
                up, vp_top = cam.project(X, 6.0, Z)
                _, vp_bot = cam.project(X, 0.0, Z)
                pw = max(1.0, FOCAL * 0.15 / Z)
                fill_rect(img, up - pw / 2, vp_top, up + pw / 2, vp_bot, c2ck(2.0))
                bx = up - np.sign(X) * FOCAL * 0.6 / Z
                bw, bh = FOCAL * 0.3 / Z, FOCAL * 0.12 / Z
                fill_ellipse(img, bx, vp_top + bh / 2, max(bw / 2, 0.8), max(bh / 2, 0.8), c2ck(85.0), mode="max")
        # objects far to near (painter's algorithm)
        objs = []
        for i, (X, Z0, tc) in enumerate(people):
            Z = Z0 - 0.6 * travelled * (0.7 + 0.2 * i)
            if Z < 6.0:
                Z += 30.0
            objs.append(("person", Z, X + 0.02 * t * (1 if i % 2 else -1), tc, None))
        for c in cars:
            if not (c["frames"][0] <= t < c["frames"][1]):
                continue
            X, Z = c["f"](t)
            objs.append(("car", Z, X, None, c))
        objs.sort(key=lambda o: -o[1])
        boxes = []
        for kind, Z, X, tc, c in objs:
            if Z < 4.0:
                continue
            if kind == "person":
                u0, v0 = cam.project(X - 0.27, 1.75, Z)
                u1, v1 = cam.project(X + 0.27, 0.0, Z)
                draw_person(img, u0, v0, u1 - u0, v1 - v0, tc)
                cat = 0
            else:
                u0, v0 = cam.project(X - c["w"] / 2, c["h"], Z)
                u1, v1 = cam.project(X + c["w"] / 2, 0.0, Z)
                draw_car(img, u0, v0, u1 - u0, v1 - v0, c["front"], c["temps"])
                cat = 1
            x0, y0 = max(0, int(round(u0))), max(0, int(round(v0)))
            x1, y1 = min(W, int(round(u1))), min(H, int(round(v1)))
            full = max(1.0, (u1 - u0) * (v1 - v0))
            boxes.append((x0, y0, x1, y1, cat, full))
        # ground truth near to far: an object hidden by more than a third behind
        # nearer ones or cut by the frame edge becomes DontCare (4), as annotators of HIT-UAV do
        cover = np.zeros((H, W), dtype=bool)
        for x0, y0, x1, y1, cat, full in reversed(boxes):
            if x1 - x0 >= 12 and y1 - y0 >= 8:
                seen = float((~cover[y0:y1, x0:x1]).sum())
                hidden = 1.0 - seen / full       # hidden or outside the frame
                bbox = [x0, y0, x1 - x0, y1 - y0]
                anns.append({"segmentation": [[x0, y0, x1, y0, x1, y1, x0, y1]], "area": bbox[2] * bbox[3],
                             "image_id": t, "bbox": bbox, "category_id": cat if hidden <= 1 / 3 else 4,
                             "id": ann_id})
                ann_id += 1
            if x1 > x0 and y1 > y0:
                cover[y0:y1, x0:x1] = True
        # optics: 3x3 binomial blur; sensor: column pattern + temporal noise (~0.12 K)
        p = np.pad(img, 1, mode="edge")
        img = (p[:-2] + 2 * p[1:-1] + p[2:]) / 4
        img = (img[:, :-2] + 2 * img[:, 1:-1] + img[:, 2:]) / 4
        img += col_noise[None, :] + rng.normal(0.0, 12.0, size=img.shape)
        frames.append(np.clip(np.rint(img), 0, 65535).astype(np.uint16))
    return frames, anns


def write_pgm(path, a):
    """P5 PGM: 8-bit, or 16-bit big-endian with maxval 65535.  Written to a temporary
    name and renamed, so a reader never sees half a file."""
    maxval = 255 if a.dtype == np.uint8 else 65535
    data = a.tobytes() if a.dtype == np.uint8 else a.astype(">u2").tobytes()
    tmp = path.with_name("." + path.name + ".tmp")
    with open(tmp, "wb") as f:
        f.write(b"P5\n%d %d\n%d\n" % (a.shape[1], a.shape[0], maxval))
        f.write(data)
    os.replace(tmp, path)


def read_pgm(path):
    """Reads a P5 PGM written by write_pgm (for tests and tools)."""
    raw = Path(path).read_bytes()
    parts, pos = [], 0
    while len(parts) < 4:
        while raw[pos:pos + 1].isspace():
            pos += 1
        if raw[pos:pos + 1] == b"#":
            while raw[pos:pos + 1] not in (b"\n", b""):
                pos += 1
            continue
        start = pos
        while not raw[pos:pos + 1].isspace():
            pos += 1
        parts.append(raw[start:pos])
    pos += 1
    assert parts[0] == b"P5", path
    w, h, maxval = int(parts[1]), int(parts[2]), int(parts[3])
    dt = np.uint8 if maxval < 256 else np.dtype(">u2")
    return np.frombuffer(raw[pos:pos + w * h * np.dtype(dt).itemsize], dtype=dt).reshape(h, w).astype(
        np.uint8 if maxval < 256 else np.uint16)


def generate(out, frames=120, width=640, height=512, seed=1):
    """Writes the clip into `out` (created); returns the annotation dict."""
    args = argparse.Namespace(frames=frames, width=width, height=height, seed=seed)
    out = Path(out)
    (out / "u16").mkdir(parents=True, exist_ok=True)
    (out / "u8").mkdir(parents=True, exist_ok=True)
    imgs, anns = render(args)
    images = []
    for t, a in enumerate(imgs):
        name = f"frame_{t:04d}.pgm"
        write_pgm(out / "u16" / name, a)
        write_pgm(out / "u8" / name, ck_to_u8(a))
        images.append({"filename": name, "height": height, "width": width, "id": t})
    doc = {
        "info": {"description": "vd synthetic night-road clip (vdtools.data.clip)", "version": "1.0",
                 "seed": seed, "u16": "TLinear centi-kelvin (value/100 = K)",
                 "u8": f"round((ck - {U8_OFFSET_CK}) / {U8_STEP_CK}) clamped 0..255; 150 = 30 degC"},
        "categories": CATEGORIES,
        "images": images,
        "annotation": anns,
        "annotations": anns,
    }
    tmp = out / ".annotations.json.tmp"
    tmp.write_text(json.dumps(doc, indent=1) + "\n")
    os.replace(tmp, out / "annotations.json")
    (out / "README.txt").write_text(
        "Synthetic night-road FIR clip generated by `python3 -m vdtools.data.clip` (tools/vdtools/data/clip.py).\n"
        f"{frames} frames {width}x{height}, seed {seed}.\n"
        "u16/: 16-bit P5 PGM, TLinear centi-kelvin (30.00 degC = 30315).\n"
        f"u8/: 8-bit P5 PGM, u8 = round((ck - {U8_OFFSET_CK}) / {U8_STEP_CK}) clamped; 150 = 30 degC.\n"
        "annotations.json: COCO-like (HIT-UAV layout), category 1 = Car, 0 = Person.\n")
    return doc


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", required=True, help="output directory (created)")
    ap.add_argument("--frames", type=int, default=120)
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=512)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args(argv)
    if a.frames < 1 or a.width < 64 or a.height < 64:
        ap.error("need --frames >= 1 and a frame of at least 64x64")
    doc = generate(a.out, a.frames, a.width, a.height, a.seed)
    ncar = sum(1 for x in doc["annotation"] if x["category_id"] == 1)
    print(f"vdtools.data.clip: {a.frames} frames {a.width}x{a.height} and {ncar} car boxes in {a.out}")


if __name__ == "__main__":
    main()
