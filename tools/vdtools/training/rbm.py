# SPDX-License-Identifier: MIT
"""Restricted Boltzmann machine (CD-1) and deep belief network (greedy pre-training + back-propagation),
numpy, float32, CPU.

Recipe of paper 001 section 4 (and 000 section 3): each pair of adjacent layers is an RBM with binary
hidden units and visible units in [0, 1] (grey levels / 255 used as probabilities); weights start from a
small Gaussian; CD-1 updates with momentum theta and learning rate alpha, eq. (8):
    dW <- theta*dW + alpha*(<v0 h0>_data - <v1 h1>_recon - wd*W)
layer by layer from the input upwards; then the whole stack plus a 2-unit softmax label layer is
fine-tuned by back-propagation of the cross-entropy -sum y log y_hat. `fold()` turns the 2-unit
softmax into one sigmoid unit (w = w1 - w0, b = b1 - b0; unit 1 = vehicle), the float interchange
format (.npz with mode, input_size, n_layers, W<i> [out,in], b<i> [out]; contract in vdtools/formats/quantise.py).
"""
import json
from pathlib import Path

import numpy as np


def sigmoid(x):
    # clip keeps exp() finite in float32; sigmoid(+-30) is 0/1 to float32 precision anyway
    return 1.0 / (1.0 + np.exp(-np.clip(x, -30.0, 30.0)))


class RBM:
    """Bernoulli-Bernoulli RBM. W is [n_vis, n_hid] (transposed on export)."""

    def __init__(self, n_vis, n_hid, rng, sigma=0.01):
        self.W = (rng.standard_normal((n_vis, n_hid)) * sigma).astype(np.float32)
        self.vb = np.zeros(n_vis, np.float32)
        self.hb = np.zeros(n_hid, np.float32)

    def hidden(self, v):
        return sigmoid(v @ self.W + self.hb)

    def visible(self, h):
        return sigmoid(h @ self.W.T + self.vb)

    def recon_error(self, v):
        """Mean squared error of the one-step mean-field reconstruction."""
        return float(np.mean((v - self.visible(self.hidden(v))) ** 2))

    def train_cd1(self, X, epochs=20, lr=0.4, momentum=0.75, weight_decay=2e-4, batch=64, rng=None,
                  momentum_warmup=5, progress=None, desc="rbm"):
        """CD-1 on rows of X (float32 in [0, 1]). Momentum starts at 0.5 for `momentum_warmup` epochs
        (Hinton's practical guide: large early gradients with full momentum oscillate), then `momentum`.
        Returns the per-epoch reconstruction errors."""
        rng = rng if rng is not None else np.random.default_rng(0)
        X = np.asarray(X, np.float32)
        n = len(X)
        dW = np.zeros_like(self.W)
        dvb = np.zeros_like(self.vb)
        dhb = np.zeros_like(self.hb)
        lr = np.float32(lr)
        errs = []
        ep_iter = range(epochs)
        if progress:
            from tqdm import tqdm
            ep_iter = tqdm(ep_iter, desc=desc, unit="ep", leave=False, mininterval=1.0)
        for ep in ep_iter:
            m = np.float32(0.5 if ep < momentum_warmup else momentum)
            order = rng.permutation(n)
            for s in range(0, n, batch):
                v0 = X[order[s:s + batch]]
                b = np.float32(len(v0))
                h0 = self.hidden(v0)
                h0s = (rng.random(h0.shape, dtype=np.float32) < h0).astype(np.float32)
                v1 = self.visible(h0s)
                h1 = self.hidden(v1)
                gW = (v0.T @ h0 - v1.T @ h1) / b
                dW *= m
                dW += lr * (gW - np.float32(weight_decay) * self.W)
                dvb *= m
                dvb += lr * (v0 - v1).mean(0)
                dhb *= m
                dhb += lr * (h0 - h1).mean(0)
                self.W += dW
                self.vb += dvb
                self.hb += dhb
            errs.append(self.recon_error(X[:2048]))
            if progress:
                ep_iter.set_postfix(recon=f"{errs[-1]:.4f}")
        return errs


def pretrain_stack(X, sizes, epochs=20, lr=0.4, momentum=0.75, weight_decay=2e-4, batch=64, seed=0,
                   progress=True, lr_upper=None, log=print):
    """Greedy layer-wise CD-1: returns the list of RBMs (input -> sizes[0] -> sizes[1] ...).
    `lr_upper` (default lr) is used for layers above the first, whose inputs are hidden
    probabilities. A prefix of the stack is the pre-training of a shallower DBN."""
    rng = np.random.default_rng(seed)
    rbms = []
    v = np.asarray(X, np.float32)
    for i, n_hid in enumerate(sizes):
        r = RBM(v.shape[1], n_hid, rng)
        e0 = r.recon_error(v[:2048])
        errs = r.train_cd1(v, epochs, lr if i == 0 or lr_upper is None else lr_upper, momentum, weight_decay,
                           batch, rng, progress=progress, desc=f"rbm{i} {v.shape[1]}->{n_hid}")
        if log:
            log(f"  rbm{i} {v.shape[1]}->{n_hid}: recon error {e0:.4f} -> {errs[-1]:.4f} ({epochs} epochs)")
        rbms.append(r)
        v = r.hidden(v)
    return rbms


class DBN:
    """Feed-forward view of a DBN: sigmoid hidden layers + 2-unit softmax label layer (unit 1 = vehicle).
    Ws[i] is [in, out]."""

    def __init__(self, Ws, bs, mode="grey", input_norm="none", norm_min_range=0):
        self.Ws = [np.asarray(w, np.float32) for w in Ws]
        self.bs = [np.asarray(b, np.float32) for b in bs]
        self.mode = mode
        self.input_norm = input_norm          # recorded in the .npz; the caller feeds normalised X
        self.norm_min_range = int(norm_min_range)

    @classmethod
    def from_rbms(cls, rbms, n_in, rng, mode="grey", input_norm="none", norm_min_range=0):
        Ws = [r.W.copy() for r in rbms]
        bs = [r.hb.copy() for r in rbms]
        top = rbms[-1].W.shape[1] if rbms else n_in
        Ws.append((rng.standard_normal((top, 2)) * 0.01).astype(np.float32))
        bs.append(np.zeros(2, np.float32))
        return cls(Ws, bs, mode, input_norm, norm_min_range)

    @property
    def sizes(self):
        return [w.shape[1] for w in self.Ws[:-1]]

    def forward(self, X):
        acts = [np.asarray(X, np.float32)]
        for W, b in zip(self.Ws[:-1], self.bs[:-1]):
            acts.append(sigmoid(acts[-1] @ W + b))
        z = acts[-1] @ self.Ws[-1] + self.bs[-1]
        z = z - z.max(1, keepdims=True)
        p = np.exp(z)
        p /= p.sum(1, keepdims=True)
        return acts, p

    def predict_proba(self, X, batch=4096):
        """p(vehicle) for rows of X (float in [0,1])."""
        out = [self.forward(X[s:s + batch])[1][:, 1] for s in range(0, len(X), batch)]
        return np.concatenate(out) if out else np.zeros(0, np.float32)

    def loss(self, X, y):
        p = self.predict_proba(X)
        p = np.clip(p, 1e-7, 1 - 1e-7)
        return float(-np.mean(y * np.log(p) + (1 - y) * np.log(1 - p)))

    def finetune(self, X, y, Xv, yv, epochs=40, lr=0.1, momentum=0.9, weight_decay=1e-4, batch=64, seed=0,
                 patience=8, progress=True, desc="finetune", log=print):
        """Mini-batch back-propagation of the softmax cross-entropy; keeps the parameters of the epoch
        with the lowest validation loss (early stopping after `patience` epochs without improvement).
        Returns the history [(epoch, train_loss, val_loss, val_acc)]."""
        rng = np.random.default_rng(seed)
        X = np.asarray(X, np.float32)
        Y = np.zeros((len(y), 2), np.float32)
        Y[np.arange(len(y)), np.asarray(y, int)] = 1
        vel_W = [np.zeros_like(w) for w in self.Ws]
        vel_b = [np.zeros_like(b) for b in self.bs]
        best = (np.inf, None, -1)
        hist = []
        lr = np.float32(lr)
        mom = np.float32(momentum)
        wd = np.float32(weight_decay)
        ep_iter = range(epochs)
        if progress:
            from tqdm import tqdm
            ep_iter = tqdm(ep_iter, desc=desc, unit="ep", leave=False, mininterval=1.0)
        for ep in ep_iter:
            order = rng.permutation(len(X))
            tl = 0.0
            for s in range(0, len(X), batch):
                idx = order[s:s + batch]
                acts, p = self.forward(X[idx])
                tl += float(-np.sum(Y[idx] * np.log(np.clip(p, 1e-7, 1))))
                delta = (p - Y[idx]) / np.float32(len(idx))
                for i in range(len(self.Ws) - 1, -1, -1):
                    gW = acts[i].T @ delta + wd * self.Ws[i]
                    gb = delta.sum(0)
                    if i > 0:
                        delta = (delta @ self.Ws[i].T) * acts[i] * (1 - acts[i])
                    vel_W[i] = mom * vel_W[i] - lr * gW
                    vel_b[i] = mom * vel_b[i] - lr * gb
                    self.Ws[i] += vel_W[i]
                    self.bs[i] += vel_b[i]
            vl = self.loss(Xv, yv)
            va = float(np.mean((self.predict_proba(Xv) >= 0.5) == (yv == 1)))
            hist.append((ep, tl / len(X), vl, va))
            if progress:
                ep_iter.set_postfix(train=f"{tl / len(X):.3f}", val=f"{vl:.3f}", acc=f"{va:.3f}")
            if vl < best[0]:
                best = (vl, ([w.copy() for w in self.Ws], [b.copy() for b in self.bs]), ep)
            elif ep - best[2] >= patience:
                break
        if best[1] is not None:
            self.Ws, self.bs = best[1]
        if log:
            log(f"  {desc}: {len(hist)} epochs, best epoch {best[2]} val loss {best[0]:.4f} "
                f"val acc {hist[best[2]][3]:.4f}")
        return hist

    def fold(self):
        """Layers as [out, in] float32 with the softmax folded into one sigmoid unit = p(vehicle)."""
        Ws = [w.T.copy() for w in self.Ws[:-1]]
        bs = [b.copy() for b in self.bs[:-1]]
        Wl, bl = self.Ws[-1], self.bs[-1]
        Ws.append((Wl[:, 1] - Wl[:, 0])[None, :].astype(np.float32))
        bs.append(np.array([bl[1] - bl[0]], np.float32))
        return Ws, bs

    def save_npz(self, path, meta=None):
        """Float interchange model (the .npz contract of vdtools/formats/quantise.py) + a sidecar <path>.json with `meta`."""
        Ws, bs = self.fold()
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        arrays = {"mode": np.array(self.mode), "input_size": np.array(32, np.int32),
                  "n_layers": np.array(len(Ws), np.int32)}
        if self.input_norm != "none":
            arrays["input_norm"] = np.array(self.input_norm)
            arrays["norm_min_range"] = np.array(self.norm_min_range, np.int32)
        for i, (W, b) in enumerate(zip(Ws, bs)):
            arrays[f"W{i}"] = W.astype(np.float32)
            arrays[f"b{i}"] = b.astype(np.float32)
        np.savez(path, **arrays)
        if meta is not None:
            path.with_suffix(".json").write_text(json.dumps(meta, indent=1, default=str))
        return path


def load_folded(path):
    """(mode, [W [out,in]], [b]) from a float interchange .npz."""
    with np.load(path, allow_pickle=False) as z:
        L = int(z["n_layers"])
        return str(z["mode"]), [z[f"W{i}"] for i in range(L)], [z[f"b{i}"] for i in range(L)]


def folded_proba(Ws, bs, X):
    """p(vehicle) of a folded float model (sigmoid everywhere) for rows of X in [0, 1]."""
    a = np.asarray(X, np.float32)
    for W, b in zip(Ws, bs):
        a = sigmoid(a @ W.T + b)
    return a[:, 0]
