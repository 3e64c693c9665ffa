# SPDX-License-Identifier: MIT
"""RBM / DBN training, folding to the float interchange format, DET curve and the baselines' features
on small synthetic sets (fast, no data needed)."""
import numpy as np
import pytest

from vdtools.training import baselines, rbm
from vdtools.metrics import det


def _bars(n, rng):
    """Toy 8x8 binary images: one horizontal (label 0) or vertical (label 1) bar, 5% pixel noise."""
    X = np.zeros((n, 8, 8), np.float32)
    y = rng.integers(0, 2, n)
    pos = rng.integers(0, 8, n)
    for i in range(n):
        if y[i]:
            X[i, :, pos[i]] = 1
        else:
            X[i, pos[i], :] = 1
    flip = rng.random(X.shape) < 0.05
    X[flip] = 1 - X[flip]
    return X.reshape(n, 64), y


def test_rbm_cd1_lowers_reconstruction_error():
    rng = np.random.default_rng(0)
    X, _ = _bars(600, rng)
    r = rbm.RBM(64, 32, rng)
    e0 = r.recon_error(X)
    errs = r.train_cd1(X, epochs=15, lr=0.1, momentum=0.75, rng=rng)
    assert errs[-1] < 0.6 * e0
    assert errs[-1] < errs[0]


def test_rbm_training_is_deterministic_with_seed():
    X, _ = _bars(200, np.random.default_rng(1))
    a = rbm.RBM(64, 16, np.random.default_rng(5))
    b = rbm.RBM(64, 16, np.random.default_rng(5))
    a.train_cd1(X, epochs=2, rng=np.random.default_rng(9))
    b.train_cd1(X, epochs=2, rng=np.random.default_rng(9))
    assert np.array_equal(a.W, b.W)


def _blobs(n, rng):
    """Toy 8x8 images: a 3x3 blob near the centre (label 1) or near a border (label 0), 5% noise."""
    X = np.zeros((n, 8, 8), np.float32)
    y = rng.integers(0, 2, n)
    for i in range(n):
        r, c = (rng.integers(2, 4, 2) if y[i] else rng.choice([0, 5], 2))
        X[i, r:r + 3, c:c + 3] = 1
    flip = rng.random(X.shape) < 0.05
    X[flip] = 1 - X[flip]
    return X.reshape(n, 64), y


def test_dbn_pretrain_finetune_fold_and_save(tmp_path):
    rng = np.random.default_rng(2)
    X, y = _blobs(800, rng)
    Xv, yv = _blobs(200, rng)
    stack = rbm.pretrain_stack(X, [32, 16], epochs=5, lr=0.1, progress=False, log=None)
    assert [r.W.shape for r in stack] == [(64, 32), (32, 16)]
    net = rbm.DBN.from_rbms(stack, 64, rng)
    net.finetune(X, y, Xv, yv, epochs=30, lr=0.2, progress=False, log=None)
    p = net.predict_proba(Xv)
    assert np.mean((p >= 0.5) == (yv == 1)) > 0.9
    # folding the 2-unit softmax gives the same p(vehicle)
    Ws, bs = net.fold()
    assert [w.shape for w in Ws] == [(32, 64), (16, 32), (1, 16)]
    assert np.allclose(rbm.folded_proba(Ws, bs, Xv), p, atol=1e-5)
    path = net.save_npz(tmp_path / "m.npz", meta={"x": 1})
    with np.load(path) as z:
        assert str(z["mode"]) == "grey" and int(z["input_size"]) == 32 and int(z["n_layers"]) == 3
        for i in range(3):
            assert z[f"W{i}"].dtype == np.float32 and z[f"b{i}"].dtype == np.float32
            assert z[f"W{i}"].shape == Ws[i].shape and z[f"b{i}"].shape == (Ws[i].shape[0],)
    assert (tmp_path / "m.json").exists()


def test_finetune_keeps_best_validation_epoch():
    rng = np.random.default_rng(3)
    X, y = _bars(300, rng)
    Xv, yv = _bars(100, rng)
    net = rbm.DBN.from_rbms(rbm.pretrain_stack(X, [16], epochs=2, progress=False, log=None), 64, rng)
    hist = net.finetune(X, y, Xv, yv, epochs=12, progress=False, log=None)
    assert net.loss(Xv, yv) == pytest.approx(min(h[2] for h in hist), rel=1e-5)


def test_det_curve_hand_worked():
    # scores of 2 vehicles (0.9, 0.4) and 3 windows (0.8, 0.3, 0.1)
    f, m = det.det_curve([0.9, 0.8, 0.4, 0.3, 0.1], [1, 0, 1, 0, 0])
    assert np.allclose(f, [0, 0, 1 / 3, 1 / 3, 2 / 3, 1])
    assert np.allclose(m, [1, 0.5, 0.5, 0, 0, 0])
    assert det.miss_at(f, m, 0.0) == 0.5
    assert det.miss_at(f, m, 0.4) == 0.0


def test_baseline_features_shapes():
    X = (np.random.default_rng(4).random((3, 32, 32)) * 255).astype(np.uint8)
    assert baselines.hog_features(X).shape == (3, 324)
    L = baselines.lbp_features(X)
    assert L.shape == (3, 160) and np.allclose(L.reshape(3, 16, 10).sum(2), 1)
    coords, types, n_all = baselines.haar_coords(0, 50)
    assert n_all > 1000 and len(coords) == 50
    assert baselines.haar_features(X, coords, types).shape == (3, 50)


def test_normalised_model_round_trip(tmp_path):
    """A DBN trained on stretched input records the normalisation; the float and integer references
    apply it to raw bytes, so a brightness offset does not change the score."""
    from vdtools.training import dbn_train
    from vdtools.formats import quantise
    rng = np.random.default_rng(6)
    net = rbm.DBN.from_rbms([rbm.RBM(1024, 8, rng)], 1024, rng, "grey", **dbn_train.norm_spec("minmax"))
    path = net.save_npz(tmp_path / "n.npz")
    fm = quantise.load_float(str(path))
    assert fm["input_norm"] == "minmax" and fm["norm_min_range"] == dbn_train.NORM_MIN_RANGE
    x = rng.integers(0, 120, (5, 1024)).astype(np.uint8)
    assert np.allclose(quantise.float_forward(fm, x), quantise.float_forward(fm, x + 100))
    xs = quantise.stretch_u8(x, dbn_train.NORM_MIN_RANGE).astype(np.float32) / 255
    assert np.allclose(quantise.float_forward(fm, x), net.predict_proba(xs), atol=1e-5)
    assert quantise.load_float(str(rbm.DBN.from_rbms([], 1024, rng).save_npz(tmp_path / "r.npz")))["input_norm"] == "none"
