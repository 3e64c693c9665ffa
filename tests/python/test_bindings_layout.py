# SPDX-License-Identifier: MIT
"""Every C struct that tools/vdtools mirrors in ctypes has the size and field offsets of the C build.

A mirror that drifts from its header (a field added, a type widened, a rename) would make ctypes read
and write the wrong bytes without any error; this test compiles a small C program against the
public headers with the host compiler, prints sizeof / offsetof of every mirrored field, and compares
them with the ctypes classes. (Issue 15 item 3: the C struct layouts are known in one checked place.)
"""
import ctypes as C
import shutil
import subprocess
from pathlib import Path

import pytest

from vdtools.bindings import clib, components, detector, pixel, port, refine, sources
from vdtools.bindings import cnn as vd_cnn, dbn as vd_dbn

REPO = Path(__file__).resolve().parents[2]

# (ctypes class, C type, header, {ctypes field name: C field name} where they differ)
MIRRORS = [
    (clib.Rect, "vd_rect_t", "vd/rect.h", {}),
    (clib.Point, "vd_point_t", "vd/rect.h", {}),
    (clib.ViewU8, "vd_view_u8_t", "vd/image.h", {}),
    (clib.ViewU16, "vd_view_u16_t", "vd/image.h", {}),
    (clib.Frame, "vd_frame_t", "vd/image.h", {}),
    (vd_cnn.CnnLayer, "vd_cnn_layer_t", "vd/cnn.h", {"in_": "in"}),
    (vd_cnn.CnnModel, "vd_cnn_model_t", "vd/cnn.h", {}),
    (vd_cnn.CnnOutput, "vd_cnn_output_t", "vd/cnn.h", {}),
    (vd_cnn.CnnBox, "vd_cnn_box_t", "vd/cnn.h", {}),
    (components.CcStats, "vd_components_stats_t", "vd/components.h", {}),
    (components.Rules, "vd_components_rules_t", "vd/components.h", {}),
    (clib.Calib, "vd_calib_t", "vd/calib.h", {}),
    (detector.TemporalCfg, "vd_temporal_cfg_t", "vd/temporal.h", {}),
    (detector.Detection, "vd_detection_t", "vd/detection.h", {}),
    (detector.DetectorCfg, "vd_detector_cfg_t", "vd/detector.h", {}),
    (detector.Stats, "vd_detector_stats_t", "vd/detector.h", {}),
    (refine.RefineCfg, "vd_refine_cfg_t", "vd/refine.h", {}),
    (refine.RefineStats, "vd_refine_stats_t", "vd/refine.h", {}),
    (refine.Contour, "vd_contour_t", "vd/contour.h", {}),
    (sources.WindowBand, "vd_window_band_t", "vd/windows.h", {}),
    (sources.WindowsCfg, "vd_windows_cfg_t", "vd/windows.h", {}),
    (sources.ContrastCfg, "vd_contrast_cfg_t", "vd/contrast.h", {}),
    (vd_dbn._Layer, "vd_dbn_layer_t", "vd/dbn.h", {"in_": "in"}),
    (vd_dbn.Model, "vd_dbn_model_t", "vd/dbn.h", {}),
    (port.CaptureOpts, "vd_capture_opts_t", "vd_port/capture.h", {}),
]


def _c_layout(tmp_path):
    cc = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
    if cc is None:
        pytest.skip("no C compiler on PATH")
    headers = sorted({h for _, _, h, _ in MIRRORS})
    lines = ["#include <stddef.h>", "#include <stdio.h>"] + [f'#include "{h}"' for h in headers]
    lines.append("int main(void) {")
    for i, (cls, ctype, _, rename) in enumerate(MIRRORS):
        lines.append(f'    printf("{i} =sizeof %zu\\n", sizeof({ctype}));')
        for name, _ in cls._fields_:
            lines.append(f'    printf("{i} {name} %zu\\n", offsetof({ctype}, {rename.get(name, name)}));')
    lines.append("    return 0;\n}")
    src, exe = tmp_path / "layout.c", tmp_path / "layout"
    src.write_text("\n".join(lines) + "\n")
    subprocess.run([cc, "-std=c99", "-I", str(REPO / "lib" / "include"), "-I", str(REPO / "port" / "include"),
                    str(src), "-o", str(exe)], check=True, capture_output=True, text=True)
    out = {}
    for line in subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout.splitlines():
        i, name, value = line.split()
        out[(int(i), name)] = int(value)
    return out


def test_every_mirror_matches_the_c_layout(tmp_path):
    c = _c_layout(tmp_path)
    bad = []
    for i, (cls, ctype, _, _) in enumerate(MIRRORS):
        size = c[(i, "=sizeof")]   # "=" keeps it apart from a field called "size"
        if C.sizeof(cls) != size:
            bad.append(f"{cls.__module__}.{cls.__name__}: sizeof {C.sizeof(cls)} != {ctype} {size}")
        for name, _ in cls._fields_:
            off = getattr(cls, name).offset
            if off != c[(i, name)]:
                bad.append(f"{cls.__module__}.{cls.__name__}.{name}: offset {off} != {ctype} {c[(i, name)]}")
    assert not bad, "\n".join(bad)


def test_one_mirror_per_struct():
    """Calib and the component rules were once mirrored twice; now every C type has one ctypes class."""
    assert detector.Calib is clib.Calib and pixel.Calib is clib.Calib and detector.CcRules is components.Rules
    ctypes_of = {}
    for cls, ctype, _, _ in MIRRORS:
        assert ctypes_of.setdefault(ctype, cls) is cls, ctype


def test_the_check_catches_a_drift(tmp_path):
    """A mirror with one field too wide must be reported (the test above is not vacuous)."""
    class Drifted(C.Structure):
        _fields_ = [("x", C.c_int32), ("y", C.c_int64), ("w", C.c_int32), ("h", C.c_int32)]
    MIRRORS.append((Drifted, "vd_rect_t", "vd/rect.h", {}))
    try:
        with pytest.raises(AssertionError, match=r"Drifted: sizeof 24 != vd_rect_t 16"):
            test_every_mirror_matches_the_c_layout(tmp_path)
    finally:
        MIRRORS.pop()
