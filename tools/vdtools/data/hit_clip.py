# SPDX-License-Identifier: MIT
"""The bundled real clip: a contiguous run of the HIT-UAV ``sequence-0_100`` flight (CC BY 4.0).

``python3 -m vdtools.data.hit_clip [--src ../shared/data/hit-uav] [--out tools/demo/hit-uav-clip]
[--budget 2850000]`` copies the longest run of consecutive frames whose JPEG bytes fit the budget
(the repository may hold at most 3 MB of it, ``../shared/data/README.md``), byte for byte, with the
matching subset of ``annotations.json`` (same COCO-like format: the box list under ``annotation``,
images under ``filename``), the licence text and a README with the citation. ``--check`` verifies a
committed clip against the source instead of writing (used by the tests).

Why this flight: it is the one HIT-UAV recording kept in time order, and vd's split rule makes it
test only (``vdtools.data.dataset``: the ``seq`` family never enters a training or validation set, and
its flight groups ``0_100_*`` do not occur among ``hit-uav/frames``), so no committed model has
trained on, or had a threshold chosen on, any bundled frame.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import shutil
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[3]
DEFAULT_SRC = REPO.parent / "shared" / "data" / "hit-uav"
DEFAULT_OUT = REPO / "tools" / "demo" / "hit-uav-clip"
BUDGET = 2_850_000   # JPEG bytes; annotations, licence and README stay under the 3 MB total

CITATION = ("J. Suo, T. Wang, X. Zhang, H. Chen, W. Zhou, W. Shi: HIT-UAV: A high-altitude infrared "
            "thermal dataset for Unmanned Aerial Vehicle-based object detection. Scientific Data 10, "
            "227 (2023). https://doi.org/10.1038/s41597-023-02066-6")


def pick_run(sizes: list[int], budget: int) -> tuple[int, int]:
    """(first, count) of the longest run of consecutive items whose sizes sum to <= budget;
    the earliest such run on ties."""
    best = (0, 0)
    j, total = 0, 0
    for i in range(len(sizes)):
        if j < i:
            j, total = i, 0
        while j < len(sizes) and total + sizes[j] <= budget:
            total += sizes[j]
            j += 1
        if j - i > best[1]:
            best = (i, j - i)
        if j > i:
            total -= sizes[i]
    return best


def plan(src: Path, budget: int) -> tuple[list[str], dict]:
    """The frame names of the clip and its annotations document."""
    seq = src / "sequence-0_100"
    doc = json.loads((seq / "annotations.json").read_text())
    names = sorted(im["filename"] for im in doc["images"])
    sizes = [(seq / "images" / n).stat().st_size for n in names]
    first, count = pick_run(sizes, budget)
    keep = names[first:first + count]
    ids = {im["id"] for im in doc["images"] if im["filename"] in keep}
    out = dict(doc)
    out["images"] = sorted((im for im in doc["images"] if im["filename"] in keep), key=lambda im: im["filename"])
    out["annotation"] = [a for a in doc["annotation"] if a["image_id"] in ids]
    out["info"] = dict(doc.get("info", {}), vd_note=(
        f"frames {keep[0]} .. {keep[-1]} ({count} consecutive frames) of HIT-UAV sequence-0_100, "
        "copied unchanged by tools/vdtools/data/hit_clip.py; CC BY 4.0"))
    return keep, out


def readme(keep: list[str], doc: dict) -> str:
    cars = sum(1 for a in doc["annotation"] if a["category_id"] in (1, 3))
    return f"""# Bundled real clip: HIT-UAV, flight `sequence-0_100` (excerpt)

{len(keep)} consecutive 640×512 8-bit LWIR frames (`{keep[0]}` … `{keep[-1]}`), JPEG files unchanged,
and their boxes (`annotations.json`, the dataset's COCO-like format: boxes under `annotation`,
`bbox = [x, y, w, h]` pixels; {cars} vehicle boxes of classes 1 Car and 3 OtherVehicle). They are
the default input of `vd_fir_demo`.

**Source and licence.** HIT-UAV (Suo et al., 2023), repository
suojiashun/HIT-UAV-Infrared-Thermal-Dataset, licensed under Creative Commons Attribution 4.0
International (CC BY 4.0); the licence text is in `LICENSE` beside this file. The frames and boxes
are unmodified excerpts; the selection was made by `tools/vdtools/data/hit_clip.py` (the longest run of
consecutive frames within a 2.85 MB budget). Cite:

> {CITATION}

**Never trained on.** vd's split rule keeps this flight out of every training and validation set
(docs/training.md), so the figures the demo prints on it are test figures.
"""


def write(src: Path, out: Path, budget: int) -> None:
    keep, doc = plan(src, budget)
    img = out / "images"
    if img.exists():
        shutil.rmtree(img)
    img.mkdir(parents=True)
    for n in keep:
        shutil.copyfile(src / "sequence-0_100" / "images" / n, img / n)
    (out / "annotations.json").write_text(json.dumps(doc, separators=(",", ":")) + "\n")
    shutil.copyfile(src / "LICENSE", out / "LICENSE")
    (out / "README.md").write_text(readme(keep, doc))


def sha(p: Path) -> str:
    return hashlib.sha256(p.read_bytes()).hexdigest()


def check(src: Path, out: Path, budget: int) -> list[str]:
    """Differences between the committed clip and what write() would produce (empty when equal)."""
    keep, doc = plan(src, budget)
    errs = []
    have = sorted(p.name for p in (out / "images").iterdir())
    if have != keep:
        errs.append(f"frames differ: have {len(have)}, expected {len(keep)}")
    for n in set(have) & set(keep):
        if sha(out / "images" / n) != sha(src / "sequence-0_100" / "images" / n):
            errs.append(f"{n}: bytes differ from the source")
    if json.loads((out / "annotations.json").read_text()) != doc:
        errs.append("annotations.json differs from the source subset")
    if sha(out / "LICENSE") != sha(src / "LICENSE"):
        errs.append("LICENSE differs from the dataset's")
    total = sum(p.stat().st_size for p in out.rglob("*") if p.is_file())
    if total > 3_000_000:
        errs.append(f"clip is {total} bytes, over 3 MB")
    return errs


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--src", type=Path, default=DEFAULT_SRC)
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT)
    ap.add_argument("--budget", type=int, default=BUDGET)
    ap.add_argument("--check", action="store_true")
    a = ap.parse_args(argv)
    if a.check:
        errs = check(a.src, a.out, a.budget)
        for e in errs:
            print("hit_clip:", e, file=sys.stderr)
        return 1 if errs else 0
    write(a.src, a.out, a.budget)
    print(f"hit_clip: wrote {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
