# SPDX-License-Identifier: MIT
"""The same quantised CNN as an int8 ONNX graph (QLinearConv, Resize nearest, Concat), the benchmark peer
of vd's C inference (docs/performance.md). Weights, biases and zero points are the .vdm's; the float scales
onnxruntime needs are rebuilt from the per-tensor scales of the export (ONNX requantises in float, so its
int8 outputs may differ from vd's by one step; the benchmark compares time, parity is vd's own test).

    python3 -m vdtools.formats.cnn_onnx models/vd_cnn.vdm --scales models/vd_cnn.scales.json --out out/vd_cnn.onnx
"""
import argparse
import json

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper

from vdtools.formats import cnn_vdm as V


def build(desc, scales, width, height, u8=False):
    """ONNX model of desc for a (1, 1, height, width) int8 input; scales[t] = real scale of tensor t.
    u8: activations as uint8 with every zero point + 128 (the same quantisation, u8s8 kernels: the
    layout onnxruntime's x86 int8 GEMMs are fastest with)."""
    nodes, inits = [], []
    adt = np.uint8 if u8 else np.int8
    off = 128 if u8 else 0
    zp = [desc["input_zp"]]
    names = ["x"]

    def const(name, arr):
        inits.append(numpy_helper.from_array(np.asarray(arr), name))
        return name

    for i, L in enumerate(desc["layers"]):
        src = names[L["in"]]
        out = f"t{i + 1}"
        op = L["op"]
        if op in (V.CONV3X3, V.DW3X3, V.PW1X1):
            s_in, s_out = scales[L["in"]], scales[i + 1]
            mult = L["mult"].astype(np.float64) * np.power(2.0, L["shift"].astype(np.float64) - 31)
            s_w = (mult * s_out / s_in).astype(np.float32)
            cout, cin = L["cout"], L["cin"]
            if op == V.CONV3X3:
                w = L["w"].reshape(cout, 3, 3, cin).transpose(0, 3, 1, 2)
                k, g = 3, 1
            elif op == V.DW3X3:
                w = L["w"].reshape(3, 3, cout).transpose(2, 0, 1)[:, None]
                k, g = 3, cout
            else:
                w = L["w"].reshape(cout, cin)[:, :, None, None]
                k, g = 1, 1
            p = f"l{i}_"
            nodes.append(helper.make_node(
                "QLinearConv",
                [src, const(p + "xs", np.float32(s_in)), const(p + "xz", adt(zp[L["in"]] + off)),
                 const(p + "w", np.ascontiguousarray(w, np.int8)), const(p + "ws", s_w),
                 const(p + "wz", np.zeros(cout, np.int8)),
                 const(p + "ys", np.float32(s_out)), const(p + "yz", adt(L["out_zp"] + off)),
                 const(p + "b", L["bias"].astype(np.int32))],
                [out], kernel_shape=[k, k], pads=[k // 2] * 4, strides=[L["stride"]] * 2, group=g))
        elif op == V.UPSAMPLE2:
            nodes.append(helper.make_node("Resize", [src, "", const(f"l{i}_sc", np.array([1, 1, 2, 2], np.float32))],
                                          [out], mode="nearest", nearest_mode="floor",
                                          coordinate_transformation_mode="asymmetric"))
        elif op == V.CONCAT:
            nodes.append(helper.make_node("Concat", [src, names[L["in2"]]], [out], axis=1))
        elif op == V.MAXPOOL2:
            nodes.append(helper.make_node("MaxPool", [src], [out], kernel_shape=[2, 2], strides=[2, 2]))
        else:
            raise ValueError(f"op {op}")
        names.append(out)
        zp.append(L["out_zp"])
    f = desc["out_stride"]
    graph = helper.make_graph(
        nodes, "vd_cnn",
        [helper.make_tensor_value_info("x", TensorProto.UINT8 if u8 else TensorProto.INT8, [1, 1, height, width])],
        [helper.make_tensor_value_info(names[-1], TensorProto.UINT8 if u8 else TensorProto.INT8,
                                       [1, desc["layers"][-1]["cout"], height // f, width // f])],
        inits)
    m = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 13)])
    m.ir_version = 8
    onnx.checker.check_model(m)
    return m


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("vdm")
    ap.add_argument("--scales", required=True, help="JSON list of per-tensor scales written by vdtools.training.cnn_export")
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=256)
    ap.add_argument("--out", required=True)
    a = ap.parse_args(argv)
    desc = V.unpack(open(a.vdm, "rb").read())
    scales = json.load(open(a.scales))["scale"]
    onnx.save(build(desc, scales, a.width, a.height), a.out)
    print(f"wrote {a.out}")


if __name__ == "__main__":
    main()
