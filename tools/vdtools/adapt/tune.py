# SPDX-License-Identifier: MIT
"""vd-adapt's PyTorch part: quantisation-aware fine-tuning of float networks on the user's frames mixed with
../shared/data's training frames, and their int8 export. Built on cnn_train (Net, batch, loss_fn, the QAT
forward) and cnn_export (load_net, calibrate, quantise, save_float): the adapted networks are trained,
quantised and exported exactly as the shipped ones, with the shipped QAT stage's optimiser (AdamW, lr 3e-4,
weight decay 1e-4, batch 16, 192-pixel crops, the training augmentation) over a short cosine schedule.
"""
import contextlib
import math
import time

import numpy as np
import torch

from vdtools.data import cnn_data as CD
from vdtools.formats import cnn_vdm as V
from vdtools.training import cnn_export as E
from vdtools.training import cnn_train as T

LR = 3e-4                   # the shipped networks' QAT stage
WEIGHT_DECAY = 1e-4
BATCH = 16
WARMUP = 50                 # steps of linear warm-up (a trained network: a short one)
RECALIBRATE_AT = (0.5,)     # share of the schedule at which the fake-quantisation scales follow the weights again
CALIB_TRAIN = 32            # calibration frames of those scales while training (the export takes all of them):
                            # a calibration of two networks on 96 frames takes minutes on a busy 2-core machine
CALIB_USER = 48             # at most this many of the user's frames among the calibration frames
CHECKPOINT_EVERY_S = 60.0


def user_frame(uf, boxes=None, ignore=None):
    """A cnn_data.Frame of a user's frame (dataset "user", group its block), with other boxes if given."""
    b = uf.boxes if boxes is None else np.asarray(boxes, np.float32).reshape(-1, 4)
    ig = uf.ignore if ignore is None else np.asarray(ignore, np.float32).reshape(-1, 4)
    return CD.Frame("user", uf.path.name, str(uf.path), f"user:{uf.block}", uf.part, uf.img, b, ig,
                    CD._hot_flags(uf.img, b))


def halved(fr):
    """fr's 2 x 2 box averages with its boxes scaled by 1/2: the half-resolution plane of it is (up to the
    rounding of two means in turn) fr's quarter-resolution plane, so training on it teaches the networks fr at
    quarter resolution (cfg.cnn_res QUARTER)."""
    import dataclasses
    return dataclasses.replace(fr, img=CD.box_mean(fr.img, 2), boxes=fr.boxes / 2, ignore=fr.ignore / 2,
                               others=fr.others * np.array([0.5, 0.5, 0.5, 0.5, 1], np.float32) if len(fr.others)
                               else fr.others)


def at_res(fr, res):
    """fr as the networks train on it to read it at cfg.cnn_res res: itself (half), doubled (full), halved
    (quarter)."""
    return fr if res == 0 else doubled(fr) if res == 1 else halved(fr)


def doubled(fr):
    """fr with every pixel repeated 2 x 2 and its boxes scaled by 2: the half-resolution plane of it is fr's
    frame itself, so training on it teaches the networks fr at full resolution (cfg.cnn_res)."""
    import dataclasses
    img = np.ascontiguousarray(np.repeat(np.repeat(fr.img, 2, 0), 2, 1))
    return dataclasses.replace(fr, img=img, boxes=fr.boxes * 2, ignore=fr.ignore * 2,
                               others=fr.others * np.array([2, 2, 2, 2, 1], np.float32) if len(fr.others) else fr.others)


def load_base(path):
    """(Net in training mode, arch) of float weights (.npz of models/float, or a cnn_train checkpoint)."""
    net, ck = E.load_net(path)
    net.train()
    return net, ck["arch"]


def calibration_set(user, replay, seed=0):
    """The exporter's calibration frames: up to CALIB_USER of the user's (seeded draw), the rest of
    cnn_export's CALIB_FRAMES from the replayed training frames."""
    rng = np.random.default_rng(seed)
    u = [user[i] for i in sorted(rng.choice(len(user), min(CALIB_USER, len(user)), replace=False))] if user else []
    return u + (E.calibration_frames(replay, E.CALIB_FRAMES - len(u)) if replay else [])


def export(net, calib, thr, name, max_peaks):
    """(desc, .vdm bytes, scales meta) of net quantised as cnn_export does, header threshold thr."""
    fq = net.fq
    net.set_fake_quant(None)
    net.eval()
    ranges = E.calibrate(net, calib)
    desc, q = E.quantise(net, ranges, thr, max_peaks=max_peaks, name=name)
    net.train()
    net.set_fake_quant(fq)
    return desc, V.pack(desc), dict(scale=q["scale"], zp=q["zp"], ranges=ranges)


def with_threshold(desc, meta, thr):
    """The same network's .vdm bytes with another header score threshold thr (quantise's rule; meta: export's
    scales, whose last tensor is the head)."""
    s_h, z_h = meta["scale"][-1], meta["zp"][-1]
    logit = math.log(thr / (1 - thr))
    return V.pack(dict(desc, score_threshold_q=int(np.clip(math.ceil(logit / s_h + z_h), -128, 127))))


def train_calib(calib):
    """The CALIB_TRAIN of the calibration frames that set the scales while training (evenly drawn)."""
    return calib[:: max(1, len(calib) // CALIB_TRAIN)][:CALIB_TRAIN]


@contextlib.contextmanager
def family_shares(shares):
    """cnn_train.batch draws families by cnn_train.FAMILY_SHARE: these shares while the block runs."""
    old = dict(T.FAMILY_SHARE)
    T.FAMILY_SHARE.clear()
    T.FAMILY_SHARE.update(shares)
    try:
        yield
    finally:
        T.FAMILY_SHARE.clear()
        T.FAMILY_SHARE.update(old)


class Tuner:
    """QAT fine-tuning of one or two networks on shared batches (one crop set per step, each network its own
    optimiser), a cosine schedule over a budget of steps or seconds, resumable from state()."""

    def __init__(self, nets, seed=0, lr=LR):
        self.nets, self.lr = nets, lr
        self.opts = [torch.optim.AdamW(n.parameters(), lr=lr, weight_decay=WEIGHT_DECAY) for n in nets]
        torch.manual_seed(seed)
        self.rng = np.random.default_rng(seed)
        self.step, self.t_train, self.calibrated_at, self.losses = 0, 0.0, -1.0, []
        self.q = [None] * len(nets)

    def recalibrate(self, calib):
        """The exporter's scales for the current weights (cnn_train --qat's recalibrate)."""
        for i, net in enumerate(self.nets):
            net.set_fake_quant(None)
            net.eval()
            _, q = E.quantise(net, E.calibrate(net, calib))
            net.train()
            net.set_fake_quant(q)
            self.q[i] = q

    def start(self, calib):
        """The first fake-quantisation scales (on train_calib(calib)); returns the seconds it took."""
        t0 = time.time()
        self.recalibrate(train_calib(calib))
        self.calibrated_at = 0.0
        return time.time() - t0

    def state(self):
        return dict(nets=[n.state_dict() for n in self.nets], opts=[o.state_dict() for o in self.opts],
                    step=self.step, t_train=self.t_train, calibrated_at=self.calibrated_at, q=self.q,
                    rng=self.rng.bit_generator.state, torch_rng=torch.get_rng_state(), losses=self.losses)

    def load(self, st):
        for n, s in zip(self.nets, st["nets"]):
            n.load_state_dict(s)
        for o, s in zip(self.opts, st["opts"]):
            o.load_state_dict(s)
        self.step, self.t_train, self.calibrated_at = st["step"], st["t_train"], st["calibrated_at"]
        self.rng.bit_generator.state = st["rng"]
        torch.set_rng_state(st["torch_rng"])
        self.losses = st["losses"]
        self.q = st["q"]
        for n, q in zip(self.nets, self.q):
            n.set_fake_quant(q)

    def progress(self, steps, seconds):
        return self.step / steps if steps else self.t_train / max(seconds, 1e-9)

    def train(self, by_fam, shares, calib, stop_at, steps=0, seconds=0.0, on_step=None, save=None,
              interrupt_after=None):
        """Trains until progress() reaches stop_at (a share of the whole schedule: steps, else seconds of
        training). on_step(tuner, loss) after each step; save(tuner) every CHECKPOINT_EVERY_S and at the end.
        interrupt_after: stop (after a checkpoint) once this many steps are done, as if the run were killed.
        Returns False when interrupted."""
        by_fam = {k: v for k, v in by_fam.items() if v and shares.get(k, 0) > 0}
        calib = train_calib(calib)
        if self.q[0] is None:
            self.start(calib)
        last_save = time.time()
        with family_shares(shares):
            while self.progress(steps, seconds) < stop_at:
                t0 = time.time()          # all of a step's wall time counts: recalibration and checkpoints too
                p = self.progress(steps, seconds)
                due = [r for r in RECALIBRATE_AT if self.calibrated_at < r <= p]
                if due:
                    self.recalibrate(calib)
                    self.calibrated_at = due[-1]
                lr = self.lr * 0.5 * (1 + math.cos(math.pi * min(1.0, p)))
                if self.step < WARMUP:
                    lr *= (self.step + 1) / WARMUP
                x, hm, m, reg, regm = T.batch(by_fam, self.rng, BATCH)
                losses = []
                for net, opt in zip(self.nets, self.opts):
                    for g in opt.param_groups:
                        g["lr"] = lr
                    loss, _, _ = T.loss_fn(net(x), hm, m, reg, regm)
                    opt.zero_grad()
                    loss.backward()
                    opt.step()
                    losses.append(loss.item())
                self.step += 1
                if self.step % 10 == 0:
                    self.losses.append((self.step, [round(v, 4) for v in losses]))
                stop = interrupt_after is not None and self.step >= interrupt_after
                if save and (stop or time.time() - last_save >= CHECKPOINT_EVERY_S):
                    self.t_train += time.time() - t0
                    t0 = time.time()
                    save(self)
                    last_save = time.time()
                self.t_train += time.time() - t0
                if on_step:
                    on_step(self, losses)
                if stop:
                    return False
        if save:
            save(self)
        return True
