# SPDX-License-Identifier: MIT
"""The shared C library as a private CDLL with every pointer argument declared c_void_p, for callers
that pass pre-built addresses and time the bare call (vdtools.evaluation.bench). The prototypes are
declared here so that no module outside vdtools.bindings knows a C signature."""
import ctypes as C

from vdtools.bindings import clib


class RawLib:
    """A private CDLL instance (so our argtypes never clash with vdtools bindings)
    with every pointer argument as c_void_p: arguments are pre-built addresses."""

    def __init__(self):
        self.path = str(clib.lib_path())
        lib = C.CDLL(self.path)
        vp, sz, u32 = C.c_void_p, C.c_size_t, C.c_uint32
        sigs = {
            "vd_status_str": [C.c_int],
            "vd_threshold_u8": [vp, vp, C.c_uint8, vp],
            "vd_median3_u8": [vp, vp, vp],
            "vd_median5_u8": [vp, vp, vp],
            "vd_otsu_u8": [vp, vp, vp],
            "vd_components_workspace_size": [u32, u32, vp],
            "vd_components_label": [vp, vp, vp, sz, vp, sz, vp],
            "vd_components_filter": [vp, sz, vp, vp],
            "vd_components_rules_default": [vp],
            "vd_rect_expand": [vp, C.c_uint16, C.c_uint16, u32, u32, vp],
            "vd_refine_workspace_size": [u32, u32, vp],
            "vd_refine_region": [vp, vp, vp, vp, sz, vp, vp],
            "vd_contour_workspace_size": [u32, u32, vp],
            "vd_contour_find_external": [vp, vp, sz, vp, vp, sz, vp, sz, vp, vp],
            "vd_resample_u8": [vp, vp, vp, u32, u32],
            "vd_contrast_map_workspace_size": [u32, vp],
            "vd_contrast_map_u8": [vp, u32, C.c_uint8, vp, sz, vp],
            "vd_dbn_load": [vp, vp, sz],
            "vd_dbn_workspace_size": [vp, vp],
            "vd_dbn_classify": [vp, vp, vp, sz, vp],
        }
        for name, args in sigs.items():
            f = getattr(lib, name, None)
            if f is None:   # a module not built yet
                continue
            f.argtypes = args
            f.restype = C.c_int
        lib.vd_status_str.restype = C.c_void_p
        lib.vd_components_rules_default.restype = None
        self.lib = lib

    def __getattr__(self, name):
        return getattr(self.lib, name)
