# SPDX-License-Identifier: MIT
"""The ctypes layer agrees with the C structs (smoke test of the shared build)."""
import ctypes as C

from vdtools.bindings import clib


def test_status_text_through_ctypes(vdlib):
    vdlib.vd_status_str.restype = C.c_char_p
    assert vdlib.vd_status_str(-2) == b"workspace missing, misaligned or too small"


def test_iou_through_ctypes(vdlib):
    vdlib.vd_rect_iou_q15.restype = C.c_uint32
    a, b = clib.Rect(0, 0, 10, 10), clib.Rect(5, 0, 10, 10)
    assert vdlib.vd_rect_iou_q15(C.byref(a), C.byref(b)) == 10922
