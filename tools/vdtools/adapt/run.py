# SPDX-License-Identifier: MIT
"""One vd-adapt run after its input was checked (cli.prepare): in the work folder OUT.tmp-<key>, read the
replayed frames, measure the networks before, train (resuming from the folder's checkpoint), export, choose
the threshold, check vd.json with vd_fir_demo, write the report, rename the folder to OUT."""
import json
import os
import shlex
import shutil
import sys
import time
from pathlib import Path

import torch
from tqdm import tqdm

from vdtools.adapt import measure as M
from vdtools.adapt import tune as TU
from vdtools.adapt.inputs import InputError
from vdtools.adapt.report import measured as measured_text, report_md
from vdtools.bindings import clib
from vdtools.bindings.detector import CNN_RES_NAMES
from vdtools.data import cnn_data as CD
from vdtools.formats import cnn_vdm as V
from vdtools.training import cnn_export as E

NAMES = ("vd_cnn", "vd_cnn2")
MAX_PEAKS = (100, 80)           # the shipped pair's top-K (vd_cnn2's 80 keeps the pair's workspace in budget)
BASE_THR = 0.3                  # header threshold of a base exported here (not the shipped pair)
REPLAY_SHARE = {"msrs": 0.6, "hit": 0.4}   # the shipped recipe's crop shares, for the replayed frames
PSEUDO_HI = 0.5                 # self-training: fused pair score of a pseudo-labelled vehicle
PSEUDO_LO = 0.1                 # ... and of an uncertain box, an ignore region (no loss either way)
EXIT_INTERRUPTED = 3


def find_demo(path=None):
    """vd_fir_demo: path, else the build's (beside VD_BUILD_DIR / the library, or build/), else on PATH."""
    if path:
        return Path(path)
    for cand in (Path(os.environ.get("VD_BUILD_DIR", clib.lib_path().parent)) / "tools" / "vd_fir_demo",
                 clib.REPO / "build" / "tools" / "vd_fir_demo"):
        if cand.is_file():
            return cand
    found = shutil.which("vd_fir_demo")
    return Path(found) if found else None


def config(models, thr, res=0, invert=False):
    """vd_fir_demo --config settings: the adapted networks, their operating point, the fused flip pass and the
    input resolution (cfg.cnn_res res) and polarity chosen here, always written (the demo's own defaults, auto, would measure them
    again with less evidence than vd-adapt had, and would judge the adapted networks by the shipped ones'
    white-hot habit). invert: the user's frames were inverted before adaptation (a black-hot camera), so the
    detector reads them black-hot (cfg.cnn_invert)."""
    return {"sources": "cnn", "cnn-model": str(models[0]),
            "cnn-model2": str(models[1]) if len(models) > 1 else "none",
            "cnn-thr": round(float(thr), 4), "cnn-flip": True, "cnn-res": CNN_RES_NAMES[res],
            "cnn-polarity": "black-hot" if invert else "white-hot"}


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


def run(a, plan, t_start, argv):
    """The adaptation of plan (cli.prepare) with the arguments a; 0, or EXIT_INTERRUPTED. A fresh work folder
    goes again when the run stops on an InputError (e.g. a budget too small for the frames)."""
    fresh = not (plan["tmp"] / "ckpt.pt").is_file()
    try:
        return Adaptation(a, plan, t_start, argv).run()
    except InputError:
        if fresh:
            shutil.rmtree(plan["tmp"], ignore_errors=True)
        raise


class Adaptation:
    def __init__(self, a, plan, t_start, argv):
        self.a, self.plan, self.t_start, self.argv = a, plan, t_start, argv
        self.tmp, self.out, self.frames = plan["tmp"], plan["out"], plan["frames"]
        self.labelled = plan["labels"] is not None
        self.trains = self.labelled or a.self_train   # without labels the networks are kept unless --self-train
        self.tuner = None
        n = len(plan["bases"])
        self.names, self.peaks = NAMES[:n], MAX_PEAKS[:n]
        self.resumed = (self.tmp / "ckpt.pt").is_file()
        self.ck = torch.load(self.tmp / "ckpt.pt", weights_only=False) if self.resumed else None
        self.times = dict(self.ck["times"]) if self.ck else {}
        self.t_prev = self.ck["wall"] if self.ck else 0.0       # wall time of earlier, interrupted runs
        self.state = dict(round=self.ck["round"] if self.ck else 0, pseudo=self.ck.get("pseudo") if self.ck else None,
                          log=self.ck["pseudo_log"] if self.ck else [])

    def say(self, msg):
        if not self.a.quiet:
            print(f"vd-adapt: {msg}", flush=True)

    def run(self):
        torch.set_num_threads(self.a.threads)
        self.tmp.mkdir(exist_ok=True)
        if self.resumed:
            self.say(f"resuming in {self.tmp.name} from step {self.ck['tuner']['step']}")
        self.load()
        self.measure_before()
        if self.trains:
            self.tuner = TU.Tuner(self.nets, self.a.seed, lr=self.a.lr)
            if self.ck:
                self.tuner.load(self.ck["tuner"])
            else:
                self.times["calibrate"] = self.tuner.start(self.calib)
            self.budget = self.ck["budget"] if self.ck else self.time_budget()
            if not self.train():
                print(f"vd-adapt: interrupted after step {self.tuner.step}; run the same command again to resume "
                      f"(checkpoint in {self.tmp})", file=sys.stderr)
                return EXIT_INTERRUPTED
            self.export()
        else:
            self.keep()
        rep = self.report()
        (self.tmp / "ckpt.pt").unlink(missing_ok=True)
        for q in self.tmp.glob("round-*"):
            shutil.rmtree(q)
        os.rename(self.tmp, self.out)
        v = rep["val"]
        self.say(f"wrote {self.out} in {rep['time']['wall_s'] / 60:.1f} min: " +
                 (f"val AP@0.5 of the output {100 * v['before']['ap_out']:.1f} -> {100 * v['after']['ap_out']:.1f}"
                  if self.labelled else
                  f"boxes per val frame {v['boxes_per_frame']['before']:.2f} -> {v['boxes_per_frame']['after']:.2f}"))
        return 0

    def load(self):
        """The replayed training frames, the user's frames as cnn_data frames, the calibration set, the nets."""
        t0, plan = time.time(), self.plan
        self.replay = []
        if plan["replay"] and (self.trains or plan["before"] is None):   # kept networks need no replay
            self.say(f"reading the training frames of {plan['data']} ({', '.join(plan['replay'])}) to mix in")
            self.replay = [f for f in CD.load_frames(plan["data"], splits=("train",)) if CD.family(f) in plan["replay"]]
        self.by_fam = {}
        for f in self.replay:
            self.by_fam.setdefault(CD.family(f), []).append(f)
        self.times["read"] = self.times.get("read", 0.0) + (time.time() - t0)
        self.adapt = [TU.user_frame(f) for f in self.frames if f.part == "adapt"]
        self.val = [TU.user_frame(f) for f in self.frames if f.part == "val"]
        self.calib = TU.calibration_set(self.adapt, self.replay, self.a.seed)
        self.nets, self.archs = zip(*[TU.load_base(p) for p in plan["bases"]])
        user = self.a.user_share if self.by_fam else 1.0
        rs = sum(REPLAY_SHARE[f] for f in self.by_fam)
        self.shares = dict(user=user, **{f: (1 - user) * REPLAY_SHARE[f] / rs for f in self.by_fam})

    def measure_before(self):
        """The before files (the shipped ones, or the base quantised here, calibrated on what it was trained
        on) and their figures on the val part."""
        t0 = time.time()
        before = self.plan["before"]
        if before is None:
            before = self.export_before("before")
            self.times["before_export"] = time.time() - t0
            t0 = time.time()
        self.before, self.thr_before = before, M.header_threshold(before)
        self.choose_polarity()
        if self.invert and self.plan["before"] is None and not self.replay:
            # quantised on the user's frames as they were: again on them inverted, as the networks will read them
            self.before = before = self.export_before("before-inverted")
        self.choose_resolution()
        self.res_before = M.detections(before, self.val, self.res)
        if self.labelled:
            self.fig_before = M.figures(self.res_before, self.thr_before)
            self.fig_before_val = M.figures(self.res_before, M.choose_threshold(self.res_before, self.thr_before))
        self.times["before"] = time.time() - t0
        self.say(f"{len(self.frames)} frames: {len(self.adapt)} adapt, {len(self.val)} val; before: "
                 + (f"val AP@0.5 of the output {100 * self.fig_before['ap_out']:.1f}" if self.labelled
                    else f"{M.boxes_per_frame(self.res_before, self.thr_before):.2f} boxes per val frame"))

    def export_before(self, folder):
        """The base networks quantised here (no int8 files given): calibrated on the replayed training frames, or
        without them on the user's frames (as self.calib holds them); files under tmp/folder, kept on a resume."""
        bdir = self.tmp / folder
        bdir.mkdir(exist_ok=True)
        calib = E.calibration_frames(self.replay) if self.replay else self.calib
        before = []
        for net, name, mp in zip(self.nets, self.names, self.peaks):
            before.append(bdir / f"{name}.vdm")
            if not before[-1].is_file():
                before[-1].write_bytes(TU.export(net, calib, BASE_THR, name, mp)[1])
        return before

    def choose_polarity(self):
        """--polarity: white-hot, black-hot, or (auto) what the before files do better on all the user's frames
        (M.choose_polarity). Black-hot: every user frame is inverted (255 - v) here, so everything after it
        (training, calibration, the figures) sees white-hot frames, and vd.json has the detector invert them."""
        if self.ck is not None and "invert" in self.ck:
            self.invert, self.pol_measured = self.ck["invert"], self.ck.get("pol_measured")
        elif self.a.polarity == "auto":
            self.invert, self.pol_measured = M.choose_polarity(self.before, self.adapt + self.val, self.thr_before,
                                                               self.labelled)
        else:
            self.invert, self.pol_measured = self.a.polarity == "black-hot", None
        if self.invert:
            self.adapt, self.val = M.inverted(self.adapt), M.inverted(self.val)
            self.calib = TU.calibration_set(self.adapt, self.replay, self.a.seed)
        if self.pol_measured:
            r = self.pol_measured
            self.say(f"polarity: {'black-hot' if self.invert else 'white-hot'} ({r['measure']} on all "
                     f"{len(self.frames)} frames: as they are {r['as_is']:.3f}, inverted {r['inverted']:.3f})")

    def choose_resolution(self):
        """--resolution: half, full, quarter, or (auto) what the before files do better on all the user's frames
        (none of which they trained on): AP@0.5 with labels, the rating without (M.choose_resolution). Full: the
        user's training frames are doubled (TU.doubled), quarter: halved (TU.halved), and so is the calibration
        set; everything measured reads the frames at that resolution."""
        if self.ck is not None and ("cnn_res" in self.ck or "full_res" in self.ck):
            self.res = self.ck.get("cnn_res", int(bool(self.ck.get("full_res"))))
            self.res_measured = self.ck.get("res_measured")
        elif self.a.resolution == "auto":
            self.res, self.res_measured = M.choose_resolution(self.before, self.adapt + self.val, self.thr_before,
                                                              self.labelled)
        else:
            self.res, self.res_measured = CNN_RES_NAMES.index(self.a.resolution), None
        if self.res:
            self.calib = TU.calibration_set([TU.at_res(f, self.res) for f in self.adapt], self.replay, self.a.seed)
        if self.res_measured:
            r = self.res_measured
            self.say(f"input resolution: {CNN_RES_NAMES[self.res]} ({r['measure']} on all "
                     f"{len(self.frames)} frames: {measured_text(r)})")

    def user_train(self, frames):
        """The user's frames as the networks train on them: doubled at full resolution, halved at quarter."""
        return [TU.at_res(f, self.res) for f in frames]

    def time_budget(self):
        """Seconds of training: what --minutes leaves after reading, measuring and calibrating, less what
        measuring and exporting afterwards take (an export calibrates on all calibration frames, the start on
        train_calib's; self-training labels and exports once per round)."""
        if self.a.steps:
            return 0.0
        t = self.times
        per_frame = t["before"] / max(len(self.val), 1)
        export_s = t["calibrate"] * len(self.calib) / max(len(TU.train_calib(self.calib)), 1)
        rounds = self.a.rounds
        reserve = 20.0 + 1.5 * t["before"] + export_s + (0.0 if self.labelled else
                                                          rounds * per_frame * len(self.adapt)
                                                          + (rounds - 1) * export_s + 2 * t["before"])
        budget = self.a.minutes * 60.0 - (time.time() - self.t_start) - reserve
        if budget < 20.0:
            raise InputError(f"--minutes {self.a.minutes:g} leaves no time to train after reading and measuring "
                             f"({(self.a.minutes * 60 - budget) / 60:.1f} min); give more minutes or fewer frames")
        return budget

    def save(self, tuner):
        path = self.tmp / "ckpt.pt"
        part = path.with_suffix(".part")
        torch.save(dict(tuner=tuner.state(), budget=self.budget, times=self.times, pseudo_log=self.state["log"],
                        round=self.state["round"], pseudo=self.state["pseudo"], cnn_res=self.res,
                        res_measured=self.res_measured, invert=self.invert, pol_measured=self.pol_measured,
                        wall=self.t_prev + time.time() - self.t_start), part)
        os.replace(part, path)

    def pseudo_labels(self, r):
        """Round r's pseudo-labels of the adapt frames: the before files' boxes, then the adapted networks'."""
        models = self.before
        if r > 0:
            rdir = self.tmp / f"round-{r}"
            rdir.mkdir(exist_ok=True)
            models = []
            for net, name, mp in zip(self.nets, self.names, self.peaks):
                models.append(rdir / f"{name}.vdm")
                models[-1].write_bytes(TU.export(net, self.calib, BASE_THR, name, mp)[1])
        res = M.detections(models, self.adapt, self.res)
        pseudo = [([d[0] for d in dets if d[1] >= PSEUDO_HI], [d[0] for d in dets if PSEUDO_LO <= d[1] < PSEUDO_HI])
                  for _, _, dets, _ in res]
        self.state["log"].append(dict(round=r, vehicles=sum(len(p[0]) for p in pseudo),
                                      ignore=sum(len(p[1]) for p in pseudo),
                                      frames_with_vehicles=sum(1 for p in pseudo if p[0])))
        return pseudo

    def train(self):
        """The training rounds (one with labels); False when interrupted (--interrupt-after)."""
        a, tuner, budget = self.a, self.tuner, self.budget
        bar = tqdm(total=a.steps or 100, disable=a.quiet, unit="step" if a.steps else "%", file=sys.stderr,
                   bar_format="{l_bar}{bar}| {n_fmt}/{total_fmt} [{elapsed}<{remaining}{postfix}]")

        def on_step(tu, losses):
            bar.update((tu.step if a.steps else min(100, int(100 * tu.progress(0, budget)))) - bar.n)
            bar.set_postfix_str(f"loss {' '.join(f'{v:.2f}' for v in losses)}", refresh=False)

        on_step(tuner, [])
        t0, done = time.time(), True
        self.rounds = 1 if self.labelled else a.rounds
        for r in range(self.state["round"], self.rounds):
            self.state["round"] = r
            user = self.user_train(self.adapt)
            if not self.labelled:
                if self.state["pseudo"] is None:
                    self.state["pseudo"] = self.pseudo_labels(r)
                src = [f for f in self.frames if f.part == "adapt"]
                user = self.user_train([TU.user_frame(f, b, ig) for f, (b, ig) in zip(src, self.state["pseudo"])])
            done = tuner.train(dict(self.by_fam, user=user), self.shares, self.calib, (r + 1) / self.rounds,
                               a.steps, budget, on_step=on_step, save=self.save, interrupt_after=a.interrupt_after)
            if not done:
                break
            self.state.update(pseudo=None, round=r + 1)
            self.save(tuner)
        bar.close()
        self.times["train"] = self.times.get("train", 0.0) + (time.time() - t0)
        return done

    def export(self):
        """The adapted .vdm files (threshold chosen on the val part with labels), their C arrays, scales and
        float weights, vd.json; the check of vd.json with vd_fir_demo."""
        t0, tmp = time.time(), self.tmp
        exported = [TU.export(net, self.calib, BASE_THR, name, mp) for net, name, mp in zip(self.nets, self.names,
                                                                                              self.peaks)]
        mdir = tmp / "models-check"
        mdir.mkdir(exist_ok=True)
        self.after = []
        for (_, blob, _), name in zip(exported, self.names):
            self.after.append(mdir / f"{name}.vdm")
            self.after[-1].write_bytes(blob)
        self.res_after = M.detections(self.after, self.val, self.res)
        self.thr = M.choose_threshold(self.res_after, self.thr_before) if self.labelled else self.thr_before
        (tmp / "float").mkdir(exist_ok=True)
        for (desc, _, meta), net, name, arch in zip(exported, self.nets, self.names, self.archs):
            V.write_c_array(TU.with_threshold(desc, meta, self.thr), name, tmp)
            (tmp / f"{name}.scales.json").write_text(json.dumps(dict(meta, arch=arch, step=self.tuner.step,
                                                                     thr=self.thr, adapted_by="vd-adapt"), indent=1) + "\n")
            net.set_fake_quant(None)
            net.eval()
            # norm: the input normalisation the network reads (vd_cnn2: equalise); --base reads it back
            E.save_float(net, dict(arch=arch, step=self.tuner.step, qat=True, norm=net.norm),
                         tmp / "float" / f"{name}.npz")
        self.times["export"] = time.time() - t0
        self.write_config()

    def keep(self):
        """Without labels and without --self-train: the before networks unchanged (self-training lowered AP on
        every proxy measured with the shipped pair: docs/results/adapt.md, section E), at the resolution chosen
        on the user's frames, threshold unchanged; the same outputs as export()."""
        t0, tmp = time.time(), self.tmp
        mdir = tmp / "models-check"
        mdir.mkdir(exist_ok=True)
        (tmp / "float").mkdir(exist_ok=True)
        self.after, self.thr, self.res_after = [], self.thr_before, self.res_before
        for src, base, net, name, arch in zip(self.before, self.plan["bases"], self.nets, self.names, self.archs):
            blob = Path(src).read_bytes()
            self.after.append(mdir / f"{name}.vdm")
            self.after[-1].write_bytes(blob)
            V.write_c_array(blob, name, tmp)
            scales = Path(src).with_suffix(".scales.json")
            meta = json.loads(scales.read_text()) if scales.is_file() else {}
            (tmp / f"{name}.scales.json").write_text(json.dumps(dict(meta, arch=arch, thr=self.thr, kept=True,
                                                                     adapted_by="vd-adapt"), indent=1) + "\n")
            if Path(base).suffix == ".npz":
                shutil.copyfile(base, tmp / "float" / f"{name}.npz")
            else:
                net.eval()
                E.save_float(net, dict(arch=arch, step=0, qat=False, norm=net.norm), tmp / "float" / f"{name}.npz")
        self.times["export"] = time.time() - t0
        self.write_config()

    def write_config(self):
        """vd.json, and its check with vd_fir_demo on a val frame."""
        tmp = self.tmp
        (tmp / "vd.json").write_text(json.dumps(config([self.out / f"{n}.vdm" for n in self.names], self.thr,
                                                       self.res, self.invert), indent=1) + "\n")
        self.demo_check = None
        demo = find_demo(self.a.demo)
        if demo is not None and demo.is_file():
            cp = tmp / "vd.check.json"
            cp.write_text(json.dumps(config([tmp / f"{n}.vdm" for n in self.names], self.thr, self.res, self.invert)))
            ok, what = check_config(demo, cp, self.val[0].path, tmp)
            cp.unlink()
            if not ok:
                raise RuntimeError(f"vd_fir_demo rejected the config vd-adapt wrote: {what}")
            self.demo_check = dict(demo=demo.name, accepted=True, frame=Path(self.val[0].path).name, detections=what)

    def report(self):
        """report.json and report.md in the work folder; returns the report."""
        plan, f, tuner = self.plan, self.frames, self.tuner
        rep = dict(
            command=shlex.join(["vd-adapt"] + list(self.argv)), labelled=self.labelled,
            frames=dict(count=len(f), size=list(f[0].img.shape[::-1]), block=plan["block"], adapt=len(self.adapt),
                        val=len(self.val), adapt_vehicles=int(sum(len(x.boxes) for x in self.adapt)),
                        val_vehicles=int(sum(len(x.boxes) for x in self.val)),
                        val_blocks=sorted({x.block for x in f if x.part == "val"})),
            labels=plan["labels"], base=[str(p) for p in plan["bases"]], archs=list(self.archs),
            before_models=[str(p) for p in self.before] if plan["before"] else [f"{p.parent.name}/{p.name}" for p in self.before],
            before_quantised_here=plan["before"] is None,
            replay=dict(families={k: len(v) for k, v in self.by_fam.items()}, shares=self.shares, data=str(plan["data"])),
            training=dict(trained=self.trains, self_train=self.a.self_train, steps=tuner.step if tuner else 0,
                          budget_s=round(self.budget, 1) if tuner and not self.a.steps else None,
                          steps_asked=self.a.steps, rounds=self.rounds if tuner else 0, resumed=self.resumed,
                          lr=self.a.lr, batch=TU.BATCH, threads=self.a.threads,
                          last_losses=tuner.losses[-1][1] if tuner and tuner.losses else None),
            threshold=dict(before=self.thr_before, after=self.thr,
                           chosen_on="val part, one-standard-error rule towards the shipped threshold" if self.labelled
                           else "unchanged (no labels)"),
            polarity=dict(black_hot=bool(self.invert), asked=self.a.polarity,
                          chosen_on=f"{self.pol_measured['measure']} of the before networks on all frames"
                          if self.pol_measured else "asked", measured=self.pol_measured),
            resolution=dict(full_res=self.res == 1, res=CNN_RES_NAMES[self.res], asked=self.a.resolution,
                            chosen_on=f"{self.res_measured['measure']} of the before networks on all frames"
                            if self.res_measured else "asked", measured=self.res_measured),
            outputs=dict(models=[f"{n}.vdm" for n in self.names], config="vd.json", demo_check=self.demo_check),
        )
        if self.labelled:
            rep["val"] = dict(before=self.fig_before, before_at_val_choice=self.fig_before_val,
                              after=M.figures(self.res_after, self.thr))
        else:
            if self.trains:
                rep["pseudo_labels"] = dict(hi=PSEUDO_HI, lo=PSEUDO_LO, rounds=self.state["log"])
            rep["val"] = dict(
                boxes_per_frame=dict(before=M.boxes_per_frame(self.res_before, self.thr_before),
                                     after=M.boxes_per_frame(self.res_after, self.thr)),
                flip_agreement=dict(before=M.flip_agreement(self.before, self.val, self.thr_before, self.res),
                                    after=M.flip_agreement(self.after, self.val, self.thr, self.res)),
                before_after_agreement=M.agreement(self.res_before, self.thr_before, self.res_after, self.thr))
        rep["rules"] = M.rules(self.before, self.after, f[0].img.shape[1], f[0].img.shape[0], self.res)
        shutil.rmtree(self.after[0].parent)
        cpu = os.times()
        rep["time"] = dict(wall_s=round(self.t_prev + time.time() - self.t_start, 1),
                           this_run_s=round(time.time() - self.t_start, 1),
                           parts_s={k: round(v, 1) for k, v in self.times.items()}, minutes_asked=self.a.minutes,
                           this_run_cpu_s=round(cpu.user + cpu.system + cpu.children_user + cpu.children_system, 1))
        (self.tmp / "report.json").write_text(json.dumps(rep, indent=1, default=float) + "\n")
        (self.tmp / "report.md").write_text(report_md(rep))
        return rep
