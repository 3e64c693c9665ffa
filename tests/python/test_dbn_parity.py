# SPDX-License-Identifier: MIT
"""Bit-exact parity of the C quantised DBN (vd_dbn_classify via ctypes) with the
integer numpy reference (vdtools.formats.quantise.quant_forward): random models and
inputs always; every sample of the test split for every models/*.vdm when the
data set cache built by vdtools.data.dataset exists. Also the .vdm packer/loader,
the generated sigmoid table and the exported C source."""
import shutil
import subprocess
import zlib

import numpy as np
import pytest

from vdtools.bindings import clib
from vdtools.formats import export, quantise, vdm
from vdtools.bindings import dbn as vd_dbn

REPO = clib.REPO


@pytest.fixture(scope="module")
def dbn(vdlib):
    return vd_dbn.lib()


def _image_like(rng, n, side=32):
    """Smooth blobs with noise: closer to real samples than uniform noise."""
    yy, xx = np.mgrid[0:side, 0:side]
    out = np.empty((n, side * side), np.uint8)
    for i in range(n):
        cx, cy, r = rng.uniform(4, side - 4, 2).tolist() + [rng.uniform(3, 12)]
        g = np.exp(-((xx - cx) ** 2 + (yy - cy) ** 2) / (2 * r * r))
        img = rng.uniform(0, 120) + rng.uniform(0, 255) * g + rng.normal(0, 10, g.shape)
        out[i] = np.clip(img, 0, 255).astype(np.uint8).reshape(-1)
    return out


@pytest.mark.parametrize("sizes,scale", [([1024, 576, 256, 64, 1], 0.6), ([1024, 64, 1], 0.5),
                                         ([1024, 64, 1], 4.0), ([64, 16, 4, 1], 1.5), ([1024, 1], 1.0)])
def test_random_models_bit_exact(dbn, sizes, scale):
    rng = np.random.default_rng(sizes[1] + int(scale * 10))
    fm = quantise.load_float(quantise.random_float_model(sizes, seed=len(sizes), scale=scale))
    qm = quantise.quantise(fm, name="rand")
    m = vd_dbn.CModel(vdm.pack(qm))
    side = int(np.sqrt(sizes[0]))
    x = np.concatenate([rng.integers(0, 256, (150, sizes[0]), dtype=np.uint8), _image_like(rng, 150, side),
                        np.zeros((1, sizes[0]), np.uint8), np.full((1, sizes[0]), 255, np.uint8)])
    c = m.classify(x)
    p = quantise.quant_forward(qm, x)
    np.testing.assert_array_equal(c, p)
    # The quantised model follows the float one closely.
    pf = quantise.float_forward(fm, x)
    assert np.abs(pf - p / 256.0).max() < 0.04


@pytest.mark.parametrize("sizes,scale,min_range", [([1024, 576, 256, 1], 0.6, 16), ([1024, 48, 16, 1], 1.0, 16),
                                                   ([64, 16, 4, 1], 1.5, 1), ([1024, 1], 1.0, 255)])
def test_minmax_models_bit_exact(dbn, sizes, scale, min_range):
    """Models with the min-max input stretch (format version 2): C == Python, flat samples included."""
    rng = np.random.default_rng(min_range + sizes[1])
    fm = quantise.load_float(quantise.random_float_model(sizes, seed=3, scale=scale, input_norm="minmax",
                                                         norm_min_range=min_range))
    qm = quantise.quantise(fm, name="randn")
    blob = vdm.pack(qm)
    assert vdm.unpack(blob)["input_norm"] == "minmax" and vdm.unpack(blob)["norm_min_range"] == min_range
    m = vd_dbn.CModel(blob)
    assert m.m.input_norm == 1 and m.m.norm_min_range == min_range and m.m.format_version == 2
    side = int(np.sqrt(sizes[0]))
    x = np.concatenate([rng.integers(0, 256, (100, sizes[0]), dtype=np.uint8), _image_like(rng, 100, side),
                        rng.integers(100, 108, (20, sizes[0]), dtype=np.uint8),      # narrow range
                        np.full((1, sizes[0]), 0, np.uint8), np.full((1, sizes[0]), 93, np.uint8)])
    np.testing.assert_array_equal(m.classify(x), quantise.quant_forward(qm, x))
    # brightness offsets do not change the score (the point of the stretch)
    y = _image_like(rng, 20, side) // 2
    np.testing.assert_array_equal(m.classify(y), m.classify(y + 100))
    pf = quantise.float_forward(fm, x)
    assert np.abs(pf - quantise.quant_forward(qm, x) / 256.0).max() < 0.04


def test_stretch_matches_reference(dbn):
    rng = np.random.default_rng(21)
    for trial in range(300):
        n = int(rng.integers(1, 1025))
        lo = int(rng.integers(0, 256))
        x = np.clip(lo + rng.integers(0, int(rng.integers(1, 257)), n), 0, 255).astype(np.uint8)
        mr = int(rng.integers(1, 256))
        st, got = vd_dbn.c_stretch(x, mr)
        assert st == clib.VD_OK
        np.testing.assert_array_equal(got, quantise.stretch_u8(x[None], mr)[0])
    # hand-worked: flat -> 0; r = 32; ties round up
    assert quantise.stretch_u8(np.array([[9, 9, 9]], np.uint8), 16).tolist() == [[0, 0, 0]]
    assert quantise.stretch_u8(np.array([[10, 20, 30, 42]], np.uint8), 16).tolist() == [[0, 80, 159, 255]]
    assert quantise.stretch_u8(np.array([[0, 1]], np.uint8), 2).tolist() == [[0, 128]]
    assert vd_dbn.c_stretch(np.array([1, 2], np.uint8), 0)[0] == -1          # VD_ERR_ARG
    with pytest.raises(ValueError):
        quantise.stretch_u8(np.zeros((1, 4), np.uint8), 0)


def test_format_versions_and_norm_field(dbn):
    """Version 1 blobs (no normalisation) still load; unknown versions/normalisations are VD_ERR_MODEL."""
    fm = quantise.load_float(quantise.random_float_model([64, 8, 1], seed=2))
    blob = bytearray(vdm.pack(quantise.quantise(fm, name="v")))
    assert blob[4] == 2 and vd_dbn.c_load(bytes(blob)) == clib.VD_OK
    v1 = bytearray(blob)
    v1[4] = 1
    v1 = vdm.fix_crc(bytes(v1))
    assert vd_dbn.c_load(v1) == clib.VD_OK
    x = np.random.default_rng(0).integers(0, 256, (16, 64), dtype=np.uint8)
    np.testing.assert_array_equal(vd_dbn.CModel(v1).classify(x), vd_dbn.CModel(bytes(blob)).classify(x))
    for version, norm, rng_ in ((3, 0, 0), (0, 0, 0), (1, 1, 16), (2, 2, 16), (2, 1, 0), (2, 0, 4)):
        bad = bytearray(blob)
        bad[4], bad[36], bad[37] = version, norm, rng_
        assert vd_dbn.c_load(vdm.fix_crc(bytes(bad))) == -4, (version, norm, rng_)
    ok = bytearray(blob)
    ok[36], ok[37] = 1, 16
    assert vd_dbn.c_load(vdm.fix_crc(bytes(ok))) == clib.VD_OK


def test_requantize_matches_reference(dbn):
    rng = np.random.default_rng(3)
    acc = rng.integers(-(2**31), 2**31, 3000)
    acc[:1000] = rng.integers(-(2**20), 2**20, 1000)
    mult = rng.integers(1 << 30, 2**31, 3000)
    shift = rng.integers(-31, 8, 3000)
    ref = quantise.requantise(acc, mult, shift)
    got = [dbn.vd_dbn_requantize(int(a), int(b), int(s)) for a, b, s in zip(acc, mult, shift)]
    np.testing.assert_array_equal(np.array(got), ref)


def test_sigmoid_table_in_sync(dbn):
    path = REPO / "lib" / "src" / "models" / "dbn_sigmoid_table.h"
    assert path.read_text() == quantise.sigmoid_table_c(), \
        "regenerate: python3 -m vdtools.formats.quantise --write-sigmoid-table lib/src/models/dbn_sigmoid_table.h"
    got = np.array([dbn.vd_dbn_sigmoid_q8(z) for z in range(-2100, 2101)])
    np.testing.assert_array_equal(got, quantise.SIGMOID_Q8[np.clip(np.arange(-2100, 2101), -2048, 2048) + 2048])


def test_quantize_multiplier_tflite_cases():
    assert quantise.quantize_multiplier(0.5) == (1 << 30, 0)
    assert quantise.quantize_multiplier(1.0) == (1 << 30, 1)
    assert quantise.quantize_multiplier(0.75) == (3 << 29, 0)
    q, s = quantise.quantize_multiplier(1.0 / 255 * 256 * 0.01)
    assert (1 << 30) <= q < (1 << 31) and abs(q * 2.0 ** (s - 31) - 0.01 * 256 / 255) < 1e-9
    with pytest.raises(ValueError):
        quantise.quantize_multiplier(1000.0)


def test_golden_blob_matches_generator(dbn):
    blob = (REPO / "tests" / "data" / "golden_tiny.vdm").read_bytes()
    qm = vdm.unpack(blob)
    assert vdm.pack(qm) == blob and qm["version"] == vdm.VERSION
    x = np.random.default_rng(0).integers(0, 256, (64, 64), dtype=np.uint8)
    np.testing.assert_array_equal(vd_dbn.CModel(blob).classify(x), quantise.quant_forward(qm, x))


def test_loader_from_python(dbn):
    fm = quantise.load_float(quantise.random_float_model([64, 8, 1], seed=1))
    blob = vdm.pack(quantise.quantise(fm, name="t"))
    assert vd_dbn.c_load(blob) == clib.VD_OK
    assert vd_dbn.c_load(blob, offset=2) == -1            # misaligned pointer: VD_ERR_ARG
    assert vd_dbn.c_load(blob, nbytes=len(blob) - 4) == -4
    rng = np.random.default_rng(9)
    for i in rng.choice(len(blob), 64, replace=False):   # a random byte anywhere, CRC left stale
        bad = bytearray(blob)
        bad[i] ^= 0x5A
        assert vd_dbn.c_load(bytes(bad)) == -4
    bad = bytearray(blob)
    bad[64] += 1                                          # layer 0 'in' + fixed CRC: structure check
    assert vd_dbn.c_load(vdm.fix_crc(bytes(bad))) == -4
    assert zlib.crc32(blob[16:]) & 0xFFFFFFFF == int.from_bytes(blob[12:16], "little")


def test_export_c_source_compiles_and_loads(dbn, tmp_path):
    cc = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
    if cc is None:
        pytest.skip("no C compiler on PATH")
    libdir = clib.lib_path().parent
    fm = quantise.load_float(quantise.random_float_model([1024, 16, 1], seed=5, scale=0.5))
    qm, blob = export.export(fm, "unit_test", tmp_path)
    assert (tmp_path / "unit_test.vdm").read_bytes() == blob
    x = _image_like(np.random.default_rng(1), 1)[0]
    (tmp_path / "main.c").write_text(
        '#include <stdio.h>\n#include "vd/vd.h"\n#include "unit_test_vdm.h"\n'
        "static const unsigned char x[1024] = {" + ",".join(map(str, x)) + "};\n"
        "int main(void) { size_t n; const void *b = vd_model_unit_test(&n); vd_dbn_model_t m;\n"
        "  static unsigned long long ws[16]; unsigned char s = 0;\n"
        "  if (vd_dbn_load(&m, b, n) != VD_OK || ((unsigned long)b % 8u) != 0u) return 2;\n"
        "  if (vd_dbn_classify(&m, x, ws, sizeof ws, &s) != VD_OK) return 3;\n"
        '  printf("%u\\n", s); return 0; }\n')
    exe = tmp_path / "t"
    subprocess.run([cc, "-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror", "-I", str(REPO / "lib" / "include"),
                    "-I", str(tmp_path), str(tmp_path / "main.c"), str(tmp_path / "unit_test_vdm.c"),
                    f"-L{libdir}", "-lvd", f"-Wl,-rpath,{libdir}", "-o", str(exe)], check=True)
    out = subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout
    assert int(out) == int(quantise.quant_forward(qm, x[None])[0])


def _models():
    """The DBN models of models/ (format versions 1-2; version 3 is the CNN, tests/python/test_cnn_parity.py)."""
    return [p for p in sorted((REPO / "models").glob("*.vdm"))
            if int.from_bytes(p.read_bytes()[4:6], "little") in vdm.VERSIONS]


def test_models_on_test_split(dbn, data_dir):
    """Every models/*.vdm against the reference on every test-split sample of
    its input mode (the cached set built by vdtools.data.dataset)."""
    models = _models()
    if not models:
        pytest.skip("no models/*.vdm exported yet")
    try:
        from vdtools.data import dataset  # noqa: F401
    except ImportError:
        pytest.skip("vdtools.data.dataset (the data set builder) is not present")
    checked = 0
    for path in models:
        blob = path.read_bytes()
        qm = vdm.unpack(blob)
        split = quantise.test_split(qm["mode"])   # the test split alone is built (~30 s) when no cache exists
        if split is None:
            continue
        x, _y = split
        np.testing.assert_array_equal(vd_dbn.CModel(blob).classify(x), quantise.quant_forward(qm, x),
                                      err_msg=f"{path.name}: C and Python differ")
        checked += len(x)
    if checked == 0:
        pytest.skip("no cached data set for the models' modes (python3 -m vdtools.data.dataset --mode MODE)")
