# SPDX-License-Identifier: MIT
"""ctypes binding of cnn.h (vd_cnn_*): the model, layer, output and box mirrors, the prototypes and
a blob loaded by the C library with its workspaces (CModel)."""
import ctypes as C

import numpy as np

from vdtools.bindings import clib
from vdtools.bindings.dbn import aligned_copy, load_status   # one aligned-copy helper for both .vdm kinds

MAX_LAYERS = 32          # VD_CNN_MAX_LAYERS
MAX_PEAKS = 1024         # VD_CNN_MAX_PEAKS
KEEP_TENSORS = 1          # VD_CNN_KEEP_TENSORS
THR_DEFAULT = -(1 << 31)  # VD_CNN_THR_DEFAULT


class CnnLayer(C.Structure):
    """Mirror of vd_cnn_layer_t."""
    _fields_ = [("op", C.c_uint8), ("stride", C.c_uint8), ("in_", C.c_uint8), ("in2", C.c_uint8),
                ("cin", C.c_uint16), ("cout", C.c_uint16), ("out_zp", C.c_int8), ("act_min", C.c_int8),
                ("act_max", C.c_int8), ("w", C.c_void_p), ("bias", C.c_void_p), ("mult", C.c_void_p),
                ("shift", C.c_void_p)]


class CnnModel(C.Structure):
    """Mirror of vd_cnn_model_t."""
    _fields_ = [("blob", C.c_void_p), ("size", C.c_uint32), ("crc32", C.c_uint32), ("format_version", C.c_uint16),
                ("input_norm", C.c_uint8), ("out_channels", C.c_uint8), ("input_w", C.c_uint16),
                ("input_h", C.c_uint16), ("norm_lo_permille", C.c_uint16), ("norm_hi_permille", C.c_uint16),
                ("norm_min_range", C.c_uint16), ("input_zp", C.c_int8), ("out_stride", C.c_uint8),
                ("score_threshold_i8", C.c_int8), ("max_peaks", C.c_uint16), ("align", C.c_uint32),
                ("name", C.c_char * 17), ("n_layers", C.c_uint32), ("layers", CnnLayer * MAX_LAYERS),
                ("decode_table", C.c_void_p), ("prepared", C.c_void_p)]


class CnnOutput(C.Structure):
    """Mirror of vd_cnn_output_t."""
    _fields_ = [("data", C.c_void_p), ("w", C.c_uint32), ("h", C.c_uint32), ("c", C.c_uint32),
                ("stride", C.c_uint32), ("zp", C.c_int32)]


class CnnBox(C.Structure):
    """Mirror of vd_cnn_box_t."""
    _fields_ = [("rect", clib.Rect), ("score_q15", C.c_uint16), ("logit", C.c_int8)]


_bound = False


def lib():
    """The shared C library with the vd_cnn_* prototypes declared (OSError / AttributeError when the
    library is not built or has no CNN module)."""
    global _bound
    lb = clib.load()
    if not _bound:
        M, O = C.POINTER(CnnModel), C.POINTER(CnnOutput)
        sz = C.POINTER(C.c_size_t)
        lb.vd_cnn_load.argtypes = [M, C.c_void_p, C.c_size_t]
        lb.vd_cnn_workspace_size.argtypes = [M, C.c_uint32, C.c_uint32, sz]
        lb.vd_cnn_workspace_size_ex.argtypes = [M, C.c_uint32, C.c_uint32, C.c_uint32, sz]
        lb.vd_cnn_run.argtypes = [M, C.c_void_p, C.c_uint32, C.c_uint32, C.c_uint32, C.c_void_p, C.c_size_t, O]
        lb.vd_cnn_run_ex.argtypes = [M, C.c_void_p, C.c_uint32, C.c_uint32, C.c_uint32, C.c_uint32, C.c_void_p,
                                     C.c_size_t, O]
        lb.vd_cnn_tensor.argtypes = [M, C.c_void_p, C.c_size_t, C.c_uint32, C.c_uint32, C.c_uint32, O]
        lb.vd_cnn_decode.argtypes = [M, O, C.c_int32, C.c_uint32, C.c_uint32, C.c_uint32, C.POINTER(CnnBox),
                                     C.c_size_t, sz]
        lb.vd_cnn_macs.argtypes = [M, C.c_uint32, C.c_uint32, C.POINTER(C.c_uint64)]
        lb.vd_cnn_prepared_size.argtypes = [M, sz]
        lb.vd_cnn_prepare.argtypes = [M, C.c_void_p, C.c_size_t]
        for f in (lb.vd_cnn_load, lb.vd_cnn_workspace_size, lb.vd_cnn_workspace_size_ex, lb.vd_cnn_run,
                  lb.vd_cnn_run_ex, lb.vd_cnn_tensor, lb.vd_cnn_decode, lb.vd_cnn_macs, lb.vd_cnn_prepared_size,
                  lb.vd_cnn_prepare):
            f.restype = C.c_int
        _bound = True
    return lb


def prepare(m):
    """vd_cnn_prepare on the loaded model struct m (its weights packed once for this CPU's x86 kernels:
    the same outputs, faster runs); returns the buffer to keep alive with m (None where there is nothing
    to prepare)."""
    lb = lib()
    n = C.c_size_t(0)
    clib.check(lb.vd_cnn_prepared_size(C.byref(m), C.byref(n)), "vd_cnn_prepared_size")
    if n.value == 0:
        return None
    keep = np.zeros((n.value + 63) // 8 + 8, dtype=np.uint64)
    addr = (keep.ctypes.data + 63) // 64 * 64   # 64: the kernels' cache lines (the API needs 8)
    clib.check(lb.vd_cnn_prepare(C.byref(m), addr, n.value), "vd_cnn_prepare")
    return keep


def c_load(blob, offset=0, nbytes=None):
    """Status of vd_cnn_load on a copy of blob (for tests); the model struct is not kept."""
    return load_status(lib().vd_cnn_load, CnnModel(), blob, offset, nbytes)


def tensor_array(o):
    """Copy of a vd_cnn_output_t's tensor as int8 [h, w, c]."""
    n = o.w * o.h * o.c
    return np.ctypeslib.as_array((C.c_int8 * n).from_address(o.data)).reshape(o.h, o.w, o.c).copy()


class CModel:
    """A blob loaded by vd_cnn_load (kept alive, 8-byte aligned), with workspaces per input size.

        m = CModel(blob)
        head = m.run(img_u8)                        # int8 [Ho, Wo, C_out] (copy), vd_cnn_run
        ts = m.run_all(img_u8)                      # every tensor, vd_cnn_run_ex(KEEP_TENSORS) + vd_cnn_tensor
        boxes = m.decode(head, frame_w, frame_h)    # [(x, y, w, h, score_q15, logit)], vd_cnn_decode
    """

    def __init__(self, blob):
        self._keep, addr = aligned_copy(blob)
        self.m = CnnModel()
        clib.check(lib().vd_cnn_load(C.byref(self.m), addr, len(blob)), "vd_cnn_load")
        self._ws = {}
        zps = [self.m.input_zp] + [self.m.layers[i].out_zp for i in range(self.m.n_layers)]
        self.head_zp = int(zps[-1])

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def workspace_size(self, w, h, flags=0):
        n = C.c_size_t()
        clib.check(lib().vd_cnn_workspace_size_ex(C.byref(self.m), w, h, flags, C.byref(n)),
                   "vd_cnn_workspace_size_ex")
        return n.value

    def workspace(self, w, h, flags=0):
        """(keepalive, address, bytes) of this model's workspace for w x h (cached)."""
        k = (w, h, flags)
        if k not in self._ws:
            n = self.workspace_size(w, h, flags)
            buf, ptr = clib.workspace(n)
            self._ws[k] = (buf, ptr.value, n)
        return self._ws[k]

    def run_status(self, img_u8, flags=0, ws=None):
        """(status, vd_cnn_output_t) of vd_cnn_run_ex on a 2-D uint8 array (row stride = its strides[0])."""
        a = np.asarray(img_u8)
        if a.dtype != np.uint8 or a.ndim != 2 or a.strides[1] != 1:
            raise ValueError("a 2-D uint8 plane with contiguous rows expected")
        h, w = a.shape
        _buf, addr, n = ws if ws is not None else self.workspace(w, h, flags)
        out = CnnOutput()
        st = lib().vd_cnn_run_ex(C.byref(self.m), a.ctypes.data, w, h, a.strides[0], flags, addr, n, C.byref(out))
        return st, out

    def run(self, img_u8):
        """Head tensor int8 [Ho, Wo, C_out] (a copy) of vd_cnn_run on a uint8 plane."""
        a = np.asarray(img_u8)
        st, out = self.run_status(a)
        clib.check(st, "vd_cnn_run")
        return tensor_array(out)

    def run_all(self, img_u8):
        """Every tensor [t0, ..., tL] (copies) of one run with VD_CNN_KEEP_TENSORS."""
        a = np.asarray(img_u8)
        h, w = a.shape
        buf, addr, n = self.workspace(w, h, KEEP_TENSORS)
        st, _ = self.run_status(a, KEEP_TENSORS)
        clib.check(st, "vd_cnn_run_ex")
        out = []
        for i in range(self.m.n_layers + 1):
            t = CnnOutput()
            clib.check(lib().vd_cnn_tensor(C.byref(self.m), addr, n, w, h, i, C.byref(t)), f"vd_cnn_tensor {i}")
            out.append(tensor_array(t))
        return out

    def decode_status(self, head, frame_w, frame_h, thr_q=None, max_peaks=None, capacity=None):
        """(status, boxes) of vd_cnn_decode on a head tensor given as int8 [Ho, Wo, C_out] (any head, e.g.
        hand-made: it is wrapped in a vd_cnn_output_t with the model's out_stride and head zero point).
        thr_q None: VD_CNN_THR_DEFAULT; max_peaks None: 0 (header's); capacity None: VD_CNN_MAX_PEAKS."""
        hd = np.ascontiguousarray(head, dtype=np.int8)
        out = CnnOutput(hd.ctypes.data, hd.shape[1], hd.shape[0], hd.shape[2], self.m.out_stride, self.head_zp)
        cap = MAX_PEAKS if capacity is None else int(capacity)
        boxes = (CnnBox * max(cap, 1))()
        count = C.c_size_t(0)
        st = lib().vd_cnn_decode(C.byref(self.m), C.byref(out), THR_DEFAULT if thr_q is None else int(thr_q),
                                 0 if max_peaks is None else int(max_peaks), int(frame_w), int(frame_h),
                                 boxes if cap > 0 else None, cap, C.byref(count))
        res = [(b.rect.x, b.rect.y, b.rect.w, b.rect.h, b.score_q15, b.logit) for b in boxes[:count.value]]
        return st, res

    def decode(self, head, frame_w, frame_h, thr_q=None, max_peaks=None, capacity=None):
        """Boxes [(x, y, w, h, score_q15, logit)] of vd_cnn_decode (see decode_status)."""
        st, res = self.decode_status(head, frame_w, frame_h, thr_q, max_peaks, capacity)
        clib.check(st, "vd_cnn_decode")
        return res

    def macs(self, w, h):
        n = C.c_uint64()
        clib.check(lib().vd_cnn_macs(C.byref(self.m), w, h, C.byref(n)), "vd_cnn_macs")
        return n.value
