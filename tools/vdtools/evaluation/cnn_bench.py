# SPDX-License-Identifier: MIT
"""Speed of vd's int8 CNN against onnxruntime running the same quantised network (docs/performance.md).

Both run single-threaded in one process on the same network inputs (real test-split frames at half
resolution, stretched and quantised by the numpy reference, so both see identical int8 tensors): vd
through the shared library (vd_cnn_run, the head tensor only; decoding is timed separately), onnxruntime
1 intra-op thread, all graph optimisations, on two exports of the network: int8 activations (s8s8, the
.vdm's zero points as they are) and uint8 activations (u8s8, every zero point + 128: the same arithmetic
up to onnxruntime's float requantisation, and the layout its x86 kernels are fastest with). Median over
ROUNDS passes of all frames; the ratio vd / onnxruntime is taken within the same run.

    VD_LIB=build/libvd.so python3 -m vdtools.evaluation.cnn_bench --model models/vd_cnn.vdm [--frames 20] [--rounds 5]
"""
import argparse
import json
import statistics
import time
from pathlib import Path

import numpy as np

from vdtools.bindings import clib
from vdtools.data import cnn_data as CD
from vdtools.evaluation import cnn_eval as E
from vdtools.formats import cnn_onnx as O
from vdtools.formats import cnn_ref as R
from vdtools.formats import cnn_vdm as V
from vdtools.bindings import cnn as vd_cnn


def timed(fn, xs, rounds):
    fn(xs[0])                                  # warm-up
    per = []
    for _ in range(rounds):
        t0 = time.perf_counter()
        for x in xs:
            fn(x)
        per.append((time.perf_counter() - t0) * 1e3 / len(xs))
    return statistics.median(per), per


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--model", required=True)
    ap.add_argument("--scales", help="per-tensor scales JSON (default: the model's .scales.json beside it)")
    ap.add_argument("--data", default=str(clib.REPO.parent / "shared" / "data"))
    ap.add_argument("--frames", type=int, default=20)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--out", help="JSON record")
    a = ap.parse_args(argv)
    import onnxruntime as ort
    blob = Path(a.model).read_bytes()
    desc = V.unpack(blob)
    scales = json.loads(Path(a.scales or str(Path(a.model).with_suffix("")) + ".scales.json").read_text())["scale"]
    # 640x512 drone frames (network input 320x256, the reference size): one input size per session
    frames = [f for f in CD.load_frames(a.data, splits=("test",)) if f.img.shape == (512, 640)]
    idx = np.linspace(0, len(frames) - 1, a.frames).astype(int)
    align = V.alignment(desc)
    imgs = [E.net_input(frames[i].img, align) for i in idx]
    h, w = imgs[0].shape
    q = [R.preprocess(im, desc) for im in imgs]           # int8 [h, w, 1]
    cm = vd_cnn.CModel(blob)
    res = {"model": Path(a.model).name, "input": [w, h], "frames": len(imgs), "rounds": a.rounds,
           "macs": R.macs(desc, w, h), "ort_version": ort.__version__}
    res["vd_run_ms"], _ = timed(lambda im: cm.run(im), imgs, a.rounds)
    head = cm.run(imgs[0])
    res["vd_decode_ms"], _ = timed(lambda _x: cm.decode(head, 2 * w, 2 * h), [0] * 50, a.rounds)
    so = ort.SessionOptions()
    so.intra_op_num_threads = 1
    so.inter_op_num_threads = 1
    so.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_ALL
    for tag, u8 in (("ort_s8s8_ms", False), ("ort_u8s8_ms", True)):
        m = O.build(desc, scales, w, h, u8=u8)
        sess = ort.InferenceSession(m.SerializeToString(), so, providers=["CPUExecutionProvider"])
        xs = [(x[:, :, 0].astype(np.int16) + 128).astype(np.uint8)[None, None] if u8 else x[:, :, 0][None, None]
              for x in q]
        res[tag], _ = timed(lambda x: sess.run(None, {"x": x}), xs, a.rounds)
        # agreement with vd's head (onnxruntime requantises in float: expect at most a step or two)
        o = sess.run(None, {"x": xs[0]})[0][0].transpose(1, 2, 0).astype(np.int16) - (128 if u8 else 0)
        res[tag.replace("_ms", "_max_abs_diff")] = int(np.abs(o - head.astype(np.int16)).max())
    res["ratio_vd_over_ort_s8s8"] = res["vd_run_ms"] / res["ort_s8s8_ms"]
    res["ratio_vd_over_ort_u8s8"] = res["vd_run_ms"] / res["ort_u8s8_ms"]
    print(json.dumps(res, indent=1))
    if a.out:
        Path(a.out).write_text(json.dumps(res, indent=1) + "\n")


if __name__ == "__main__":
    main()
