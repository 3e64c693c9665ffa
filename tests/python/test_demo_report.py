# SPDX-License-Identifier: MIT
"""vd_fir_demo --report DIR (one self-contained index.html) and the progress line on stderr.

The page is rendered in headless Chromium (Debian package `chromium`; the test skips with a
message when it is absent): the screenshot must not be blank and the figures in the rendered
DOM must equal the ones the demo prints for --eval, the AP must equal
vdtools.metrics.evaluate.average_precision of the demo's JSON Lines, and the gallery must hold the
frames with misses or false positives found by vdtools.metrics.evaluate.match_flags. The progress
tests run the demo once with stderr on a pipe and once on a pseudo-terminal (pty)."""
import json
import os
import pty
import re
import select
import shutil
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

from vdtools.data import clip
from vdtools.metrics import evaluate
from buildpaths import build_dir, run_demo as run


FRAMES = 60
MAX_THUMBS = 48   # DEMO_REPORT_MAX_THUMBS (tools/demo/report.h)


@pytest.fixture(scope="module")
def clip_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("clip")
    clip.generate(out, frames=FRAMES, seed=1)
    return out


@pytest.fixture(scope="module", params=["bundled", "synthetic"])
def report(request, demo, clip_dir, tmp_path_factory):
    """One run with every output; the default sources and models (varied scores: a real PR curve).
    bundled: the demo's default input, the real HIT-UAV clip with its own annotations (38 frames);
    synthetic: 60 generated frames, more frames with errors than the gallery holds."""
    d = tmp_path_factory.mktemp("report")
    rep, jl, ev = d / "rep", d / "det.jsonl", d / "eval.json"
    inp = [] if request.param == "bundled" else ["--input", clip_dir / "u16", "--eval", clip_dir / "annotations.json"]
    p = run(demo, *inp, "--json", jl, "--eval-out", ev, "--report", rep, "--quiet")
    return dict(dir=rep, stdout=p.stdout, jsonl=jl, eval=json.loads(ev.read_text()), tmp=d, kind=request.param)


def stdout_figures(text):
    m = re.search(r"TP rate ([\d.]+)%  FP rate ([\d.]+)%  precision ([\d.]+)%  recall ([\d.]+)%  FPPI ([\d.]+)  "
                  r"\(TP (\d+), FP (\d+), FN (\d+)\)", text)
    a = re.search(r"AP ([\d.]+)%", text)
    s = re.search(r"(\d+) frames, (\d+) detections; ([\d.]+) fps \(detector\)", text)
    assert m and a and s, text
    return {"tp-rate": m[1] + "%", "fp-rate": m[2] + "%", "precision": m[3] + "%", "fppi": m[5], "tp": m[6],
            "fp": m[7], "fn": m[8], "ap": a[1] + "%", "frames": s[1], "detections": s[2], "fps-detector": s[3]}


def by_id(html, ident):
    m = re.search(rf'id="{ident}"[^>]*>([^<]*)<', html)
    assert m, ident
    return m[1]


def test_report_is_self_contained(report):
    files = sorted(p.name for p in report["dir"].iterdir())
    assert files == ["index.html"], files            # no staged thumbnails or temporaries left
    html = (report["dir"] / "index.html").read_text()
    srcs = re.findall(r'\ssrc="([^"]*)"', html)
    assert srcs and all(s.startswith("data:image/png;base64,") for s in srcs)
    assert not re.search(r'(href|src)="(https?:|//|file:)', html)
    assert "<svg" in html and 'id="pr-curve"' in html


def test_report_figures_match_eval(report):
    html = (report["dir"] / "index.html").read_text()
    for k, v in stdout_figures(report["stdout"]).items():
        assert by_id(html, k) == v, (k, by_id(html, k), v)
    e = report["eval"]
    assert by_id(html, "vehicles") == str(e["vehicles"]) and by_id(html, "eval-frames") == str(e["frames"])
    assert e["frames"] == (FRAMES if report["kind"] == "synthetic" else 38)
    assert float(by_id(html, "ap").rstrip("%")) == pytest.approx(100 * e["ap"], abs=0.006)
    # the AP is the Python reference's on the same detections
    gt = evaluate.GroundTruth(Path(e["annotations"]))
    frames, bad = [], 0
    for line in report["jsonl"].read_text().splitlines():
        r = json.loads(line)
        boxes = gt.boxes(r["frame"], r["width"], r["height"])
        dets = [(d["box"], d["score"]) for d in r["detections"]]
        frames.append((dets, boxes))
        flags, used = evaluate.match_flags(dets, boxes)
        misses = sum(1 for g in boxes if g[4]) - len(used)
        bad += any(f == 0 for _, f in flags) or misses > 0
    ap, rec, prec = evaluate.average_precision(frames)
    assert e["ap"] == pytest.approx(ap, abs=1e-6)
    assert len(set(prec)) > 3, "scores should vary: the curve is a real curve"
    # gallery: every frame with a miss or a false positive counted, the top MAX_THUMBS shown
    assert f"{bad} frames have a miss or a false positive" in html
    assert html.count('<figure class="thumb">') == min(bad, MAX_THUMBS)
    if report["kind"] == "synthetic":
        assert bad > MAX_THUMBS   # the cap is exercised


def chromium():
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is None:
        pytest.skip("chromium not installed (Debian package 'chromium', tools/setup.sh): page not rendered")
    return exe


def render(page, tmp, *mode):
    prof = tmp / f"profile-{mode[0].lstrip('-').split('=')[0]}"
    cmd = [chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
           "--disable-background-networking", "--disable-component-update", "--disable-sync",
           f"--user-data-dir={prof}", "--hide-scrollbars", *mode, page.as_uri()]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=120)


def test_report_renders_in_chromium(report):
    from PIL import Image   # Pillow: a dependency of matplotlib (tools/pyproject.toml)
    page, tmp = report["dir"] / "index.html", report["tmp"]
    shot = tmp / "shot.png"
    p = render(page, tmp, f"--screenshot={shot}", "--window-size=1200,1600")
    assert p.returncode == 0 and shot.is_file(), p.stderr[-2000:]
    img = np.asarray(Image.open(shot).convert("RGB")).astype(int)
    assert img.shape[:2] == (1600, 1200)
    # not blank: varied grey levels and many colours (text, curve, thumbnails)
    assert img.mean(axis=2).std() > 20
    assert len(np.unique(img.reshape(-1, 3) @ np.array([65536, 256, 1]))) > 200
    # the PR curve / stage bars (#1f5fbf) and the curve's shaded area (#cfe3ff) are drawn
    blue = (abs(img[..., 0] - 0x1f) < 8) & (abs(img[..., 1] - 0x5f) < 8) & (abs(img[..., 2] - 0xbf) < 8)
    shade = (abs(img[..., 0] - 0xcf) < 4) & (abs(img[..., 1] - 0xe3) < 4) & (abs(img[..., 2] - 0xff) < 4)
    assert blue.sum() > 500 and shade.sum() > 5000, (blue.sum(), shade.sum())
    # the rendered DOM shows the demo's figures
    q = render(page, tmp, "--dump-dom")
    assert q.returncode == 0, q.stderr[-2000:]
    for k, v in stdout_figures(report["stdout"]).items():
        assert by_id(q.stdout, k) == v, k
    assert q.stdout.count("data:image/png;base64,") == min(MAX_THUMBS, q.stdout.count('class="thumb"'))


def test_report_without_ground_truth(demo, clip_dir, tmp_path):
    rep = tmp_path / "r"
    p = run(demo, "--input", clip_dir / "u8", "--model", "none", "--frames", 5, "--report", rep, "--quiet")
    html = (rep / "index.html").read_text()
    assert by_id(html, "frames") == "5" and "No ground truth" in html and "<svg" not in html
    assert by_id(html, "detections") == re.search(r"(\d+) detections;", p.stdout)[1]
    assert sorted(x.name for x in rep.iterdir()) == ["index.html"]


def test_report_failed_run_leaves_nothing(demo, clip_dir, tmp_path):
    rep = tmp_path / "new" / "r"
    bad = tmp_path / "mixed"
    bad.mkdir()
    shutil.copy(clip_dir / "u16" / "frame_0000.pgm", bad / "a.pgm")
    shutil.copy(clip_dir / "u8" / "frame_0001.pgm", bad / "b.pgm")   # 8-bit after 16-bit: an error
    p = run(demo, "--input", bad, "--eval", clip_dir / "annotations.json", "--report", rep, check=False)
    assert p.returncode == 1 and "vd_fir_demo: error:" in p.stderr
    assert not rep.exists()


PROGRESS = re.compile(r"\[(\d+)/(\d+) (\d+)%\] ([\d.]+) frames/s, (\d+):(\d\d) left \| (\S+): (\d+) detections")


def check_progress_line(m, total):
    done, tot, pct, rate = int(m[1]), int(m[2]), int(m[3]), float(m[4])
    left = int(m[5]) * 60 + int(m[6])
    assert tot == total and 1 <= done <= total and pct == round(100 * done / total)
    assert rate > 0
    # time left = (total - done) / rate, rounded up to whole seconds
    assert abs(left - (total - done) / rate) <= 1.0 + 0.1 * (total - done) / rate
    assert m[7] == f"frame_{done - 1:04d}.pgm"
    return done


def test_progress_plain_lines_when_not_a_terminal(demo, clip_dir):
    p = run(demo, "--input", clip_dir / "u8", "--model", "none")
    lines = p.stderr.splitlines()
    assert lines[0].startswith("vd_fir_demo: input ")
    assert "\r" not in p.stderr and "\033" not in p.stderr
    done = [check_progress_line(PROGRESS.fullmatch(x), FRAMES) for x in lines[1:]]
    assert done == [50, 60]   # every 50 frames and the last one
    q = run(demo, "--input", clip_dir / "u8", "--model", "none", "--frames", 7)
    assert [check_progress_line(PROGRESS.fullmatch(x), 7) for x in q.stderr.splitlines()[1:]] == [7]
    assert run(demo, "--input", clip_dir / "u8", "--model", "none", "--quiet").stderr == ""


def run_on_pty(demo, *args):
    """Runs the demo with stderr on a pseudo-terminal (stdout on a pipe); returns (rc, stdout, stderr bytes)."""
    master, slave = pty.openpty()
    proc = subprocess.Popen([str(demo), *map(str, args)], stdout=subprocess.PIPE, stderr=slave, stdin=subprocess.DEVNULL)
    os.close(slave)
    err = b""
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        r, _, _ = select.select([master], [], [], 1.0)
        if r:
            try:
                chunk = os.read(master, 65536)
            except OSError:   # EIO: the demo closed its end
                break
            if not chunk:
                break
            err += chunk
        elif proc.poll() is not None:
            break
    out = proc.stdout.read().decode()
    rc = proc.wait(timeout=60)
    os.close(master)
    return rc, out, err.decode()


def test_progress_one_updating_line_on_a_terminal(demo, clip_dir):
    rc, out, err = run_on_pty(demo, "--input", clip_dir / "u8", "--model", "none")
    assert rc == 0 and f"{FRAMES} frames" in out
    err = err.replace("\r\n", "\n")              # the terminal's output processing turns \n into \r\n
    head, rest = err.split("\n", 1)
    assert head.startswith("vd_fir_demo: input ")
    # one line: every update starts with \r and ends by erasing the rest of the line; one newline at the end
    assert rest.endswith("\n") and rest.count("\n") == 1
    updates = [u for u in rest[:-1].split("\r") if u]
    assert updates and all(u.endswith("\033[K") for u in updates)
    done = [check_progress_line(PROGRESS.fullmatch(u[:-3]), FRAMES) for u in updates]
    assert done == sorted(done) and done[-1] == FRAMES   # the last frame is always shown
    rc, _, err = run_on_pty(demo, "--input", clip_dir / "u8", "--model", "none", "--quiet")
    assert rc == 0 and err == ""


def test_error_after_progress_on_a_terminal_is_its_own_line(demo, clip_dir, tmp_path):
    bad = tmp_path / "mixed"
    bad.mkdir()
    shutil.copy(clip_dir / "u16" / "frame_0000.pgm", bad / "a.pgm")
    shutil.copy(clip_dir / "u8" / "frame_0001.pgm", bad / "b.pgm")   # 8-bit after 16-bit: an error
    rc, _, err = run_on_pty(demo, "--input", bad, "--model", "none")
    lines = err.replace("\r\n", "\n").rstrip("\n").split("\n")
    assert rc == 1 and "\r[1/2 50%]" in lines[-2], lines
    assert lines[-1].startswith("vd_fir_demo: error: "), lines   # not appended to the progress line


def test_report_path_named_on_stderr(demo, clip_dir, tmp_path):
    p = run(demo, "--input", clip_dir / "u8", "--model", "none", "--frames", 3, "--report", tmp_path / "r")
    assert p.stderr.splitlines()[-1] == f"vd_fir_demo: report {tmp_path / 'r'}/index.html"
    assert run(demo, "--input", clip_dir / "u8", "--model", "none", "--frames", 3, "--report", tmp_path / "q",
               "--quiet").stderr == ""
