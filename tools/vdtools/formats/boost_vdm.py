# SPDX-License-Identifier: MIT
"""The boosted-stump kind of the .vdm model file (format version 4, docs/model-format.md "Boosted kind"):
paper 003's verifier = an int8 CNN (a complete version-3 CNN blob, embedded) whose selected feature maps
feed AdaBoost decision stumps in fixed point. Pack / unpack / validate like vd_boost_load, the integer
reference score; the C library (vd_boost_*) is vdtools.bindings.boost.

A description ("desc") is a plain dict:
    name          <= 16 printable ASCII characters
    cnn           CNN desc (vdtools.formats.cnn_vdm), input_w = input_h = the crop side (64)
    maps          list of (tensor, channel): the selected feature maps, in feature order (1..16)
    stumps        int array [n, 5]: map index, position y * w + x in that map, threshold (int8),
                  left value, right value (int16); stump output = left if feature <= threshold else right
    threshold     int32: accept (vehicle) when score >= threshold

    score = sum over stumps of (x[map][pos] <= thr ? left : right)   (int32; |score| <= n * 32767 < 2^31)
"""
import struct
import zlib

import numpy as np

from vdtools.formats import cnn_ref as R
from vdtools.formats import cnn_vdm as V

FORMAT_VERSION = 4
KIND = 3
HEADER_SIZE = 64
STUMP_SIZE = 8
MAX_MAPS = 16
MAX_STUMPS = 4096
NAME_LEN = 16
# magic, version, header_size, total_size, crc, kind, n_maps, n_stumps, cnn_off, cnn_len, maps_off,
# stumps_off, threshold, name, reserved
HEADER_FMT = "<4sHHIIBBHIIIIi16s8s"
STUMP_FMT = "<HBbhh"     # pos, map, thr, left, right
assert struct.calcsize(HEADER_FMT) == HEADER_SIZE and struct.calcsize(STUMP_FMT) == STUMP_SIZE


def _al4(n):
    return (n + 3) & ~3


def map_shapes(cnn_desc, maps):
    """(h, w) of every selected map at the crop size."""
    sh = R.shapes(cnn_desc, int(cnn_desc["input_w"]), int(cnn_desc["input_h"]))
    return [sh[t][:2] for t, _ in maps]


def validate(desc):
    cnn = V.validate(desc["cnn"])
    maps = [(int(t), int(c)) for t, c in desc["maps"]]
    if not 1 <= len(maps) <= MAX_MAPS:
        raise ValueError(f"maps: 1..{MAX_MAPS} expected")
    sh = R.shapes(cnn, cnn["input_w"], cnn["input_h"])
    for t, c in maps:
        if not 1 <= t <= len(cnn["layers"]) or not 0 <= c < sh[t][2]:
            raise ValueError(f"map ({t}, {c}) is not a channel of a layer output")
    st = np.asarray(desc["stumps"], np.int64).reshape(-1, 5)
    if not 1 <= len(st) <= MAX_STUMPS:
        raise ValueError(f"stumps: 1..{MAX_STUMPS} expected")
    for k, (mi, pos, thr, lv, rv) in enumerate(st):
        if not 0 <= mi < len(maps):
            raise ValueError(f"stump {k}: map {mi}")
        h, w = sh[maps[mi][0]][:2]
        if not 0 <= pos < h * w:
            raise ValueError(f"stump {k}: position {pos} outside the {w}x{h} map")
        if not -128 <= thr <= 127 or not -32767 <= lv <= 32767 or not -32767 <= rv <= 32767:
            raise ValueError(f"stump {k}: threshold / values out of range")
    name = str(desc.get("name", ""))
    if len(name) > NAME_LEN or any(not 0x20 <= ord(c) <= 0x7E for c in name):
        raise ValueError("name: at most 16 printable ASCII characters")
    thr = int(desc["threshold"])
    if not -(1 << 31) <= thr < (1 << 31):
        raise ValueError("threshold: int32")
    return dict(name=name, cnn=cnn, maps=maps, stumps=st.astype(np.int32), threshold=thr)


def pack(desc):
    d = validate(desc)
    cnn_blob = V.pack(d["cnn"])
    n_maps, n_st = len(d["maps"]), len(d["stumps"])
    maps_off = HEADER_SIZE
    stumps_off = _al4(maps_off + 4 * n_maps)
    cnn_off = _al4(stumps_off + STUMP_SIZE * n_st)
    total = _al4(cnn_off + len(cnn_blob))
    buf = bytearray(total)
    for i, (t, c) in enumerate(d["maps"]):
        struct.pack_into("<BBH", buf, maps_off + 4 * i, t, 0, c)
    for i, (mi, pos, thr, lv, rv) in enumerate(d["stumps"]):
        struct.pack_into(STUMP_FMT, buf, stumps_off + STUMP_SIZE * i, int(pos), int(mi), int(thr), int(lv), int(rv))
    buf[cnn_off:cnn_off + len(cnn_blob)] = cnn_blob
    hdr = struct.pack(HEADER_FMT, b"VDMF", FORMAT_VERSION, HEADER_SIZE, total, 0, KIND, n_maps, n_st, cnn_off,
                      len(cnn_blob), maps_off, stumps_off, d["threshold"], d["name"].encode("ascii"), b"\0" * 8)
    buf[:HEADER_SIZE] = hdr
    struct.pack_into("<I", buf, 12, zlib.crc32(bytes(buf[16:])) & 0xFFFFFFFF)
    return bytes(buf)


def unpack(blob):
    (magic, ver, hs, total, crc, kind, n_maps, n_st, cnn_off, cnn_len, maps_off, stumps_off, thr, name,
     _) = struct.unpack_from(HEADER_FMT, blob, 0)
    if magic != b"VDMF" or ver != FORMAT_VERSION or hs != HEADER_SIZE or kind != KIND or total > len(blob):
        raise ValueError("not a boosted-kind .vdm")
    if zlib.crc32(blob[16:total]) & 0xFFFFFFFF != crc:
        raise ValueError("CRC mismatch")
    maps = [struct.unpack_from("<BBH", blob, maps_off + 4 * i)[::2] for i in range(n_maps)]
    st = [struct.unpack_from(STUMP_FMT, blob, stumps_off + STUMP_SIZE * i) for i in range(n_st)]
    stumps = np.array([(m, p, t, lv, rv) for p, m, t, lv, rv in st], np.int32).reshape(-1, 5)
    return validate(dict(name=name.rstrip(b"\0").decode("ascii"), cnn=V.unpack(blob[cnn_off:cnn_off + cnn_len]),
                         maps=maps, stumps=stumps, threshold=thr))


# ------------------------------------------------------------------ integer reference

def features_from_tensors(d, ts):
    """int8 feature vector: the selected maps of the tensors ts (cnn_ref.forward), concatenated
    (map order, then raster order)."""
    return np.concatenate([np.asarray(ts[t])[:, :, c].reshape(-1) for t, c in d["maps"]])


def map_offsets(d):
    sizes = [h * w for h, w in map_shapes(d["cnn"], d["maps"])]
    return np.r_[0, np.cumsum(sizes)][:-1]


def score_features(d, F):
    """int64 scores of feature rows F [n, n_features] (int8) by the stumps of d."""
    F = np.asarray(F)
    st = np.asarray(d["stumps"], np.int64)
    col = map_offsets(d)[st[:, 0]] + st[:, 1]
    x = F[:, col].astype(np.int64)
    return np.where(x <= st[:, 2], st[:, 3], st[:, 4]).sum(axis=1)


def forward_batch(cnn, X_u8, tensors):
    """{t: int8 [N, h, w, c]} for the tensors t of cnn on crops X_u8 [N, h, w]: cnn_ref.forward's integer
    arithmetic (float64 im2col products, exact below 2^53; cnn_ref.requant) vectorised over the crops.
    The parity test checks it equals cnn_ref.forward crop by crop."""
    x = np.stack([R.preprocess(a, cnn)[:, :, 0] for a in X_u8])[..., None]
    zps = V.tensor_zps(cnn)
    ts = [x]
    last = max(tensors)
    for i, L in enumerate(cnn["layers"][:last]):
        op, xin, zp = V.op_id(L["op"]), ts[L["in"]], zps[L["in"]]
        n, h, w, c = xin.shape
        if op in (V.CONV3X3, V.CONV5X5):
            ks = 3 if op == V.CONV3X3 else 5
            st, pad = int(L["stride"]), ks // 2
            ho, wo = h // st, w // st
            # float32 is exact while every partial sum stays below 2^24 (|w (x - zp)| <= 128 * 255): half
            # the memory traffic of float64 for the boosted kind's small networks
            ft = np.float32 if ks * ks * c * 128 * 255 < (1 << 24) else np.float64
            p = np.zeros((n, h + 2 * pad, w + 2 * pad, c), ft)
            p[:, pad:pad + h, pad:pad + w] = xin.astype(ft) - ft(zp)
            # The columns of one kernel row (kx, c) for every padded input row, then one product per ky:
            # ks times less copying than a whole im2col (5x faster on the boosted kind's 64x64 crops).
            cols = np.empty((n, h + 2 * pad, wo, ks, c), ft)
            for kx in range(ks):
                cols[:, :, :, kx] = p[:, :, kx:(wo - 1) * st + kx + 1:st]
            cols = cols.reshape(n, h + 2 * pad, wo, ks * c)
            wk = np.asarray(L["w"], ft).reshape(L["cout"], ks, ks * c)
            a = np.zeros((n, ho, wo, L["cout"]), ft)
            for ky in range(ks):
                a += cols[:, ky:(ho - 1) * st + ky + 1:st] @ wk[:, ky].T   # integer partial sums, exact as above
            acc = np.rint(a).astype(np.int64)
            ts.append(R.requant(acc + np.asarray(L["bias"], np.int64), L))
        elif op == V.PW1X1:
            a = (xin.reshape(-1, c).astype(np.float64) - zp) @ np.asarray(L["w"], np.float64).reshape(L["cout"], c).T
            acc = np.rint(a).astype(np.int64).reshape(n, h, w, -1)
            ts.append(R.requant(acc + np.asarray(L["bias"], np.int64), L))
        elif op == V.MAXPOOL2:
            ts.append(xin.reshape(n, h // 2, 2, w // 2, 2, c).max(axis=(2, 4)))
        elif op == V.DW3X3:
            st = int(L["stride"])
            ho, wo = h // st, w // st
            p = np.zeros((n, h + 2, w + 2, c), np.int64)
            p[:, 1:-1, 1:-1] = xin.astype(np.int64) - zp
            wk = np.asarray(L["w"], np.int64).reshape(3, 3, c)
            acc = np.zeros((n, ho, wo, c), np.int64)
            for ky in range(3):
                for kx in range(3):
                    acc += wk[ky, kx] * p[:, ky:(ho - 1) * st + ky + 1:st, kx:(wo - 1) * st + kx + 1:st]
            ts.append(R.requant(acc + np.asarray(L["bias"], np.int64), L))
        elif op == V.UPSAMPLE2:
            ts.append(xin.repeat(2, axis=1).repeat(2, axis=2))
        elif op == V.CONCAT:
            ts.append(np.concatenate([xin, ts[L["in2"]]], axis=3))
        else:
            raise ValueError(f"forward_batch: op {op} not supported")
    return {t: ts[t] for t in tensors}


def score_batch(d, X_u8, chunk=8):
    """int64 scores of crops X_u8 [N, h, w] (== score() per crop), chunk crops at a time."""
    out = []
    ts_needed = sorted({t for t, _ in d["maps"]})
    for i in range(0, len(X_u8), chunk):
        T = forward_batch(d["cnn"], X_u8[i:i + chunk], ts_needed)
        F = np.concatenate([T[t][:, :, :, c].reshape(len(T[t]), -1) for t, c in d["maps"]], axis=1)
        out.append(score_features(d, F))
    return np.concatenate(out) if out else np.zeros(0, np.int64)


def score(d, crop_u8):
    """What vd_boost_score returns for one crop (side x side uint8)."""
    ts = R.forward(d["cnn"], R.preprocess(np.asarray(crop_u8, np.uint8), d["cnn"]))
    return int(score_features(d, features_from_tensors(d, ts)[None])[0])
