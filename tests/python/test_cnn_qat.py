# SPDX-License-Identifier: MIT
"""Quantisation-aware training (cnn_train --qat) simulates the int8 network the exporter writes: the
fake-quantised float forward of a network, with the exporter's own scales and zero points, must give the
integer codes of the numpy integer reference of its export (which the C library equals bit for bit,
test_cnn_parity.py) up to the rounding of float against integer requantisation. Needs PyTorch (the
`train` extra, not installed by CI: skipped there)."""
import numpy as np
import pytest

torch = pytest.importorskip("torch", reason="PyTorch is not installed (pip install -e tools[train]); "
                            "the QAT simulation test needs it")

from vdtools.formats import cnn_ref as R          # noqa: E402
from vdtools.training import cnn_export as E      # noqa: E402
from vdtools.training import cnn_train as T       # noqa: E402


def _net():
    torch.manual_seed(0)
    net = T.Net("compact")
    with torch.no_grad():
        for m in net.modules():        # batch norm that is not the identity, so folding is exercised
            if isinstance(m, torch.nn.BatchNorm2d):
                m.running_mean.uniform_(-0.2, 0.2)
                m.running_var.uniform_(0.5, 2.0)
                m.weight.uniform_(0.5, 1.5)
                m.bias.uniform_(-0.1, 0.3)
        head = net.mods[net.spec[-1]["mod"]][0]
        head.weight.mul_(20.0)         # the training init scales the head by 0.1: make its codes vary
    net.eval()
    return net


def _planes(n=3, side=64):
    rng = np.random.default_rng(1)
    y, x = np.mgrid[0:side, 0:side]
    out = []
    for _ in range(n):
        a = 100 + 60 * np.sin(x / rng.uniform(4, 9)) * np.cos(y / rng.uniform(4, 9)) + rng.normal(0, 20, x.shape)
        out.append(np.clip(a, 0, 255).astype(np.uint8))
    return out


def _ranges(net, planes):
    """cnn_export.calibrate's percentiles, on planes instead of data-set frames."""
    vals = None
    with torch.no_grad():
        for u in planes:
            ts = net(torch.from_numpy(u[None, None].astype(np.float32) / 255), return_all=True)
            vals = vals or [[] for _ in ts]
            for i, t in enumerate(ts):
                vals[i].append(t.numpy().ravel())
    return [(float(np.percentile(np.concatenate(v), 100.0 - E.CALIB_PCT)),
             float(np.percentile(np.concatenate(v), E.CALIB_PCT))) for v in vals]


def test_fake_quant_forward_matches_integer_reference():
    net = _net()
    planes = _planes()
    desc, q = E.quantise(net, _ranges(net, planes))
    net.set_fake_quant(q)
    for u in planes:
        with torch.no_grad():
            fq = net(torch.from_numpy(u[None, None].astype(np.float32) / 255), return_all=True)
        ref = R.forward(desc, (u.astype(np.int16) - 128).astype(np.int8))
        assert len(fq) == len(ref)
        for t in range(1, len(ref)):
            codes = np.round(fq[t][0].numpy() / q["scale"][t]).astype(np.int64) + q["zp"][t]
            want = ref[t].astype(np.int64).transpose(2, 0, 1)
            d = np.abs(codes - want)
            # float rounding of s_in s_w / s_out against the Q31 multiplier, and the int32 bias rounding,
            # move a value across a rounding boundary now and then: one code, rarely two after a
            # difference upstream; never a different network
            assert d.max() <= 2, f"tensor {t}: max code difference {d.max()}"
            assert (d == 0).mean() >= 0.9 and d.mean() <= 0.1, f"tensor {t}: {(d == 0).mean():.3f} equal, mean {d.mean():.3f}"
        # the head is not degenerate (one code everywhere would make the comparison empty)
        assert len(np.unique(ref[-1])) > 10 and len(np.unique(ref[-1][:, :, 0])) > 4


def test_fake_quant_off_is_the_float_network():
    net = _net()
    x = torch.from_numpy(_planes(1)[0][None, None].astype(np.float32) / 255)
    with torch.no_grad():
        a = net(x)
        desc, q = E.quantise(net, _ranges(net, _planes(1)))
        net.set_fake_quant(q)
        b = net(x)
        net.set_fake_quant(None)
        c = net(x)
    assert torch.equal(a, c)
    assert not torch.equal(a, b)


def test_giou_hand_worked():
    # identical boxes: 1; a box twice as wide, same centre: IoU 1/2, hull = union: 1/2;
    # disjoint boxes 10 px wide, 20 px apart, same height: IoU 0, hull 30 x h, union 20 x h: -1/3
    lw, lh = np.log(10.0), np.log(8.0)
    o = torch.tensor([[lw, lw + np.log(2.0), lw], [lh, lh, lh], [0.0, 0.0, 5.0], [0.0, 0.0, 0.0]])[None, :, :, None]
    t = torch.tensor([[lw, lw, lw], [lh, lh, lh], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])[None, :, :, None]
    g = T.giou(o, t).flatten().tolist()
    assert g[0] == pytest.approx(1.0)
    assert g[1] == pytest.approx(0.5)
    assert g[2] == pytest.approx(-1.0 / 3.0)       # dx = 5 cells x stride 4 = 20 px


def test_soup_is_the_mean_of_the_weights():
    from vdtools.training import cnn_soup as S
    a, b = _net(), T.Net("compact")
    ca = dict(net=a.state_dict(), arch="compact", qat=True, step=1)
    cb = dict(net=b.state_dict(), arch="compact", qat=True, step=2)
    s = S.soup([ca, cb])
    assert s["arch"] == "compact" and s["qat"] and s["soup"] == 2
    for k, v in s["net"].items():
        if v.dtype.is_floating_point:
            torch.testing.assert_close(v, (ca["net"][k] + cb["net"][k]) / 2)
        else:       # batch counters: the first checkpoint's
            assert torch.equal(v, ca["net"][k])
    with pytest.raises(ValueError):
        S.soup([ca, dict(cb, qat=False)])
    with pytest.raises(ValueError):
        S.soup([ca, dict(net=T.Net("main").state_dict(), arch="main", qat=True)])
    with pytest.raises(ValueError):
        S.soup([])


def test_weight_average_hand_worked():
    """cnn_train --ema: the first update copies the network; after the weights and the batch-norm
    statistics all move by +1, one update at decay 0.75 moves the average by 0.25."""
    net = _net()
    avg = T.weight_average(net, 0.75)
    avg.update_parameters(net)
    before = {k: v.clone() for k, v in avg.module.state_dict().items()}
    for k, v in net.state_dict().items():
        assert torch.equal(before[k], v), k
    with torch.no_grad():
        for p in net.parameters():
            p.add_(1.0)
        for m in net.modules():
            if isinstance(m, torch.nn.BatchNorm2d):
                m.running_mean.add_(1.0)
    avg.update_parameters(net)
    after = avg.module.state_dict()
    w = net.spec[0]["mod"]
    for k in (f"mods.{w}.0.weight", f"mods.{w}.1.bias", f"mods.{w}.1.running_mean"):
        assert torch.allclose(after[k], before[k] + 0.25, atol=1e-6), k
    assert torch.allclose(after[f"mods.{w}.1.running_var"], before[f"mods.{w}.1.running_var"])


def test_refresh_bn_measures_the_averaged_weights(monkeypatch):
    """cnn_train --ema re-estimates the average's batch-norm statistics on fixed training crops: the
    first layer's running mean becomes the mean of its convolution over all those crops (equal batches),
    whatever it was before, and no weight moves."""
    net = _net()
    gen = torch.Generator().manual_seed(3)
    xs = [torch.rand(4, 1, 32, 32, generator=gen) for _ in range(T.BN_BATCHES)]
    it = iter(xs)
    monkeypatch.setattr(T, "batch", lambda *a, **k: (next(it),))
    with torch.no_grad():
        net.mods[0][1].running_mean.fill_(1e3)
    weights = {k: v.clone() for k, v in net.state_dict().items() if "running" not in k and "num_batches" not in k}
    T.refresh_bn(net, {})
    conv = net.mods[0][0]
    with torch.no_grad():
        want = torch.stack([conv(x).mean((0, 2, 3)) for x in xs]).mean(0)
    assert torch.allclose(net.mods[0][1].running_mean, want, atol=1e-5)
    for k, v in weights.items():
        assert torch.equal(net.state_dict()[k], v), k


def test_short_run_evaluates_its_last_step_once(data_dir, tmp_path):
    """A run whose time budget ends on a step evaluates that step once: log.json holds each step once and
    final.pt carries that evaluation (the weight average on, so its batch-norm refresh runs too)."""
    import json
    T.main(["--arch", "compact", "--data", str(data_dir), "--out", str(tmp_path), "--minutes", "0.03",
            "--threads", "1", "--batch", "2", "--eval-every", "1000", "--ema", "0.9"])
    log = json.loads((tmp_path / "log.json").read_text())
    steps = [e["step"] for e in log]
    assert steps and len(steps) == len(set(steps)), steps
    final = torch.load(tmp_path / "final.pt", weights_only=False)
    assert final["step"] == steps[-1] and final["val_ap"] == log[-1]["val_ap"]
    assert (tmp_path / "best.pt").is_file()


def test_step_budget_stops_at_that_step(data_dir, tmp_path):
    """--steps replaces the wall-time budget: the run makes exactly that many optimiser steps (so it is the
    same run whatever else shares the cores) and evaluates its last step once."""
    import json
    T.main(["--arch", "compact", "--data", str(data_dir), "--out", str(tmp_path), "--steps", "3",
            "--minutes", "1e-9", "--threads", "1", "--batch", "2", "--eval-every", "1000"])
    log = json.loads((tmp_path / "log.json").read_text())
    assert [e["step"] for e in log] == [3]
    assert torch.load(tmp_path / "final.pt", weights_only=False)["step"] == 3


def test_aux_head_is_dropped_by_the_export(tmp_path):
    """cnn_train --aux: the head gets AUX_CLASSES more channels; a checkpoint without them initialises
    the leading ones (load_weights), and the exporter's load_net keeps only the HEAD exported channels, so
    the float network it quantises computes exactly the trained network's first HEAD outputs."""
    torch.manual_seed(1)
    plain = T.Net("compact")
    net = T.Net("compact", T.AUX_CLASSES)
    head = net.spec[-1]
    assert head["op"] == "head" and head["cout"] == T.HEAD + T.AUX_CLASSES
    T.load_weights(net, plain.state_dict())
    x = torch.rand(1, 1, 64, 64)
    plain.eval()
    net.eval()
    with torch.no_grad():
        y, y_aux = plain(x), net(x)
    torch.testing.assert_close(y_aux[:, :T.HEAD], y)
    hb = net.mods[head["mod"]][0].bias
    assert (hb[T.HEAD:] == -2.19).all()     # the aux channels keep their init (the heatmap prior)
    ck = tmp_path / "aux.pt"
    torch.save(dict(net=net.state_dict(), arch="compact", step=1, qat=False, aux=T.AUX_CLASSES), ck)
    exp, _ = E.load_net(ck)
    assert exp.spec[-1]["cout"] == T.HEAD
    with torch.no_grad():
        torch.testing.assert_close(exp(x), y_aux[:, :T.HEAD])


def test_aux_loss_adds_the_weighted_focal_loss_of_the_extra_channels():
    """loss_fn with aux targets = the vehicle-only loss + AUX_WEIGHT x focal of the channels after HEAD."""
    torch.manual_seed(2)
    out = torch.randn(2, T.HEAD + 2, 8, 8)
    hm = torch.zeros(2, 8, 8)
    hm[0, 3, 3] = 1.0
    m = torch.ones(2, 8, 8)
    reg, regm = torch.zeros(2, 4, 8, 8), torch.zeros(2, 8, 8)
    aux = torch.zeros(2, 2, 8, 8)
    aux[1, 1, 4, 5] = 1.0
    base = T.loss_fn(out[:, :T.HEAD], hm, m, reg, regm)[0]
    with_aux = T.loss_fn(out, hm, m, reg, regm, aux_hm=aux)[0]
    torch.testing.assert_close(with_aux, base + T.AUX_WEIGHT * T.focal(out[:, T.HEAD:], aux, m[:, None]))
    # focal by hand at the single aux positive (all other cells negatives with target 0)
    p = torch.sigmoid(out[:, T.HEAD:]).clamp(1e-4, 1 - 1e-4)
    pos = -(torch.log(p[1, 1, 4, 5]) * (1 - p[1, 1, 4, 5]) ** 2)
    negm = torch.ones_like(p)
    negm[1, 1, 4, 5] = 0
    neg = -(torch.log(1 - p) * p ** 2 * negm).sum()
    torch.testing.assert_close(T.focal(out[:, T.HEAD:], aux, m[:, None]), pos + neg)


def test_soft_focal_hand_worked():
    """Quality focal loss at logit 0 (p = 1/2): target 1 costs ln 2 x (1/2)^2, target 1/2 costs nothing
    (|t - p| = 0), masked cells nothing; the sum is divided by the number of positives."""
    logit = torch.zeros(1, 2, 2)
    target = torch.tensor([[[1.0, 0.5], [1.0, 0.0]]])
    m = torch.tensor([[[1.0, 1.0], [0.0, 1.0]]])
    got = T.soft_focal(logit, target, m, torch.tensor(2.0))
    want = (0.25 * np.log(2.0) + 0.25 * np.log(2.0)) / 2     # cells (0,0) target 1 and (1,1) target 0
    torch.testing.assert_close(got, torch.tensor(want, dtype=torch.float32))
    assert float(T.soft_focal(logit, target, m, torch.tensor(0.0))) == pytest.approx(2 * want)   # n_pos >= 1


def test_ensemble_of_one_network_twice_is_that_network(tmp_path):
    """cnn_eval's FloatEnsemble averages output maps: a network averaged with itself decodes as Float."""
    from vdtools.evaluation import cnn_eval as CE
    ck = tmp_path / "n.pt"
    torch.save(dict(net=_net().state_dict(), arch="compact", step=0), ck)
    img = _planes(1, 128)[0]
    one = CE.Float(str(ck))._peaks(img)
    two = CE.FloatEnsemble([str(ck), str(ck)])._peaks(img)
    assert len(one) == len(two) > 0
    for a, b in zip(one, two):
        np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-5)


def test_teacher_run_and_crop_alignment(data_dir, tmp_path):
    """--teacher: a short distilled run trains and saves; a crop the teacher's input alignment does not
    divide is refused before any training (the teacher would see a differently padded crop)."""
    ck = tmp_path / "teacher.pt"
    torch.save(dict(net=_net().state_dict(), arch="compact", step=0), ck)
    T.main(["--arch", "compact", "--data", str(data_dir), "--out", str(tmp_path / "run"), "--steps", "2",
            "--threads", "1", "--batch", "2", "--eval-every", "1000", "--teacher", str(ck)])
    assert torch.load(tmp_path / "run" / "final.pt", weights_only=False)["step"] == 2
    wide = tmp_path / "s32n.pt"      # input alignment 32: 176 = 5.5 x 32
    torch.save(dict(net=T.Net("s32n").state_dict(), arch="s32n", step=0), wide)
    with pytest.raises(SystemExit):
        T.main(["--arch", "compact", "--data", str(data_dir), "--out", str(tmp_path / "bad"), "--steps", "1",
                "--crop", "176", "--threads", "1", "--teacher", str(wide)])
    assert not (tmp_path / "bad" / "final.pt").exists()
