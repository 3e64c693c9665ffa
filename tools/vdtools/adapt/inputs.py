# SPDX-License-Identifier: MIT
"""vd-adapt's input: the user's frames and labels, read and checked before anything is trained or written
(numpy, OpenCV and Pillow only: the checks run without PyTorch).

Every problem is an InputError whose text is one line that names the file and what is wrong with it.

- Frames: the PNG / JPEG / PGM files of one folder (what `vd_fir_demo --input DIR` reads, raw files aside),
  sorted by name, all of one size and bit depth. Colour files are read as grey; 16-bit frames are mapped to
  grey as vd_fir_demo's --grey-window auto maps them: by the detector's default radiometric map
  (vdtools.data.dataset.grey_of_ck: 0-51 degC, identity calibration), or, when 90 % of the first frame's
  samples lie outside that window (a camera's raw counts), by each frame's own window (grey_window_ck); the
  detector maps after its 2x2 average and this tool before it (±1 grey level).
- Labels: a YOLO folder (`<stem>.txt` per frame, lines `class xc yc w h` normalised to the frame; class names
  in `classes.txt` beside or above it, optional) or a COCO JSON file (boxes under `annotations`, or HIT-UAV's
  `annotation`; images named by `file_name` or HIT-UAV's `filename`; `bbox` = x, y, w, h in pixels). A frame
  without a label file (YOLO) or without an entry (COCO) has no vehicles. Vehicle classes: --classes (ids
  or names), else the categories named car, othervehicle, vehicle, truck, bus or van, else the only class
  id the labels use. Categories named DontCare / ignore are ignore regions (no loss, no false positive).
- Split: blocks of consecutive frames in file-name order (neighbours of a recording are near-duplicates, so
  they stay together), evenly spread val blocks (split_blocks).
"""
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

IMAGE_EXT = (".png", ".jpg", ".jpeg", ".pgm")
MIN_SIDE = 64               # smaller frames give the network no stride-32 plane to work on
MIN_FRAMES = 4              # fewer cannot be split into adapt and val blocks
BLOCKS = 16                 # default number of blocks of the split (block size ceil(n / BLOCKS), >= 2)
VEHICLE_NAMES = {"car", "othervehicle", "other vehicle", "vehicle", "truck", "bus", "van"}
IGNORE_NAMES = {"dontcare", "dont care", "ignore"}
COORD_SLACK = 1e-3          # YOLO coordinates may overshoot [0, 1] by rounding


class InputError(Exception):
    """Bad input: the message is one line for the user."""


@dataclass
class UserFrame:
    name: str
    path: Path
    img: np.ndarray                       # full-resolution uint8 grey
    boxes: np.ndarray = field(default_factory=lambda: np.zeros((0, 4), np.float32))     # vehicles x, y, w, h
    ignore: np.ndarray = field(default_factory=lambda: np.zeros((0, 4), np.float32))
    labelled: bool = False                # a label file / entry named it
    part: str = ""                        # "adapt" or "val" (split_blocks)
    block: int = 0


# ---------------------------------------------------------------- frames

def list_frames(images):
    p = Path(images)
    if not p.exists():
        raise InputError(f"--images {images}: no such folder")
    if not p.is_dir():
        raise InputError(f"--images {images}: not a folder")
    files = sorted((f for f in p.iterdir() if f.is_file() and f.suffix.lower() in IMAGE_EXT), key=lambda f: f.name)
    if not files:
        raise InputError(f"--images {images}: no frames in it (PNG, JPEG or PGM files)")
    stems = {}
    for f in files:
        if f.stem in stems:
            raise InputError(f"--images {images}: {stems[f.stem].name} and {f.name} have the same name stem "
                             "(labels are matched by stem)")
        stems[f.stem] = f
    return files


def read_frame(path):
    """(frame, bit depth) of one file: uint8 grey, or the uint16 samples of a 16-bit file (read_frames maps them
    to grey); InputError for a file that does not decode completely."""
    import cv2
    from PIL import Image
    try:                                   # Pillow first: OpenCV decodes a truncated JPEG without an error
        with Image.open(path) as im:
            im.load()
    except Exception as e:                 # noqa: BLE001 (any decoder failure is a corrupt file)
        raise InputError(f"{path.name}: corrupt or unreadable image ({str(e).splitlines()[0] if str(e) else type(e).__name__})")
    img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if img is None:
        raise InputError(f"{path.name}: corrupt or unreadable image")
    if img.ndim == 3:
        img = cv2.cvtColor(img, cv2.COLOR_BGRA2GRAY if img.shape[2] == 4 else cv2.COLOR_BGR2GRAY)
    if img.dtype == np.uint16:
        return img, 16
    if img.dtype != np.uint8:
        raise InputError(f"{path.name}: {img.dtype} samples (8- or 16-bit frames only)")
    return img, 8


def read_frames(files):
    """[UserFrame] of the files, checked to share one size and bit depth; 16-bit frames mapped to grey by the
    window the first one decides (module docstring)."""
    from vdtools.data import dataset as D
    out, first, per_frame = [], None, None
    for f in files:
        img, bits = read_frame(f)
        if bits == 16:
            if per_frame is None:
                per_frame = D.grey_outside_permille(img) >= D.GREY_AUTO_PERMILLE
            img = D.grey_of_ck(img, *D.grey_window_ck(img)) if per_frame else D.grey_of_ck(img)
        h, w = img.shape
        if first is None:
            first = (f.name, w, h, bits)
            if min(w, h) < MIN_SIDE:
                raise InputError(f"{f.name}: {w}x{h} frames are too small (at least {MIN_SIDE} px a side)")
        elif (w, h) != first[1:3]:
            raise InputError(f"mixed frame sizes: {first[0]} is {first[1]}x{first[2]}, {f.name} is {w}x{h} "
                             "(adapt to one camera at a time)")
        elif bits != first[3]:
            raise InputError(f"mixed bit depths: {first[0]} is {first[3]}-bit, {f.name} is {bits}-bit")
        out.append(UserFrame(f.stem, f, img))
    return out


# ---------------------------------------------------------------- labels

def _class_names(folder):
    """{id: name} of classes.txt beside or above a YOLO folder ("name" per line, or "id name")."""
    for cand in (folder / "classes.txt", folder.parent / "classes.txt"):
        if cand.is_file():
            cats = {}
            for k, line in enumerate(cand.read_text(errors="replace").splitlines()):
                parts = line.split(None, 1)
                if len(parts) == 2 and parts[0].isdigit():
                    cats[int(parts[0])] = parts[1].strip()
                elif line.strip():
                    cats[k] = line.strip()
            return cats
    return {}


def pick_classes(spec, cats, used, where):
    """The vehicle class ids: --classes (ids or names), else the vehicle-named categories, else the only id
    the labels use. cats {id: name} (may be empty), used: ids the labels use."""
    known = set(cats) or set(used)
    if spec:
        out = set()
        for tok in str(spec).split(","):
            tok = tok.strip()
            if not tok:
                continue
            if tok.lstrip("-").isdigit():
                cid = int(tok)
            else:
                ids = [i for i, n in cats.items() if n.lower() == tok.lower()]
                if not ids:
                    raise InputError(f"--classes: no class named {tok!r} in {where}"
                                     + (f" (names: {', '.join(sorted(cats.values()))})" if cats else ""))
                cid = ids[-1]
            if cid not in known:
                raise InputError(f"--classes: unknown class id {cid} (ids in {where}: "
                                 f"{', '.join(map(str, sorted(known))) or 'none'})")
            out.add(cid)
        if not out:
            raise InputError("--classes: no class given")
        return out
    named = {i for i, n in cats.items() if n.lower() in VEHICLE_NAMES}
    if named:
        return named
    if len(set(used)) == 1:
        return set(used)
    raise InputError(f"name the vehicle class ids with --classes (ids in {where}: "
                     f"{', '.join(map(str, sorted(known))) or 'none'})")


def _clip(x, y, w, h, fw, fh):
    x0, y0, x1, y1 = max(0.0, x), max(0.0, y), min(float(fw), x + w), min(float(fh), y + h)
    return (x0, y0, x1 - x0, y1 - y0) if x1 - x0 >= 1 and y1 - y0 >= 1 else None


def _yolo(folder, frames, spec):
    files = sorted(f for f in folder.glob("*.txt") if f.name != "classes.txt")
    if not files:
        raise InputError(f"--labels {folder}: no label files (<frame stem>.txt) in it")
    by_stem = {fr.name: fr for fr in frames}
    matched = [f for f in files if f.stem in by_stem]
    if not matched:
        raise InputError(f"--labels {folder}: none of its {len(files)} label files matches a frame "
                         f"(e.g. {files[0].name}; frames are named like {frames[0].path.name})")
    cats = _class_names(folder)
    rows, used = {}, set()
    for f in matched:
        lines = []
        for n, line in enumerate(f.read_text(errors="replace").splitlines(), 1):
            p = line.split()
            if not p:
                continue
            try:
                if len(p) != 5:
                    raise ValueError
                c, vals = int(p[0]), [float(v) for v in p[1:]]
            except ValueError:
                raise InputError(f"{f.name} line {n}: expected 'class xc yc w h' (YOLO, normalised), got {line.strip()[:60]!r}")
            if cats and c not in cats:
                raise InputError(f"{f.name} line {n}: unknown class id {c} (classes.txt names "
                                 f"{', '.join(f'{i} {m}' for i, m in sorted(cats.items()))})")
            if c < 0 or not all(-COORD_SLACK <= v <= 1 + COORD_SLACK for v in vals) or vals[2] <= 0 or vals[3] <= 0:
                raise InputError(f"{f.name} line {n}: box {' '.join(p[1:])} is not a normalised YOLO box (0..1)")
            used.add(c)
            lines.append((c, *vals))
        rows[f.stem] = lines
    vehicle = pick_classes(spec, cats, used, f"{folder}" + ("/classes.txt" if cats else ""))
    ignore = {i for i, n in cats.items() if n.lower() in IGNORE_NAMES}
    for stem, lines in rows.items():
        fr = by_stem[stem]
        fh, fw = fr.img.shape
        veh, ign = [], []
        for c, xc, yc, w, h in lines:
            b = _clip((xc - w / 2) * fw, (yc - h / 2) * fh, w * fw, h * fh, fw, fh)
            if b is not None and c in vehicle:
                veh.append(b)
            elif b is not None and c in ignore:
                ign.append(b)
        fr.boxes, fr.ignore = np.array(veh, np.float32).reshape(-1, 4), np.array(ign, np.float32).reshape(-1, 4)
        fr.labelled = True
    return dict(kind="yolo", label_files=len(files), matched=len(matched), vehicle_classes=sorted(vehicle),
                names={str(k): v for k, v in sorted(cats.items())})


def _coco(path, frames, spec):
    try:
        doc = json.loads(Path(path).read_text(errors="replace"))
    except (OSError, ValueError) as e:
        raise InputError(f"--labels {path}: not a readable JSON file ({str(e).splitlines()[0]})")
    if not isinstance(doc, dict) or not isinstance(doc.get("images"), list):
        raise InputError(f"--labels {path}: not COCO JSON (no \"images\" list)")
    anns = doc.get("annotations", doc.get("annotation", []))
    cats = {}
    for c in doc.get("categories", []) or []:
        if isinstance(c, dict) and "id" in c:
            cats[int(c["id"])] = str(c.get("name", c["id"]))
    by_name = {fr.path.name: fr for fr in frames}
    ids = {}
    for im in doc["images"]:
        name = im.get("file_name", im.get("filename")) if isinstance(im, dict) else None
        if name is None or "id" not in im:
            raise InputError(f"--labels {path}: an image entry without id and file_name/filename")
        fr = by_name.get(Path(str(name)).name)
        if fr is None:
            continue
        fh, fw = fr.img.shape
        if "width" in im and "height" in im and (int(im["width"]), int(im["height"])) != (fw, fh):
            raise InputError(f"--labels {path}: {fr.path.name} is {im['width']}x{im['height']} in the labels "
                             f"but {fw}x{fh} on disk")
        ids[im["id"]] = fr
    if not ids:
        raise InputError(f"--labels {path}: none of its {len(doc['images'])} images matches a frame in --images "
                         f"(frames are named like {frames[0].path.name})")
    used = set()
    for a in anns:
        if a.get("image_id") not in ids:
            continue
        c = int(a.get("category_id", -1))
        if cats and c not in cats:
            raise InputError(f"--labels {path}: annotation {a.get('id', '?')} has unknown class id {c} "
                             f"(categories: {', '.join(f'{i} {m}' for i, m in sorted(cats.items()))})")
        used.add(c)
    vehicle = pick_classes(spec, cats, used, f"{path}")
    ignore = {i for i, n in cats.items() if n.lower() in IGNORE_NAMES}
    boxes = {id(fr): ([], []) for fr in ids.values()}
    for a in anns:
        fr = ids.get(a.get("image_id"))
        if fr is None:
            continue
        bb = a.get("bbox")
        if not (isinstance(bb, list) and len(bb) == 4):
            raise InputError(f"--labels {path}: annotation {a.get('id', '?')} has no bbox [x, y, w, h]")
        fh, fw = fr.img.shape
        b = _clip(*(float(v) for v in bb), fw, fh)
        c = int(a.get("category_id", -1))
        if b is None:
            continue
        if c in ignore or a.get("iscrowd"):
            boxes[id(fr)][1].append(b)
        elif c in vehicle:
            boxes[id(fr)][0].append(b)
    for fr in ids.values():
        veh, ign = boxes[id(fr)]
        fr.boxes, fr.ignore = np.array(veh, np.float32).reshape(-1, 4), np.array(ign, np.float32).reshape(-1, 4)
        fr.labelled = True
    return dict(kind="coco", label_files=len(doc["images"]), matched=len(ids), vehicle_classes=sorted(vehicle),
                names={str(k): v for k, v in sorted(cats.items())})


def read_labels(labels, frames, classes=None):
    """Fills frames' boxes from --labels (YOLO folder or COCO JSON); returns a summary dict."""
    p = Path(labels)
    if not p.exists():
        raise InputError(f"--labels {labels}: no such folder or file")
    if p.is_dir():
        return _yolo(p, frames, classes)
    if p.suffix.lower() != ".json":
        raise InputError(f"--labels {labels}: give a YOLO label folder or a COCO .json file")
    return _coco(p, frames, classes)


# ---------------------------------------------------------------- split

def _val_blocks(nb, frac, shift=0):
    k = min(nb - 1, max(1, int(round(nb * frac))))
    return {(int(round((j + 0.5) * nb / k - 0.5)) + shift) % nb for j in range(k)}


def split_blocks(frames, val_frac=0.25, block=None, need_vehicles=True):
    """Sets each frame's part ("adapt" / "val") and block: blocks of `block` consecutive frames in name order
    (default ceil(n / BLOCKS), at least 2), round(blocks x val_frac) of them (at least 1, at most all but one)
    evenly spread over the sequence for val. With need_vehicles, the pattern is shifted block by block until
    both parts hold a vehicle. Returns the block size."""
    n = len(frames)
    n_veh = sum(len(fr.boxes) > 0 for fr in frames)
    if n < MIN_FRAMES:
        raise InputError(f"too few frames to split into adapt and val parts: {n} (at least {MIN_FRAMES})")
    if need_vehicles and n_veh < 2:
        raise InputError(f"too few labelled frames to split: {n_veh} of {n} frames hold a vehicle "
                         "(at least 2, one for each of the adapt and val parts)")
    b = int(block) if block else max(2, math.ceil(n / BLOCKS))
    nb = math.ceil(n / b)
    if nb < 2:
        raise InputError(f"too few frames to split: {n} frames make one block of {b}; give --block smaller than {n}")
    for shift in range(nb):
        val = _val_blocks(nb, val_frac, shift)
        parts = ["val" if i // b in val else "adapt" for i in range(n)]
        if not need_vehicles or all(any(len(fr.boxes) and p == want for fr, p in zip(frames, parts))
                                    for want in ("adapt", "val")):
            for i, (fr, p) in enumerate(zip(frames, parts)):
                fr.part, fr.block = p, i // b
            return b
    raise InputError(f"too few labelled frames to split: the {n_veh} frames with vehicles all fall in one part "
                     f"whichever blocks of {b} frames go to val; label more frames or give --block")
