# SPDX-License-Identifier: MIT
"""Boosted-stump verifier (paper 003, lib/src/models/boost.c): C == the integer reference
(tools/vdtools/formats/boost_vdm.py) on random models and, for the committed models/vd_boost.vdm, on every
64x64 crop of the test split (the data set builder's test rows cut at 64x64)."""
import os
from pathlib import Path

import numpy as np
import pytest

from vdtools.formats import boost_vdm as B
from vdtools.bindings import boost as vd_boost
from vdtools.bindings import clib
from vdtools.formats import cnn_ref as R
from vdtools.formats import cnn_vdm as V

MODEL = clib.REPO / "models" / "vd_boost.vdm"


@pytest.fixture(scope="module")
def lib():
    try:
        return vd_boost.lib()
    except OSError as e:
        pytest.skip(f"libvd not built: {e}")


def random_boost(rng, n_stumps=200):
    cnn = R.random_model(rng, out_channels=3, input_w=64, input_h=64, conv5=True, name="rb",
                         width=tuple(int(c) for c in rng.integers(3, 12, 4)))
    sh = R.shapes(cnn, 64, 64)
    maps = [(int(t), int(rng.integers(0, sh[t][2]))) for t in rng.choice(np.arange(1, len(sh)), 5, replace=False)]
    lens = [sh[t][0] * sh[t][1] for t, _ in maps]
    mi = rng.integers(0, len(maps), n_stumps)
    st = np.stack([mi, [int(rng.integers(0, lens[m])) for m in mi], rng.integers(-128, 128, n_stumps),
                   rng.integers(-32767, 32768, n_stumps), rng.integers(-32767, 32768, n_stumps)], 1)
    return dict(name="random_boost", cnn=cnn, maps=maps, stumps=st, threshold=int(rng.integers(-1000, 1000)))


def test_random_models_bit_exact(lib):
    rng = np.random.default_rng(3)
    for _ in range(3):
        d = B.validate(random_boost(rng))
        blob = B.pack(d)
        assert B.unpack(blob)["stumps"].tolist() == d["stumps"].tolist()
        m = vd_boost.CBoost(blob)
        lens = [h * w for h, w in B.map_shapes(d["cnn"], d["maps"])]
        assert m.threshold == d["threshold"] and m.n_features == sum(lens)
        for kind in ("blobs", "noise", "flat", "dark"):
            img = R.random_image(rng, 64, 64, kind)
            ts = R.forward(d["cnn"], R.preprocess(img, d["cnn"]))
            f = B.features_from_tensors(d, ts)
            np.testing.assert_array_equal(m.features(img), f)
            assert m.score(img) == int(B.score_features(d, f[None])[0]) == B.score(d, img)
            assert B.score_batch(d, img[None])[0] == m.score(img)


def test_loader_rejects_corruption(lib):
    rng = np.random.default_rng(4)
    blob = bytearray(B.pack(random_boost(rng, 20)))
    vd_boost.CBoost(bytes(blob))
    for off, val in ((16, 2), (17, 0), (17, 17), (18, 0), (64, 99)):   # kind, n_maps, n_stumps, map tensor
        b = bytearray(blob)
        b[off] = val
        if off == 18:
            b[19] = 0
        b = bytes(B.struct.pack_into("<I", b, 12, B.zlib.crc32(bytes(b[16:])) & 0xFFFFFFFF) or b)
        with pytest.raises(RuntimeError):
            vd_boost.CBoost(b)
    b = bytearray(blob)
    b[-5] ^= 1                                                            # CRC
    with pytest.raises(RuntimeError):
        vd_boost.CBoost(bytes(b))


def test_committed_model_every_test_crop(lib):
    if not MODEL.exists():
        pytest.skip("models/vd_boost.vdm not committed")
    from vdtools.training import boost_train as BT
    X = BT.test_crops()
    blob = MODEL.read_bytes()
    d = B.unpack(blob)
    m = vd_boost.CBoost(blob)
    limit = os.environ.get("VD_BOOST_PARITY_LIMIT")
    if limit:
        X = X[:int(limit)]
    for x in X[:3]:   # the batched reference is cnn_ref.forward crop by crop
        assert B.score_batch(d, x[None])[0] == B.score(d, x)
    ref = B.score_batch(d, X)
    c = np.array([m.score(x) for x in X])
    bad = int((c != ref).sum())
    assert bad == 0, f"{bad} of {len(X)} test crops differ"
    assert limit or len(X) > 8000   # the whole test split (8 264 rows)
