# SPDX-License-Identifier: MIT
"""vd-adapt: fit the shipped networks to your camera from its own frames (docs/adapt.md).

    vd-adapt --images DIR [--labels DIR|FILE.json] [--classes 2[,3...]] --out DIR [--minutes 15] [--val-frac 0.25]

With labels (a YOLO folder or COCO JSON; a frame without labels has no vehicles): the frames are split into an
adapt part and a val part by blocks of file-name order; the shipped float networks (models/float/vd_cnn.npz
and vd_cnn2.npz, the pair the demo runs) are fine-tuned quantisation-aware on the adapt part mixed with
../shared/data's training frames (when present, so that they do not forget what they knew), exported as
int8 .vdm files, and the score threshold is chosen on the val part. Without labels: self-training on
pseudo-labels of the shipped pair (its fused flip passes, a high score threshold, boxes of middling score
as ignore regions; iterated with the adapted networks' own labels), threshold unchanged.

OUT holds vd_cnn.vdm / vd_cnn2.vdm (+ the firmware arrays NAME_vdm.c/.h, the export scales, the float
weights), vd.json (settings for `vd_fir_demo --config` and the GStreamer element's config property) and
report.md / report.json: before / after AP@0.5 and TP / FP on the val part through the C library, the time
taken, the command. OUT appears complete or not at all: the run works in OUT.tmp-<key> beside it, which
keeps its checkpoints until the end, so the same command run again resumes there. Bad input gets one line
on stderr and exit status 2 before anything is written.
"""
import argparse
import hashlib
import json
import os
import shlex
import shutil
import sys
import time
from pathlib import Path

from vdtools.adapt import inputs as I
from vdtools.adapt.inputs import InputError
from vdtools.bindings import clib

SHIPPED_FLOAT = (clib.REPO / "models" / "float" / "vd_cnn.npz", clib.REPO / "models" / "float" / "vd_cnn2.npz")
SHIPPED_VDM = (clib.REPO / "models" / "vd_cnn.vdm", clib.REPO / "models" / "vd_cnn2.vdm")
NAMES = ("vd_cnn", "vd_cnn2")
MAX_PEAKS = (100, 80)           # the shipped pair's top-K (vd_cnn2's 80 keeps the pair's workspace in budget)
BASE_THR = 0.3                  # header threshold of a base exported here (not the shipped pair)
REPLAY_SHARE = {"msrs": 0.6, "hit": 0.4}   # the shipped recipe's crop shares, for the replayed frames
PSEUDO_HI = 0.5                 # self-training: fused pair score of a pseudo-labelled vehicle
PSEUDO_LO = 0.1                 # ... and of an uncertain box, an ignore region (no loss either way)
EXIT_INPUT, EXIT_INTERRUPTED = 2, 3


class _Parser(argparse.ArgumentParser):
    def error(self, message):               # one line, not argparse's usage + error
        raise InputError(message)


def parser():
    ap = _Parser(prog="vd-adapt", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--images", required=True, help="folder of your camera's frames (PNG, JPEG or PGM; 8 or 16 bit)")
    ap.add_argument("--labels", help="YOLO label folder (<stem>.txt) or COCO JSON; without it: self-training")
    ap.add_argument("--classes", help="vehicle class ids or names, comma separated (default: classes named car, "
                    "vehicle, truck, bus, van, othervehicle; else the only class the labels use)")
    ap.add_argument("--out", required=True, help="new folder for the adapted models, vd.json and the report")
    ap.add_argument("--minutes", type=float, default=15.0, help="wall-time budget of the whole run (default 15)")
    ap.add_argument("--steps", type=int, default=0, help="training steps instead of a time budget (the "
                    "cosine schedule runs over them; --minutes then does not bound the run)")
    ap.add_argument("--val-frac", type=float, default=0.25, help="share of the frames (whole blocks) kept to "
                    "choose the threshold and measure before / after (default 0.25)")
    ap.add_argument("--block", type=int, help="frames per block of the split (default ceil(frames / 16), >= 2)")
    ap.add_argument("--base", help="float networks to adapt, one or two comma separated (.npz of models/float "
                    "or cnn_train checkpoints; default the shipped pair)")
    ap.add_argument("--before", help="their int8 files, for the 'before' figures (default: the shipped pair "
                    "with the default --base, else the base quantised here)")
    ap.add_argument("--data", default=str(clib.DATA_DIR), help="../shared/data, mixed in when present")
    ap.add_argument("--replay", default="msrs,hit", help="families of --data mixed in: msrs, hit, both "
                    "(default) or none")
    ap.add_argument("--user-share", type=float, default=0.5, help="share of your frames among the training "
                    "crops when frames are mixed in (default 0.5)")
    ap.add_argument("--rounds", type=int, default=2, help="self-training rounds without labels (default 2)")
    ap.add_argument("--threads", type=int, default=2, help="PyTorch threads (default 2)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--demo", help="vd_fir_demo to check OUT/vd.json with (default: the build's, when present)")
    ap.add_argument("--quiet", action="store_true", help="no progress bar")
    ap.add_argument("--interrupt-after", type=int, help=argparse.SUPPRESS)   # tests: stop as if killed
    return ap


def _say(a, msg):
    if not a.quiet:
        print(f"vd-adapt: {msg}", flush=True)


# ---------------------------------------------------------------- checks (no PyTorch, nothing written)

def _check_out(out):
    out = Path(out).absolute()
    if out.exists() and not (out.is_dir() and not any(out.iterdir())):
        raise InputError(f"--out {out}: exists and is not an empty folder (vd-adapt writes a new one)")
    parent = out.parent
    if not parent.is_dir():
        raise InputError(f"--out {out}: its parent {parent} is not an existing folder")
    probe = parent / f".{out.name}.probe-{os.getpid()}"
    try:
        probe.mkdir()
        probe.rmdir()
    except OSError as e:
        raise InputError(f"--out {out}: cannot write in {parent} ({e.strerror or e})")
    return out


def _paths(spec, what):
    ps = [Path(p.strip()) for p in spec.split(",") if p.strip()]
    if not 1 <= len(ps) <= 2:
        raise InputError(f"--{what}: one or two files, comma separated")
    for p in ps:
        if not p.is_file():
            raise InputError(f"--{what} {p}: no such file")
    return ps


def prepare(a):
    """Every check of the arguments and the input; returns the plan dict. Raises InputError."""
    if a.minutes <= 0:
        raise InputError("--minutes must be > 0")
    if not 0 < a.val_frac < 1:
        raise InputError("--val-frac must be between 0 and 1")
    if a.steps < 0 or a.rounds < 1 or a.threads < 1 or not 0 < a.user_share <= 1:
        raise InputError("--steps >= 0, --rounds >= 1, --threads >= 1 and 0 < --user-share <= 1")
    if a.block is not None and a.block < 1:
        raise InputError("--block must be >= 1")
    replay = [] if a.replay == "none" else [f.strip() for f in a.replay.split(",") if f.strip()]
    if any(f not in REPLAY_SHARE for f in replay):
        raise InputError(f"--replay: msrs, hit or none, comma separated (got {a.replay!r})")
    out = _check_out(a.out)
    bases = _paths(a.base, "base") if a.base else list(SHIPPED_FLOAT)
    if a.before:
        before = _paths(a.before, "before")
        if len(before) != len(bases):
            raise InputError("--before: one int8 file per --base network")
    else:
        before = list(SHIPPED_VDM) if not a.base else None
    for p in bases + (before or []):
        if not Path(p).is_file():
            raise InputError(f"{p}: missing (a checkout without its models?)")
    files = I.list_frames(a.images)
    frames = I.read_frames(files)
    label_info = None
    if a.labels:
        label_info = I.read_labels(a.labels, frames, a.classes)
    elif a.classes:
        raise InputError("--classes names classes of --labels: give --labels too")
    block = I.split_blocks(frames, a.val_frac, a.block, need_vehicles=a.labels is not None)
    try:
        clib.load()
    except OSError as e:
        raise InputError(f"the C library is needed for the figures: not found at {clib.lib_path()} "
                         f"({str(e).splitlines()[0]}); build it or set VD_LIB")
    data = Path(a.data)
    if replay and not data.is_dir():
        replay = []
    key = hashlib.sha1(json.dumps(dict(
        images=[(f.name, f.stat().st_size, int(f.stat().st_mtime)) for f in files],
        labels=None if not a.labels else [str(Path(a.labels).resolve()), Path(a.labels).stat().st_mtime],
        classes=a.classes, bases=[str(Path(p).resolve()) for p in bases], minutes=a.minutes, steps=a.steps,
        val_frac=a.val_frac, block=block, seed=a.seed, replay=replay, user_share=a.user_share, rounds=a.rounds,
        data=str(data.resolve()))).encode()).hexdigest()[:10]
    return dict(out=out, tmp=out.parent / f"{out.name}.tmp-{key}", frames=frames, labels=label_info, block=block,
                bases=[Path(p) for p in bases], before=[Path(p) for p in before] if before else None,
                replay=replay, data=data)


# ---------------------------------------------------------------- the run

def _find_demo(a):
    if a.demo:
        return Path(a.demo)
    for cand in (Path(os.environ.get("VD_BUILD_DIR", clib.lib_path().parent)) / "tools" / "vd_fir_demo",
                 clib.REPO / "build" / "tools" / "vd_fir_demo"):
        if cand.is_file():
            return cand
    found = shutil.which("vd_fir_demo")
    return Path(found) if found else None


def config(models, thr):
    """vd_fir_demo --config settings: the adapted networks, their operating point, the fused flip pass."""
    return {"sources": "cnn", "cnn-model": str(models[0]),
            "cnn-model2": str(models[1]) if len(models) > 1 else "none",
            "cnn-thr": round(float(thr), 4), "cnn-flip": True}


def check_config(demo, cfg_path, frame_path, work):
    """Runs vd_fir_demo --config on one frame; (True, detections) or (False, its error line)."""
    import subprocess
    js = work / "check.jsonl"
    p = subprocess.run([str(demo), "--config", str(cfg_path), "--input", str(frame_path), "--temporal", "off",
                        "--json", str(js), "--quiet"], capture_output=True, text=True, timeout=300)
    if p.returncode != 0:
        return False, (p.stderr.strip().splitlines() or ["exit %d" % p.returncode])[-1]
    rec = json.loads(js.read_text().splitlines()[0])
    js.unlink()
    return True, len(rec["detections"])


def _atomic_torch_save(torch, obj, path):
    tmp = path.with_suffix(".part")
    torch.save(obj, tmp)
    os.replace(tmp, path)


def run(a, plan, t_start, argv):
    """The adaptation in plan["tmp"], renamed to OUT at the end; a fresh work folder goes again when the
    run stops on an InputError (e.g. a budget too small for the frames)."""
    fresh = not (plan["tmp"] / "ckpt.pt").is_file()
    try:
        return _run(a, plan, t_start, argv)
    except InputError:
        if fresh:
            shutil.rmtree(plan["tmp"], ignore_errors=True)
        raise


def _run(a, plan, t_start, argv):
    import torch
    from tqdm import tqdm

    from vdtools.adapt import measure as M
    from vdtools.adapt import tune as TU
    from vdtools.data import cnn_data as CD
    from vdtools.formats import cnn_vdm as V
    from vdtools.training import cnn_export as E

    torch.set_num_threads(a.threads)
    tmp, out, frames = plan["tmp"], plan["out"], plan["frames"]
    resumed = tmp.is_dir() and (tmp / "ckpt.pt").is_file()
    tmp.mkdir(exist_ok=True)
    ck = torch.load(tmp / "ckpt.pt", weights_only=False) if resumed else None
    times = dict(ck["times"]) if ck else {}
    t_prev = ck["wall"] if ck else 0.0          # wall time of earlier, interrupted runs
    labelled = plan["labels"] is not None
    n_nets = len(plan["bases"])
    names, peaks = NAMES[:n_nets], MAX_PEAKS[:n_nets]
    if resumed:
        _say(a, f"resuming in {tmp.name} from step {ck['tuner']['step']}")

    t0 = time.time()
    replay = []
    if plan["replay"]:
        _say(a, f"reading the training frames of {plan['data']} ({', '.join(plan['replay'])}) to mix in")
        replay = [f for f in CD.load_frames(plan["data"], splits=("train",)) if CD.family(f) in plan["replay"]]
    by_fam = {}
    for f in replay:
        by_fam.setdefault(CD.family(f), []).append(f)
    times["read"] = times.get("read", 0.0) + (time.time() - t0)
    adapt = [TU.user_frame(f) for f in frames if f.part == "adapt"]
    val = [TU.user_frame(f) for f in frames if f.part == "val"]
    calib = TU.calibration_set(adapt, replay, a.seed)
    nets, archs = zip(*[TU.load_base(p) for p in plan["bases"]])

    # before: the shipped files, or the base quantised here (calibrated on what it was trained on)
    t0 = time.time()
    before = plan["before"]
    if before is None:
        bdir = tmp / "before"
        bdir.mkdir(exist_ok=True)
        before = []
        calib_before = E.calibration_frames(replay) if replay else calib    # what the base was trained on
        for net, name, mp in zip(nets, names, peaks):
            path = bdir / f"{name}.vdm"
            if not path.is_file():
                path.write_bytes(TU.export(net, calib_before, BASE_THR, name, mp)[1])
            before.append(path)
        times["before_export"] = time.time() - t0
        t0 = time.time()
    thr_before = M.header_threshold(before)
    res_before = M.detections(before, val)
    if labelled:
        fig_before = M.figures(res_before, thr_before)
        thr_before_val = M.choose_threshold(res_before)
        fig_before_val = M.figures(res_before, thr_before_val)
    times["before"] = time.time() - t0
    _say(a, f"{len(frames)} frames: {len(adapt)} adapt, {len(val)} val; before: "
         + (f"val AP@0.5 {100 * fig_before['ap']:.1f}" if labelled
            else f"{M.boxes_per_frame(res_before, thr_before):.2f} boxes per val frame"))

    tuner = TU.Tuner(nets, a.seed)
    if ck:
        tuner.load(ck["tuner"])
    else:
        times["calibrate"] = tuner.start(calib)
    # budget: what is left after reading, measuring and calibrating, less what measuring and exporting
    # after training will take (an export calibrates on 3x the frames; self-training exports and labels per round)
    if ck:
        budget = ck["budget"]
    elif a.steps:
        budget = 0.0
    else:
        per_frame = times["before"] / max(len(val), 1)
        export_s = times["calibrate"] * len(calib) / max(len(TU.train_calib(calib)), 1)
        reserve = 20.0 + 1.5 * times["before"] + export_s + \
            (0 if labelled else a.rounds * per_frame * len(adapt) + (a.rounds - 1) * export_s + 2 * times["before"])
        budget = a.minutes * 60.0 - (time.time() - t_start) - reserve
        if budget < 20.0:
            raise InputError(f"--minutes {a.minutes:g} leaves no time to train after reading and measuring "
                             f"({(a.minutes * 60 - budget) / 60:.1f} min); give more minutes or fewer frames")
    shares = {"user": a.user_share if by_fam else 1.0}
    rs = sum(REPLAY_SHARE[f] for f in by_fam)
    shares.update({f: (1 - shares["user"]) * REPLAY_SHARE[f] / rs for f in by_fam})

    pseudo_log = ck["pseudo_log"] if ck else []
    start_round = ck["round"] if ck else 0
    pseudo = ck.get("pseudo") if ck else None

    def save(tu):
        _atomic_torch_save(torch, dict(tuner=tu.state(), budget=budget, times=times, pseudo_log=pseudo_log,
                                       round=state["round"], pseudo=state["pseudo"],
                                       wall=t_prev + time.time() - t_start), tmp / "ckpt.pt")

    state = dict(round=start_round, pseudo=pseudo)
    total = a.steps if a.steps else 100
    bar = tqdm(total=total, disable=a.quiet, unit="step" if a.steps else "%", file=sys.stderr,
               bar_format="{l_bar}{bar}| {n_fmt}/{total_fmt} [{elapsed}<{remaining}{postfix}]")

    def on_step(tu, losses):
        n = tu.step if a.steps else min(100, int(100 * tu.progress(0, budget)))
        bar.update(n - bar.n)
        bar.set_postfix_str(f"loss {' '.join(f'{v:.2f}' for v in losses)}", refresh=False)

    on_step(tuner, [])
    t0 = time.time()
    done = True
    rounds = 1 if labelled else a.rounds
    for r in range(start_round, rounds):
        state["round"] = r
        user = adapt
        if not labelled:
            if state["pseudo"] is None:       # pseudo-labels of this round: the base pair, then the adapted one
                if r == 0:
                    models = before
                else:
                    rdir = tmp / f"round-{r}"
                    rdir.mkdir(exist_ok=True)
                    models = []
                    for net, name, mp in zip(nets, names, peaks):
                        models.append(rdir / f"{name}.vdm")
                        models[-1].write_bytes(TU.export(net, calib, BASE_THR, name, mp)[1])
                res = M.detections(models, adapt)
                state["pseudo"] = [([d[0] for d in dets if d[1] >= PSEUDO_HI],
                                    [d[0] for d in dets if PSEUDO_LO <= d[1] < PSEUDO_HI]) for _, _, dets, _ in res]
                pseudo_log.append(dict(round=r, vehicles=sum(len(p[0]) for p in state["pseudo"]),
                                       ignore=sum(len(p[1]) for p in state["pseudo"]),
                                       frames_with_vehicles=sum(1 for p in state["pseudo"] if p[0])))
            src = [f for f in frames if f.part == "adapt"]
            user = [TU.user_frame(f, b, ig) for f, (b, ig) in zip(src, state["pseudo"])]
        done = tuner.train(dict(by_fam, user=user), shares, calib, (r + 1) / rounds, a.steps, budget,
                           on_step=on_step, save=save, interrupt_after=a.interrupt_after)
        if not done:
            break
        state["pseudo"] = None
        state["round"] = r + 1
        save(tuner)
    bar.close()
    times["train"] = times.get("train", 0.0) + (time.time() - t0)
    if not done:
        save(tuner)
        print(f"vd-adapt: interrupted after step {tuner.step}; run the same command again to resume "
              f"(checkpoint in {tmp})", file=sys.stderr)
        return EXIT_INTERRUPTED

    # export, threshold on val, outputs
    t0 = time.time()
    exported = [TU.export(net, calib, BASE_THR, name, mp) for net, name, mp in zip(nets, names, peaks)]
    mdir = tmp / "models-check"
    mdir.mkdir(exist_ok=True)
    check_models = []
    for (desc, blob, _), name in zip(exported, names):
        check_models.append(mdir / f"{name}.vdm")
        check_models[-1].write_bytes(blob)
    res_after = M.detections(check_models, val)
    if labelled:
        thr = M.choose_threshold(res_after)
        fig_after = M.figures(res_after, thr)
    else:
        thr = thr_before
    final = [out / f"{n}.vdm" for n in names]
    (tmp / "float").mkdir(exist_ok=True)
    for (desc, _, meta), net, name, arch in zip(exported, nets, names, archs):
        blob = TU.with_threshold(desc, meta, thr)
        V.write_c_array(blob, name, tmp)
        (tmp / f"{name}.scales.json").write_text(json.dumps(dict(meta, arch=arch, step=tuner.step, thr=thr,
                                                                 adapted_by="vd-adapt"), indent=1) + "\n")
        net.set_fake_quant(None)
        net.eval()
        E.save_float(net, dict(arch=arch, step=tuner.step, qat=True), tmp / "float" / f"{name}.npz")
    cfg = config(final, thr)
    (tmp / "vd.json").write_text(json.dumps(cfg, indent=1) + "\n")
    times["export"] = time.time() - t0

    demo, demo_check = _find_demo(a), None
    if demo is not None and demo.is_file():
        cp = tmp / "vd.check.json"
        cp.write_text(json.dumps(config([tmp / f"{n}.vdm" for n in names], thr)))
        ok, what = check_config(demo, cp, val[0].path, tmp)
        cp.unlink()
        if not ok:
            raise RuntimeError(f"vd_fir_demo rejected the config vd-adapt wrote: {what}")
        demo_check = dict(demo=demo.name, accepted=True, frame=Path(val[0].path).name, detections=what)

    rep = dict(
        command=shlex.join(["vd-adapt"] + list(argv)), labelled=labelled,
        frames=dict(count=len(frames), size=list(frames[0].img.shape[::-1]), block=plan["block"],
                    adapt=len(adapt), val=len(val), adapt_vehicles=int(sum(len(f.boxes) for f in adapt)),
                    val_vehicles=int(sum(len(f.boxes) for f in val)),
                    val_blocks=sorted({f.block for f in frames if f.part == "val"})),
        labels=plan["labels"], base=[str(p) for p in plan["bases"]], archs=archs,
        before_models=[str(p) for p in before] if plan["before"] else [f"before/{p.name}" for p in before],
        before_quantised_here=plan["before"] is None,
        replay=dict(families={k: len(v) for k, v in by_fam.items()}, shares=shares, data=str(plan["data"])),
        training=dict(steps=tuner.step, budget_s=round(budget, 1) if not a.steps else None, steps_asked=a.steps,
                      rounds=rounds, resumed=bool(resumed), lr=TU.LR, batch=TU.BATCH, threads=a.threads,
                      last_losses=tuner.losses[-1][1] if tuner.losses else None),
        threshold=dict(before=thr_before, after=thr, chosen_on="val part" if labelled else "unchanged (no labels)"),
        outputs=dict(models=[f.name for f in final], config="vd.json", demo_check=demo_check),
    )
    if labelled:
        rep["val"] = dict(before=fig_before, before_at_val_choice=fig_before_val, after=fig_after)
    else:
        rep["pseudo_labels"] = pseudo_log
        rep["val"] = dict(
            boxes_per_frame=dict(before=M.boxes_per_frame(res_before, thr_before), after=M.boxes_per_frame(res_after, thr)),
            flip_agreement=dict(before=M.flip_agreement(before, val, thr_before),
                                after=M.flip_agreement(check_models, val, thr)),
            before_after_agreement=M.agreement(res_before, thr_before, res_after, thr))
    rep["rules"] = M.rules(before, check_models, frames[0].img.shape[1], frames[0].img.shape[0])
    shutil.rmtree(mdir)
    wall = t_prev + time.time() - t_start
    times = {k: round(v, 1) for k, v in times.items()}
    cpu = os.times()
    rep["time"] = dict(wall_s=round(wall, 1), this_run_s=round(time.time() - t_start, 1), parts_s=times,
                       minutes_asked=a.minutes, this_run_cpu_s=round(cpu.user + cpu.system + cpu.children_user
                                                                     + cpu.children_system, 1))
    (tmp / "report.json").write_text(json.dumps(rep, indent=1, default=float) + "\n")
    (tmp / "report.md").write_text(report_md(rep))
    (tmp / "ckpt.pt").unlink(missing_ok=True)
    for q in tmp.glob("round-*"):
        shutil.rmtree(q)
    os.rename(tmp, out)
    _say(a, f"wrote {out} in {wall / 60:.1f} min: " +
         (f"val AP@0.5 {100 * fig_before['ap']:.1f} -> {100 * fig_after['ap']:.1f}" if labelled else
          f"boxes per val frame {rep['val']['boxes_per_frame']['before']:.2f} -> {rep['val']['boxes_per_frame']['after']:.2f}"))
    return 0


def _pct(v):
    return "–" if v is None else f"{100 * v:.1f}"


def report_md(r):
    f, t = r["frames"], r["training"]
    lines = ["# vd-adapt report", "", f"Command: `{r['command']}`", "",
             f"Time taken: {r['time']['wall_s'] / 60:.1f} min wall ("
             + (f"budget {r['time']['minutes_asked']:g} min" if not t["steps_asked"] else f"{t['steps_asked']} steps asked")
             + "; " + ", ".join(f"{k} {v:.0f} s" for k, v in r["time"]["parts_s"].items())
             + f"; {r['time']['this_run_cpu_s'] / 60:.1f} CPU minutes in this run)"
             + (", resumed from a checkpoint" if t["resumed"] else "") + ".", "",
             f"Frames: {f['count']} of {f['size'][0]}×{f['size'][1]}, in blocks of {f['block']} by file name: "
             f"{f['adapt']} to adapt on, {f['val']} to measure on (val; blocks {f['val_blocks']})."]
    if r["labelled"]:
        lab = r["labels"]
        lines += [f"Labels: {lab['kind']}, {lab['matched']} frames labelled (the others have no vehicles), vehicle "
                  f"classes {lab['vehicle_classes']}; {f['adapt_vehicles']} vehicles to adapt on, "
                  f"{f['val_vehicles']} to measure on.", ""]
    else:
        lines += ["Labels: none (self-training on pseudo-labels of the networks themselves).", ""]
    lines += [f"Networks: {', '.join(r['archs'])} from {', '.join(Path(b).name for b in r['base'])}; "
              f"quantisation-aware fine-tuning, {t['steps']} steps of batch {t['batch']} (lr {t['lr']:g}, "
              f"{t['threads']} threads)" + (f", {t['rounds']} self-training rounds" if not r["labelled"] else "")
              + "; training frames of ../shared/data mixed in: "
              + (", ".join(f"{k} {v} frames" for k, v in r["replay"]["families"].items()) or "none")
              + f" (crop shares {', '.join(f'{k} {v:.2f}' for k, v in r['replay']['shares'].items())}).", ""]
    if r["labelled"]:
        b, bv, a = r["val"]["before"], r["val"]["before_at_val_choice"], r["val"]["after"]
        lines += ["## Before / after on your val frames (the C library, fused flip passes)", "",
                  f"{b['n_frames']} frames, {b['n_vehicles']} vehicles. TP / FP rates: TP / vehicles and "
                  "FP / detections at the threshold.", "",
                  "| networks | AP@0.5 | threshold | TP | FP | TP rate | FP rate |", "|---|---:|---:|---:|---:|---:|---:|",
                  f"| before, its own threshold | {_pct(b['ap'])} | {b['thr']:.3f} | {b['tp']} | {b['fp']} | "
                  f"{_pct(b['tp_rate'])} % | {_pct(b['fp_rate'])} % |",
                  f"| before, threshold chosen on val | {_pct(bv['ap'])} | {bv['thr']:.3f} | {bv['tp']} | {bv['fp']} | "
                  f"{_pct(bv['tp_rate'])} % | {_pct(bv['fp_rate'])} % |",
                  f"| **after** (threshold chosen on val) | **{_pct(a['ap'])}** | {a['thr']:.3f} | {a['tp']} | {a['fp']} | "
                  f"{_pct(a['tp_rate'])} % | {_pct(a['fp_rate'])} % |", "",
                  "The val part chose the threshold, so its after figures lean optimistic; with few val vehicles "
                  "they are noisy too. Measure on frames of other scenes before you rely on them."]
    else:
        v = r["val"]
        lines += ["## What can be measured without labels", "",
                  "**Without labels the gain is not measured**: these figures say how the output changed, not "
                  "whether it got better.", "",
                  "| on the val frames | before | after |", "|---|---:|---:|",
                  f"| boxes per frame at the threshold ({r['threshold']['after']:.3f}) | "
                  f"{v['boxes_per_frame']['before']:.2f} | {v['boxes_per_frame']['after']:.2f} |",
                  f"| flip agreement (boxes found on the frame and on its mirror image) | "
                  f"{_pct(v['flip_agreement']['before'])} % | {_pct(v['flip_agreement']['after'])} % |", "",
                  f"Boxes in common before / after: {_pct(v['before_after_agreement'])} %. Pseudo-labels per round "
                  f"(score >= {PSEUDO_HI}; {PSEUDO_LO}..{PSEUDO_HI} ignored): "
                  + "; ".join(f"round {p['round']}: {p['vehicles']} vehicles in {p['frames_with_vehicles']} frames, "
                              f"{p['ignore']} ignored" for p in r["pseudo_labels"]) + "."]
    dc, ru = r["outputs"]["demo_check"], r["rules"]
    lines += ["", f"Library rules: the adapted files have the same layers and top-K as before "
              f"({'yes' if all(ru['same_layers_and_top_k']) else 'NO'}), so the same multiply-adds; detector "
              f"workspace at {f['size'][0]}×{f['size'][1]} with the flip pass {ru['workspace_bytes']['after']} B "
              f"(before {ru['workspace_bytes']['before']} B); model files {ru['file_bytes']['after']} B.",
              "", "## Outputs", "",
              "- " + ", ".join(f"`{m}`" for m in r["outputs"]["models"]) + ": the adapted int8 networks (header "
              f"threshold {r['threshold']['after']:.3f}); `NAME_vdm.c` / `NAME_vdm.h`: the same bytes as firmware "
              "arrays; `NAME.scales.json`: the export's scales; `float/NAME.npz`: the float weights (to adapt again: "
              "`--base`)" + ("; `before/`: the base networks as quantised here, the before figures' files"
                              if r["before_quantised_here"] else "") + ".",
              "- `vd.json`: `vd_fir_demo --config OUT/vd.json --input FRAMES` (or the GStreamer element's `config` "
              "property) runs them" + (f"; checked with {dc['demo']} on {dc['frame']}" if dc else
                                        "; vd_fir_demo was not found, so it was not run here") + ".", ""]
    return "\n".join(lines)


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    t_start = time.time()
    try:
        a = parser().parse_args(argv)
        plan = prepare(a)
        try:
            import torch  # noqa: F401
        except ImportError:
            raise InputError("PyTorch is not installed: pip install torch (the CPU build is enough)")
        return run(a, plan, t_start, argv)
    except InputError as e:
        print(f"vd-adapt: error: {e}", file=sys.stderr)
        return EXIT_INPUT
