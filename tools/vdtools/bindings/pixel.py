# SPDX-License-Identifier: MIT
"""ctypes bindings of the pixel modules (threshold.h, otsu.h, median.h): numpy in, numpy out.

Also the generator of the 5x5 median selection network used in lib/src/median.c
(`median_network()`), with its exhaustive 0-1-principle check."""
import ctypes as C
import itertools

import numpy as np

from . import clib

_P = C.POINTER
_configured = set()


Calib = clib.Calib   # the one mirror of vd_calib_t


def _lib():
    lib = clib.load()
    if id(lib) not in _configured:
        u8v, u16v, img, rect = _P(clib.ViewU8), _P(clib.ViewU16), _P(clib.ImageU8), _P(clib.Rect)
        sigs = {
            "vd_threshold_u8": [u8v, rect, C.c_uint8, img],
            "vd_threshold_u16": [u16v, rect, C.c_uint16, img],
            "vd_threshold_u16_ck": [u16v, rect, _P(Calib), C.c_int32, img],
            "vd_calib_ck_from_raw": [_P(Calib), C.c_uint16, _P(C.c_int32)],
            "vd_calib_raw_from_ck": [_P(Calib), C.c_int32, _P(C.c_uint16)],
            "vd_calib_raw_from_centi_celsius": [_P(Calib), C.c_int32, _P(C.c_uint16)],
            "vd_histogram_u8": [u8v, rect, _P(C.c_uint32)],
            "vd_otsu_from_hist": [_P(C.c_uint32), _P(C.c_uint8)],
            "vd_otsu_u8": [u8v, rect, _P(C.c_uint8)],
            "vd_median3_u8": [u8v, rect, img],
            "vd_median5_u8": [u8v, rect, img],
        }
        for name, args in sigs.items():
            f = getattr(lib, name)
            f.argtypes = args
            f.restype = C.c_int
        _configured.add(id(lib))
    return lib


def _roi(roi):
    """(x, y, w, h) or None -> (Rect pointer or None, rect tuple or None)."""
    if roi is None:
        return None
    return C.byref(clib.Rect(*[int(v) for v in roi]))


def _out_shape(a, roi):
    return (a.shape[0], a.shape[1]) if roi is None else (int(roi[3]), int(roi[2]))


def _image(out):
    return clib.ImageU8(out.ctypes.data_as(_P(C.c_uint8)), out.shape[1], out.shape[0], out.strides[0])


def threshold_u8(a, thr, roi=None):
    """Mask (0/255) of a >= thr over roi (x, y, w, h) of the 2-D uint8 array a."""
    out = np.empty(_out_shape(a, roi), np.uint8)
    v = clib.view_u8(a)
    clib.check(_lib().vd_threshold_u8(C.byref(v), _roi(roi), int(thr), C.byref(_image(out))), "vd_threshold_u8")
    return out


def threshold_u16(a, thr_raw, roi=None):
    out = np.empty(_out_shape(a, roi), np.uint8)
    v = clib.view_u16(a)
    clib.check(_lib().vd_threshold_u16(C.byref(v), _roi(roi), int(thr_raw), C.byref(_image(out))), "vd_threshold_u16")
    return out


def threshold_u16_ck(a, gain_q16, offset_ck, thr_ck, roi=None):
    out = np.empty(_out_shape(a, roi), np.uint8)
    v = clib.view_u16(a)
    cal = Calib(gain_q16, offset_ck)
    clib.check(_lib().vd_threshold_u16_ck(C.byref(v), _roi(roi), C.byref(cal), int(thr_ck), C.byref(_image(out))),
               "vd_threshold_u16_ck")
    return out


def ck_from_raw(gain_q16, offset_ck, raw):
    """(status, centi-kelvin) of one raw value."""
    ck = C.c_int32(0)
    st = _lib().vd_calib_ck_from_raw(C.byref(Calib(gain_q16, offset_ck)), int(raw), C.byref(ck))
    return st, ck.value


def raw_from_ck(gain_q16, offset_ck, ck):
    """(status, smallest raw whose temperature >= ck)."""
    raw = C.c_uint16(0)
    st = _lib().vd_calib_raw_from_ck(C.byref(Calib(gain_q16, offset_ck)), int(ck), C.byref(raw))
    return st, raw.value


def raw_from_centi_celsius(gain_q16, offset_ck, centi_c):
    raw = C.c_uint16(0)
    st = _lib().vd_calib_raw_from_centi_celsius(C.byref(Calib(gain_q16, offset_ck)), int(centi_c), C.byref(raw))
    return st, raw.value


def histogram_u8(a, roi=None):
    h = np.zeros(256, np.uint32)
    v = clib.view_u8(a)
    clib.check(_lib().vd_histogram_u8(C.byref(v), _roi(roi), h.ctypes.data_as(_P(C.c_uint32))), "vd_histogram_u8")
    return h


def otsu_from_hist(hist):
    h = np.ascontiguousarray(hist, dtype=np.uint32)
    assert h.shape == (256,)
    t = C.c_uint8(0)
    clib.check(_lib().vd_otsu_from_hist(h.ctypes.data_as(_P(C.c_uint32)), C.byref(t)), "vd_otsu_from_hist")
    return t.value


def otsu_u8(a, roi=None):
    t = C.c_uint8(0)
    v = clib.view_u8(a)
    clib.check(_lib().vd_otsu_u8(C.byref(v), _roi(roi), C.byref(t)), "vd_otsu_u8")
    return t.value


def median_u8(a, k, roi=None):
    """k x k median (k = 3 or 5) of roi of a; equals cv2.medianBlur(a, k)[roi]."""
    fn = {3: "vd_median3_u8", 5: "vd_median5_u8"}[k]
    out = np.empty(_out_shape(a, roi), np.uint8)
    v = clib.view_u8(a)
    clib.check(getattr(_lib(), fn)(C.byref(v), _roi(roi), C.byref(_image(out))), fn)
    return out


# ---------------------------------------------------------------------------
# Generator of the 5x5 median selection network in lib/src/median.c.
# A network is built symbolically from min/max nodes with constant folding
# (+inf padding) and common-subexpression sharing; only nodes that reach the
# wanted output are emitted. Correctness: a min/max circuit selects the k-th
# order statistic of all inputs iff it does so for all 0/1 inputs (0-1
# principle); with sorted input columns there are only 6^5 such inputs.

_INF, _NINF = "INF", "NINF"


class _Net:
    def __init__(self):
        self.nodes, self.order = {}, []

    def op(self, kind, a, b):
        if a == b:
            return a
        lo_id, hi_id = (_INF, _NINF) if kind == "min" else (_NINF, _INF)
        if a == lo_id:
            return b
        if b == lo_id:
            return a
        if hi_id in (a, b):
            return hi_id
        key = (kind,) + tuple(sorted((a, b)))
        if key not in self.nodes:
            self.nodes[key] = "n%d" % len(self.order)
            self.order.append(key)
        return self.nodes[key]

    def reachable(self, out):
        inv = {v: k for k, v in self.nodes.items()}
        need, stack = set(), [out]
        while stack:
            x = stack.pop()
            if x in need or x not in inv:
                continue
            need.add(x)
            stack += list(inv[x][1:])
        return [(k, self.nodes[k]) for k in self.order if self.nodes[k] in need]


def _oddeven_merge(lo, n, r, pairs):
    # Batcher's odd-even merge of wires lo..lo+n-1 (n a power of two), iterative form
    # of the usual recursion, unrolled by an explicit stack.
    stack = [(lo, n, r, 0)]
    while stack:
        lo, n, r, phase = stack.pop()
        step = r * 2
        if step >= n:
            pairs.append((lo, lo + r))
        elif phase == 0:
            stack.append((lo, n, r, 1))
            stack.append((lo + r, n, step, 0))
            stack.append((lo, n, step, 0))
        else:
            pairs.extend((i, i + r) for i in range(lo + r, lo + n - r, step))


def _merge_sorted(net, a, b):
    m = 1
    while m < max(len(a), len(b)):
        m *= 2
    w = list(a) + [_INF] * (m - len(a)) + list(b) + [_INF] * (m - len(b))
    pairs = []
    _oddeven_merge(0, 2 * m, 1, pairs)
    for i, j in pairs:
        x, y = w[i], w[j]
        w[i], w[j] = net.op("min", x, y), net.op("max", x, y)
    return w[:len(a) + len(b)]


def _kth(net, a, b, k):
    """k-th smallest (1-based) of sorted a u sorted b = min over i+j=k of max(a_i, b_j)."""
    best = None
    for i in range(k + 1):
        j = k - i
        if i > len(a) or j > len(b):
            continue
        m = net.op("max", a[i - 1] if i else _NINF, b[j - 1] if j else _NINF)
        best = m if best is None else net.op("min", best, m)
    return best


def _emit(net, outs, names, indent):
    need = set()
    for o, _ in outs:
        need.update(nm for _, nm in net.reachable(o))
    local, lines = {}, []
    for key in net.order:
        nm = net.nodes[key]
        if nm not in need:
            continue
        kind, a, b = key
        local[nm] = "t%d" % len(local)
        ref = lambda x: names.get(x, local.get(x, x))  # noqa: E731
        lines.append("%sconst uint8_t %s = %s(%s, %s);" % (indent, local[nm], "VD_MIN8" if kind == "min" else "VD_MAX8",
                                                            ref(a), ref(b)))
    for o, target in outs:
        lines.append("%s%s = %s;" % (indent, target, names.get(o, local.get(o, o))))
    return lines


def median_network(check=True):
    """C statements of the two generated blocks of median.c: (pair_lines, select_lines).

    pair: sorted columns a0..a4, b0..b4 -> pr[0..9][i] (Batcher merge, 26 min/max).
    select: p0..p9, q0..q9 (two sorted pairs), c0..c4 (a sorted column) -> out[i], the
    13th smallest of the 25. With check=True both are verified on every 0/1 input."""
    pnet = _Net()
    a = ["a%d" % r for r in range(5)]
    b = ["b%d" % r for r in range(5)]
    merged = _merge_sorted(pnet, a, b)
    pair_lines = _emit(pnet, [(merged[k], "pr[%d][i]" % k) for k in range(10)], {}, " " * 4)

    snet = _Net()
    p = ["p%d" % r for r in range(10)]
    q = ["q%d" % r for r in range(10)]
    c = ["c%d" % r for r in range(5)]
    qc = _merge_sorted(snet, q, c)
    out = _kth(snet, p, qc, 13)
    select_lines = _emit(snet, [(out, "out[i]")], {}, " " * 16)

    if check:
        def run(net, target, env):
            for (kind, x, y), nm in net.reachable(target):
                env[nm] = min(env[x], env[y]) if kind == "min" else max(env[x], env[y])
            return env.get(target)
        for zeros in itertools.product(range(6), repeat=2):  # pair merge: counts of zeros per column
            env = {}
            cols = [[int(r >= z) for r in range(5)] for z in zeros]
            env.update({"a%d" % r: cols[0][r] for r in range(5)})
            env.update({"b%d" % r: cols[1][r] for r in range(5)})
            want = sorted(cols[0] + cols[1])
            for k in range(10):
                assert run(pnet, merged[k], dict(env)) == want[k], "pair merge network is wrong"
        for zeros in itertools.product(range(6), repeat=5):
            cols = [[int(r >= z) for r in range(5)] for z in zeros]
            pv, qv = sorted(cols[0] + cols[1]), sorted(cols[2] + cols[3])
            env = {"p%d" % r: pv[r] for r in range(10)}
            env.update({"q%d" % r: qv[r] for r in range(10)})
            env.update({"c%d" % r: cols[4][r] for r in range(5)})
            assert run(snet, out, env) == sorted(sum(cols, []))[12], "select network is wrong"
    return pair_lines, select_lines
