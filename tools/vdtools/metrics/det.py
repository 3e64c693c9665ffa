# SPDX-License-Identifier: MIT
"""Detection error trade-off (DET) curves as in paper 003: miss rate = FN / (TP + FN) against false
positives per window (FPPW = FP / number of negative windows), both on log axes, by sweeping the
decision threshold over every score."""
import numpy as np


def det_curve(scores, y):
    """(fppw, miss) arrays for thresholds from strict to lenient (accept score >= t)."""
    s = np.asarray(scores, np.float64)
    y = np.asarray(y).astype(bool)
    order = np.argsort(-s, kind="stable")
    s, y = s[order], y[order]
    tp = np.cumsum(y)
    fp = np.cumsum(~y)
    last = np.r_[np.nonzero(np.diff(s))[0], len(s) - 1]   # one point per distinct threshold
    P, N = max(1, int(y.sum())), max(1, int((~y).sum()))
    fppw = np.r_[0.0, fp[last] / N]
    miss = np.r_[1.0, 1.0 - tp[last] / P]
    return fppw, miss


def miss_at(fppw, miss, target):
    """Lowest miss rate with FPPW <= target (1.0 if no threshold achieves it)."""
    ok = fppw <= target
    return float(miss[ok].min()) if ok.any() else 1.0


def plot(curves, path, title="DET: verifier on the test split"):
    """curves: {label: (fppw, miss)} -> PNG at path (log-log, lower left is better)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6.4, 5.0), dpi=110)
    floor = 1e-4
    for label, (f, m) in curves.items():
        ax.step(np.maximum(f, floor), np.maximum(m, 1e-3), where="post", label=label, lw=1.4)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(floor, 1.0)
    ax.set_ylim(1e-3, 1.0)
    ax.set_xlabel("false positives per window (FPPW)")
    ax.set_ylabel("miss rate")
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="lower left")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
