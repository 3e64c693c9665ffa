# SPDX-License-Identifier: MIT
"""Structured pruning (vdtools.training.cnn_prune): a network whose surplus channels are dead (ReLU output
0 for every input) pruned into the narrower architecture computes exactly what it computed before, and
the channels dropped are the dead ones; architectures that differ beyond channel counts are refused."""
from types import SimpleNamespace

import numpy as np
import pytest

torch = pytest.importorskip("torch", reason="PyTorch is not installed (pip install -e tools[train]); "
                            "pruning is a training tool")

from vdtools.training import cnn_prune as P      # noqa: E402
from vdtools.training import cnn_train as T      # noqa: E402


def _random_net(arch, seed):
    torch.manual_seed(seed)
    net = T.Net(arch)
    with torch.no_grad():
        for m in net.modules():
            if isinstance(m, torch.nn.BatchNorm2d):
                m.running_mean.uniform_(-0.1, 0.1)
                m.running_var.uniform_(0.5, 1.5)
                m.weight.uniform_(0.5, 1.5)
                m.bias.uniform_(0.0, 0.2)
    return net.eval()


def test_dead_channels_are_the_ones_pruned_and_outputs_do_not_change():
    src = _random_net("s32l", 0)
    dst = T.Net("s32m").eval()
    dead = {}
    with torch.no_grad():
        for i, (ds, dd) in enumerate(zip(src.spec, dst.spec)):
            if ds["cout"] != dd["cout"] and ds["op"] == "pw":
                # channels >= dd's width die in this layer and in the depthwise layers that follow it
                dead[i + 1] = np.arange(dd["cout"], ds["cout"])
                j = i
                while True:
                    src.mods[src.spec[j]["mod"]][1].bias[dd["cout"]:] = -1e3
                    nxt = [k for k, d in enumerate(src.spec) if d["in"] == j + 1]
                    if len(nxt) != 1 or src.spec[nxt[0]]["op"] != "dw":
                        break
                    j = nxt[0]
    assert len(dead) == 3                      # s32l -> s32m: the three 160-channel pointwise layers
    rng = np.random.default_rng(1)
    frames = [SimpleNamespace(img=rng.integers(0, 256, (128, 192), dtype=np.uint8)) for _ in range(2)]
    keep = P.keep_sets(src, dst, P.channel_importance(src, frames))
    for t, d in dead.items():
        assert np.array_equal(keep[t], np.arange(len(keep[t]))), t
    P.prune(src, dst, keep)
    x = torch.from_numpy(rng.random((1, 1, 64, 96), dtype=np.float32))
    with torch.no_grad():
        torch.testing.assert_close(dst(x), src(x), rtol=1e-5, atol=1e-5)


def test_pruning_into_the_same_architecture_is_a_copy():
    src = _random_net("compact", 2)
    dst = T.Net("compact").eval()
    keep = P.keep_sets(src, dst, [np.ones(d) for d in [1] + [s["cout"] for s in src.spec]])
    P.prune(src, dst, keep)
    for k, v in src.state_dict().items():
        assert torch.equal(v, dst.state_dict()[k]), k


def test_different_layer_lists_are_refused(tmp_path):
    ck = tmp_path / "c.pt"
    torch.save(dict(net=T.Net("compact").state_dict(), arch="compact"), ck)
    with pytest.raises(SystemExit, match="differ beyond channel counts"):
        P.main([str(ck), "--arch", "s32m", "--out", str(tmp_path / "o.pt")])
