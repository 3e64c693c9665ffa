# SPDX-License-Identifier: MIT
"""Bit-exact parity of the C int8 CNN (vd_cnn_run / vd_cnn_decode via ctypes) with the numpy integer
reference (vdtools.formats.cnn_ref): every tensor, the head and the decoded boxes on random models x random
images of several sizes (input_norm 0 and 1, 3 and 5 output channels, out_stride 4 and 8), decoding of
hand-made heads full of ties, the multiply-add count, the workspace contract, the loader against
vdtools.formats.cnn_vdm.unpack on corrupted blobs, and -- when models/vd_cnn*.vdm exist and ../shared/data
is present -- the committed models on every test-split frame."""
import ctypes as C
import os
import struct
from pathlib import Path

import numpy as np
import pytest

from vdtools.bindings import clib
from vdtools.formats import cnn_ref as R
from vdtools.formats import cnn_vdm as V
from vdtools.bindings import cnn as vd_cnn

REPO = clib.REPO
VD_ERR_ARG, VD_ERR_WORKSPACE, VD_ERR_MODEL = -1, -2, -4


@pytest.fixture(scope="module")
def cnn(vdlib):
    try:
        return vd_cnn.lib()
    except AttributeError as e:
        pytest.skip(f"{clib.lib_path()} has no CNN module ({e}): build lib/src/models/cnn/ first")


def _first_diff(c_ts, r_ts, desc):
    """Message naming the first tensor where C and the reference differ (None if all equal)."""
    for i, (c, r) in enumerate(zip(c_ts, r_ts)):
        if c.shape != r.shape:
            return f"tensor {i}: shape C {c.shape} vs reference {r.shape}"
        if not np.array_equal(c, r):
            y, x, k = (int(v[0]) for v in np.nonzero(c != r))
            what = "input" if i == 0 else f"layer {i - 1} ({V.OP_NAMES[V.op_id(desc['layers'][i - 1]['op'])]})"
            return (f"tensor {i} = {what}: {int((c != r).sum())} of {c.size} values differ, first at "
                    f"(y {y}, x {x}, c {k}): C {c[y, x, k]} vs reference {r[y, x, k]}")
    return None


CASES = [  # seed, input_norm, out_channels, out_stride
    (1, 0, 5, 4), (2, 1, 5, 4), (3, 0, 3, 4), (4, 1, 3, 4), (5, 0, 5, 8), (6, 1, 5, 8), (7, 1, 5, 4), (8, 0, 5, 4),
    (9, 2, 5, 4), (10, 2, 3, 8),
]


@pytest.mark.parametrize("seed,norm,cout,ostride", CASES)
def test_random_models_bit_exact(cnn, seed, norm, cout, ostride):
    rng = np.random.default_rng(1000 + seed)
    d = R.random_model(rng, out_channels=cout, input_norm=norm, out_stride=ostride,
                       width=tuple(int(c) for c in rng.integers(3, 20, 4)))
    m = vd_cnn.CModel(V.pack(d))
    a = int(m.m.align)
    assert a == V.alignment(d) and m.m.n_layers == len(d["layers"])
    sizes = [(a, a), (2 * a, 3 * a), (6 * a, 8 * a), (8 * a, 5 * a), (12 * a, 16 * a)]
    n_boxes = 0
    for h, w in sizes:
        for kind in ("blobs", "noise", "flat", "dark", "blobs"):
            img = R.random_image(rng, h, w, kind)
            ref = R.forward(d, R.preprocess(img, d))
            msg = _first_diff(m.run_all(img), ref, d)
            assert msg is None, f"{w}x{h} {kind}: {msg}"
            head = m.run(img)                           # shared-memory plan (no KEEP_TENSORS)
            np.testing.assert_array_equal(head, ref[-1])
            for fw, fh, thr, k, cap in ((w, h, None, None, None), (640, 480, None, None, None),
                                        (w * 2 + 1, h * 3 - 1, -128, 1024, None),
                                        (int(rng.integers(1, 2000)), int(rng.integers(1, 2000)),
                                         int(rng.integers(-128, 128)), int(rng.integers(0, 50)),
                                         int(rng.integers(0, 60)))):
                cb = m.decode(head, fw, fh, thr, k, cap)
                rb = R.decode(d, ref[-1], fw, fh, thr, k, 1024 if cap is None else cap)
                assert cb == rb, f"{w}x{h} {kind} decode frame {fw}x{fh} thr {thr} K {k} cap {cap}"
                n_boxes += len(rb)
    # the same image in a wider buffer (row stride > width)
    img = R.random_image(rng, 4 * a, 4 * a, "blobs")
    buf = np.zeros((4 * a, 4 * a + 13), np.uint8)
    buf[:, 5:5 + 4 * a] = img
    np.testing.assert_array_equal(m.run(buf[:, 5:5 + 4 * a]), R.run(d, img))
    assert n_boxes > 50


@pytest.mark.parametrize("seed,norm,ostride", [(11, 0, 4), (12, 1, 8), (13, 1, 4)])
def test_conv5x5_models_bit_exact(cnn, seed, norm, ostride):
    """CONV5X5 (op 7, padding 2) at stride 2 and 1, in a net with every other op: C == reference on
    every tensor, at sizes where the 5x5 window overhangs two border pixels on every side."""
    rng = np.random.default_rng(2000 + seed)
    d = R.random_model(rng, out_channels=5, input_norm=norm, out_stride=ostride, conv5=True,
                       width=tuple(int(c) for c in rng.integers(3, 20, 4)))
    assert sum(L["op"] == V.CONV5X5 for L in d["layers"]) == 2
    m = vd_cnn.CModel(V.pack(d))
    a = int(m.m.align)
    for h, w in [(a, a), (2 * a, 3 * a), (8 * a, 5 * a)]:
        for kind in ("blobs", "noise", "flat"):
            img = R.random_image(rng, h, w, kind)
            ref = R.forward(d, R.preprocess(img, d))
            msg = _first_diff(m.run_all(img), ref, d)
            assert msg is None, f"{w}x{h} {kind}: {msg}"
            np.testing.assert_array_equal(m.run(img), ref[-1])
    assert m.macs(8 * a, 8 * a) == R.macs(d, 8 * a, 8 * a)


def test_decode_hand_made_heads_bit_exact(cnn):
    """C decoding of arbitrary heads (few distinct values: plateaus and ties everywhere) == reference."""
    rng = np.random.default_rng(77)
    for ch, ostride in ((5, 4), (3, 4), (5, 8)):
        d = R.random_model(rng, out_channels=ch, out_stride=ostride, width=(4, 4, 4, 4))
        m = vd_cnn.CModel(V.pack(d))
        for trial in range(60):
            ho, wo = (int(v) for v in rng.integers(1, 24, 2))
            span = int(rng.choice([2, 3, 8, 256]))
            lo = int(rng.integers(-128, 128 - span + 1))
            head = rng.integers(lo, lo + span, (ho, wo, ch)).astype(np.int8)
            head[:, :, 1:] = rng.integers(-128, 128, (ho, wo, ch - 1))
            fw = int(rng.choice([1, 2, 7, wo * ostride, 640, 8192, int(rng.integers(1, 8193))]))
            fh = int(rng.choice([1, 3, ho * ostride, 480, 8192, int(rng.integers(1, 8193))]))
            thr = [None, lo, lo + span - 1, -128, 127][trial % 5]
            k = [None, 0, 1, 3, 2000][trial % 4]
            cap = [None, 0, 1, 5, 1024][trial % 5] if trial % 3 else int(rng.integers(0, 100))
            cb = m.decode(head, fw, fh, thr, k, cap)
            rb = R.decode(d, head, fw, fh, thr, k, 1024 if cap is None else cap)
            assert cb == rb, f"head {ho}x{wo}x{ch} span {span} frame {fw}x{fh} thr {thr} K {k} cap {cap}"
        head = np.zeros((3, 3, ch), np.int8)
        for bad in (dict(thr_q=128), dict(thr_q=-129), dict(frame_w=0), dict(frame_h=8193)):
            args = dict(frame_w=16, frame_h=16, thr_q=0)
            args.update(bad)
            st, _ = m.decode_status(head, args["frame_w"], args["frame_h"], args["thr_q"])
            assert st == VD_ERR_ARG, bad
            with pytest.raises(ValueError):
                R.decode(d, head, args["frame_w"], args["frame_h"], args["thr_q"])


def test_macs_equal(cnn):
    rng = np.random.default_rng(5)
    for seed in range(4):
        d = R.random_model(rng, out_stride=8 if seed % 2 else 4)
        m = vd_cnn.CModel(V.pack(d))
        a = V.alignment(d)
        for w, h in ((a, a), (320, 256), (640, 512), (4096, 4096)):
            assert m.macs(w, h) == R.macs(d, w, h)


def test_run_rejects_sizes_like_the_reference(cnn):
    d = R.random_model(np.random.default_rng(6))
    m = vd_cnn.CModel(V.pack(d))
    a = int(m.m.align)
    for w, h in ((a + 4, a), (a, 2 * a - 1), (a, 4096 + a)):
        with pytest.raises(ValueError):
            R.check_size(d, w, h)
        n = C.c_size_t()
        assert vd_cnn.lib().vd_cnn_workspace_size(C.byref(m.m), w, h, C.byref(n)) == VD_ERR_ARG
        out = vd_cnn.CnnOutput()
        img = np.zeros((h, w), np.uint8)
        st = vd_cnn.lib().vd_cnn_run(C.byref(m.m), img.ctypes.data, w, h, w, None, 0, C.byref(out))
        assert st == VD_ERR_ARG
    img = np.zeros((a, 3 * a), np.uint8)
    ws = m.workspace(2 * a, a)
    st, _ = m.run_status(img[:, :2 * a], ws=ws)
    assert st == 0
    out = vd_cnn.CnnOutput()          # stride_bytes < width
    st = vd_cnn.lib().vd_cnn_run(C.byref(m.m), img.ctypes.data, 2 * a, a, 2 * a - 1, ws[1], ws[2], C.byref(out))
    assert st == VD_ERR_ARG


def test_workspace_contract(cnn):
    """size - 1 fails with VD_ERR_WORKSPACE, a misaligned buffer too; guard bytes stay intact; a second run
    in the same workspace gives the same head."""
    rng = np.random.default_rng(8)
    d = R.random_model(rng, input_norm=1)
    m = vd_cnn.CModel(V.pack(d))
    for flags in (0, vd_cnn.KEEP_TENSORS):
        w, h = 64, 48
        img = R.random_image(rng, h, w, "blobs")
        n = m.workspace_size(w, h, flags)
        assert n > 0 and (flags == 0 or n >= sum(a * b * c for a, b, c in R.shapes(d, w, h)))
        guard = 64
        buf = np.full(n + 2 * guard + 8, 0xA5, np.uint8)
        base = buf.ctypes.data
        start = guard + (-(base + guard)) % 8
        ws = (buf, base + start, n)
        st, out = m.run_status(img, flags, ws=(buf, base + start, n - 1))
        assert st == VD_ERR_WORKSPACE
        st, out = m.run_status(img, flags, ws=(buf, base + start + 4, n))
        assert st == VD_ERR_WORKSPACE
        st, out = m.run_status(img, flags, ws=ws)
        assert st == 0
        head = vd_cnn.tensor_array(out)
        np.testing.assert_array_equal(head, R.run(d, img))
        assert (buf[:start] == 0xA5).all() and (buf[start + n:] == 0xA5).all()
        st, out = m.run_status(img, flags, ws=ws)
        np.testing.assert_array_equal(vd_cnn.tensor_array(out), head)
        t = vd_cnn.CnnOutput()
        st = vd_cnn.lib().vd_cnn_tensor(C.byref(m.m), ws[1], n, w, h, len(d["layers"]), C.byref(t))
        assert st == 0
        np.testing.assert_array_equal(vd_cnn.tensor_array(t), head)


# ------------------------------------------------------------------ loader == unpack
def _accepts_py(blob):
    try:
        V.unpack(blob)
        return True
    except ValueError:
        return False


def _field_offsets(blob):
    """(offset, struct format) of every header and layer-entry field of a blob."""
    hdr = [(4, "<H"), (6, "<H"), (8, "<I"), (16, "B"), (17, "B"), (18, "B"), (19, "B"), (20, "<H"), (22, "<H"),
           (24, "<H"), (26, "<H"), (28, "<H"), (30, "b"), (31, "B"), (32, "<I"), (36, "<I"), (40, "b"), (41, "B"),
           (42, "<H"), (44, "<I"), (48, "B"), (63, "B"), (64, "B"), (127, "B")]
    n = blob[18]
    out = list(hdr)
    for i in range(n):
        e = 128 + 32 * i
        out += [(e + o, f) for o, f in ((0, "B"), (1, "B"), (2, "B"), (3, "B"), (4, "<H"), (6, "<H"), (8, "b"),
                                        (9, "b"), (10, "b"), (11, "B"), (12, "<I"), (16, "<I"), (20, "<I"),
                                        (24, "<I"), (28, "<I"))]
    return out


def test_loader_agrees_with_unpack_on_corrupted_blobs(cnn):
    """Field-wise corruption (CRC fixed): vd_cnn_load accepts a blob iff cnn_vdm.unpack does."""
    rng = np.random.default_rng(9)
    disagree = []
    tried = accepted = 0
    for seed in range(6):
        d = R.random_model(rng, input_norm=seed % 3, out_channels=3 if seed == 3 else 5)
        blob = V.pack(d)
        assert vd_cnn.c_load(blob) == 0
        fields = _field_offsets(blob)
        for trial in range(400):
            b = bytearray(blob)
            r = rng.random()
            if r < 0.7:                                       # one header / layer-entry field
                off, fmt = fields[int(rng.integers(0, len(fields)))]
                size = struct.calcsize(fmt)
                old = struct.unpack_from(fmt, b, off)[0]
                choice = rng.random()
                if choice < 0.4:
                    new = old + int(rng.choice([-2, -1, 1, 2]))
                elif choice < 0.7:
                    new = int(rng.integers(0, 1 << (8 * size)))
                else:
                    new = int(rng.choice([0, 1, 2, 3, 4, 5, 6, 7, 8, 16, 127, 128, 255, 1024, 1025]))
                lo, hi = (-(1 << (8 * size - 1)), (1 << (8 * size - 1)) - 1) if fmt[-1] in "bhi" else (0, (1 << (8 * size)) - 1)
                struct.pack_into(fmt, b, off, min(max(new, lo), hi))
            elif r < 0.85:                                   # a per-channel array value
                i = int(rng.integers(0, len(d["layers"])))
                e = 128 + 32 * i
                ob, om, osh = struct.unpack_from("<III", b, e + 16)
                if ob == 0:
                    continue
                cout = struct.unpack_from("<H", b, e + 6)[0]
                j = int(rng.integers(0, cout))
                k = int(rng.integers(0, 3))
                if k == 0:
                    struct.pack_into("<i", b, ob + 4 * j, int(rng.choice([1 << 30, -(1 << 31), (1 << 31) - 1,
                                                                          (1 << 31) - 1 - 9 * 1024 * 128 * 255])))
                elif k == 1:
                    struct.pack_into("<i", b, om + 4 * j, int(rng.choice([(1 << 30) - 1, 1 << 30, -1, 0,
                                                                          (1 << 31) - 1])))
                else:
                    struct.pack_into("b", b, osh + j, int(rng.choice([-32, -31, 7, 8, 0, 127, -128])))
            else:                                            # the decode table
                dt = struct.unpack_from("<I", b, 36)[0]
                c = int(rng.integers(0, b[19]))
                j = int(rng.integers(0, 256))
                struct.pack_into("<i", b, dt + 4 * (256 * c + j),
                                 int(rng.choice([-1, 0, 32768, 32769, -256, -257, 512, 513, 4096 * 256,
                                                 4096 * 256 + 1, 1 << 20])))
            total = struct.unpack_from("<I", b, 8)[0]
            if len(b) < total < len(b) + 4096:                # a larger total_size: give it the bytes
                b += bytes(total - len(b))
            bb = V.fix_crc(bytes(b))
            py, c_ok = _accepts_py(bb), vd_cnn.c_load(bb) == 0
            tried += 1
            accepted += py
            if py != c_ok:
                try:
                    V.unpack(bb)
                    why = "unpack accepts"
                except ValueError as ex:
                    why = f"unpack: {ex}"
                disagree.append(f"seed {seed} trial {trial}: C {'accepts' if c_ok else 'rejects'}, {why}")
    print(f"loader vs unpack: {tried} corrupted blobs, {accepted} accepted by both, {len(disagree)} disagree")
    assert not disagree, f"{len(disagree)} of {tried} disagree:\n" + "\n".join(disagree[:25])
    assert 0 < accepted < tried


def test_loader_container_checks(cnn):
    d = R.random_model(np.random.default_rng(10))
    blob = V.pack(d)
    assert vd_cnn.c_load(blob) == 0
    assert vd_cnn.c_load(blob, offset=2) == VD_ERR_ARG                       # not 4-byte aligned
    assert vd_cnn.c_load(blob, nbytes=len(blob) - 4) == VD_ERR_MODEL         # shorter than total_size
    assert vd_cnn.c_load(blob + bytes(8), nbytes=len(blob) + 8) == 0          # excess ignored
    assert vd_cnn.c_load(blob[:300] + bytes([blob[300] ^ 1]) + blob[301:]) == VD_ERR_MODEL   # CRC
    for ver in (1, 2, 4):
        assert vd_cnn.c_load(V.fix_crc(blob[:4] + struct.pack("<H", ver) + blob[6:])) == VD_ERR_MODEL
    dbn = (REPO / "models" / "vd_dbn_grey.vdm")
    if dbn.exists():
        assert vd_cnn.c_load(dbn.read_bytes()) == VD_ERR_MODEL                # a DBN blob is not a CNN


# ------------------------------------------------------------------ committed models, real frames
def _half(img):
    """The detector's network input: exact 2x2 box average, round half up."""
    h, w = img.shape[0] // 2 * 2, img.shape[1] // 2 * 2
    a = img[:h, :w].astype(np.uint16)
    return ((a[0::2, 0::2] + a[1::2, 0::2] + a[0::2, 1::2] + a[1::2, 1::2] + 2) >> 2).astype(np.uint8)


def _pad(img, a):
    h, w = img.shape
    return np.pad(img, ((0, (-h) % a), (0, (-w) % a)), mode="edge")


def _test_frames(data_dir):
    from vdtools.data import dataset as D
    frames = D.all_frames(data_dir, synth=False)
    split = D.assign_splits(frames)
    return [f for f in frames if split[f.group] == "test"]


# The committed models, plus any listed in $VD_CNN_PARITY_MODELS (os.pathsep-separated .vdm paths,
# e.g. a freshly exported model before it is committed).
MODELS = sorted((REPO / "models").glob("vd_cnn*.vdm")) + [
    Path(p) for p in os.environ.get("VD_CNN_PARITY_MODELS", "").split(os.pathsep) if p]


@pytest.mark.parametrize("path", MODELS or [None], ids=[p.name for p in MODELS] or ["none"])
def test_committed_models_on_test_split(cnn, data_dir, path):
    if path is None:
        pytest.skip("no committed CNN model (models/vd_cnn*.vdm) yet")
    import cv2
    blob = path.read_bytes()
    d = V.unpack(blob)
    m = vd_cnn.CModel(blob)
    a = V.alignment(d)
    frames = _test_frames(data_dir)
    if not frames:
        pytest.skip(f"no test-split frames under {data_dir}")
    n_boxes = 0
    for f in frames:
        img = cv2.imread(str(f.path), cv2.IMREAD_GRAYSCALE)
        assert img is not None, f.path
        x = _pad(_half(img), a)
        head = m.run(x)
        ref = R.run(d, x)
        if not np.array_equal(head, ref):
            msg = _first_diff(m.run_all(x), R.forward(d, R.preprocess(x, d)), d)
            pytest.fail(f"{path.name} on {f.name}: {msg}")
        fh, fw = img.shape
        for thr, k in ((None, None), (-128, 1024)):
            cb = m.decode(head, fw, fh, thr, k)
            rb = R.decode(d, ref, fw, fh, thr, k, 1024)
            assert cb == rb, f"{path.name} on {f.name}: decode thr {thr} K {k}"
        n_boxes += len(rb)
    assert len(frames) >= 100 and n_boxes > 0
