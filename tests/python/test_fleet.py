# SPDX-License-Identifier: MIT
"""vdtools.evaluation.fleet on a 2-worker Dask LocalCluster: a worker process killed mid-shard and a task that raises,
then every recording compared byte for byte with vd_fir_demo run on the same shards in one process;
resume, the exactly-once check, and the mined hard examples read back by vdtools.data.dataset."""
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from vdtools.bindings import clib, port
from vdtools.data import clip, dataset
from vdtools.evaluation import fleet

pytest.importorskip("distributed", reason="dask[distributed] not installed: pip install -e 'tools[fleet]'")
import cloudpickle  # noqa: E402  (comes with distributed)

BUILD = Path(os.environ.get("VD_BUILD_DIR", clib.REPO / "build"))
DEMO = BUILD / "tools" / "vd_fir_demo"
SHARD = 4   # frames per shard: 9-frame recordings give shards of 4, 4, 1

# the fault-injecting task wrappers below are shipped to the workers by value (this module is not
# importable there)
cloudpickle.register_pickle_by_value(sys.modules[__name__])


@pytest.fixture(scope="module")
def setup(tmp_path_factory, vdlib):
    if not DEMO.exists() or not port.lib_path().exists():
        pytest.skip(f"{DEMO} or {port.lib_path()} not built")
    from distributed import Client, LocalCluster
    d = tmp_path_factory.mktemp("fleet")
    rows = []
    for k, seed in enumerate((21, 22, 23)):
        clip.generate(d / f"c{seed}", frames=9, width=160, height=128, seed=seed)
        rows.append({"id": f"rec{k}", "input": f"c{seed}/u16" if k != 1 else f"c{seed}/u8",
                     "camera": f"cam{k % 2}", "daynight": "night" if k else "day"})
    rows[0]["gt"] = "c21/annotations.json"
    rows[1]["gt"] = "c22/annotations.json"
    (d / "manifest.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
                           silence_logs=50)
    client = Client(cluster)
    yield d, client
    client.close()
    cluster.close()


def faulty(spec, models, marks):
    """run_shard, but the worker process dies (os._exit) after the 3rd frame of shard rec0/1 and shard
    rec2/0 raises, each the first time only (marker files)."""
    kill, boom = Path(marks, "killed"), Path(marks, "raised")

    def on_frame(i):
        if spec["rec"] == "rec0" and spec["index"] == 1 and i == 2 and not kill.exists():
            kill.write_text(str(os.getpid()))
            os._exit(1)
    if spec["rec"] == "rec2" and spec["index"] == 0 and not boom.exists():
        boom.write_text(str(os.getpid()))
        raise RuntimeError("injected failure")
    return fleet.run_shard(spec, models, on_frame=on_frame)


def counting(spec, models, marks):
    Path(marks, f"ran-{spec['rec']}-{spec['index']}").touch()
    return fleet.run_shard(spec, models)


def demo_reference(manifest, tmp):
    """{recording id: vd_fir_demo --json over each shard's frames (a list file), concatenated}."""
    recs = fleet.read_manifest(manifest)
    out = {}
    for s in fleet.plan(recs, SHARD):
        lst = tmp / f"{s['rec']}-{s['index']}.lst"
        lst.write_text("".join(f + "\n" for f in s["files"]))
        js = tmp / f"{s['rec']}-{s['index']}.jsonl"
        subprocess.run([str(DEMO), "--input", str(lst), "--json", str(js), "--quiet"], check=True,
                       stdout=subprocess.DEVNULL)
        out[s["rec"]] = out.get(s["rec"], "") + js.read_text()
    return out


def leftovers(root):
    return [str(p) for p in Path(root).rglob("*") if ".tmp." in p.name or p.name.startswith(".tmp")]


def test_faults_resume_exactly_once_and_mining(setup, tmp_path):
    d, client = setup
    manifest, out, mine, marks = d / "manifest.jsonl", tmp_path / "out", tmp_path / "mine", tmp_path / "marks"
    marks.mkdir()
    pids = set(client.run(os.getpid).values())
    task = lambda spec, models: faulty(spec, models, str(marks))
    rep = fleet.run(manifest, out, shard_frames=SHARD, mine=mine, client=client, shard_fn=task, log=lambda m: None)
    # both faults happened, in a worker process, and the killed one is gone (the nanny started another);
    # the raising shard may run on that replacement, a worker that did not exist when pids was taken
    now = set(client.run(os.getpid).values())
    assert int((marks / "killed").read_text()) in pids
    assert int((marks / "raised").read_text()) in pids | now
    assert int((marks / "killed").read_text()) not in now
    assert rep["recordings"] == 3 and rep["shards"] == 9 and rep["frames"] == 27 and rep["exactly_once"]
    assert leftovers(out) == [] and leftovers(mine) == []
    # frame by frame: the same bytes as the single-process demo on the same shards
    ref = demo_reference(manifest, tmp_path)
    for rid, text in ref.items():
        got = (out / "recordings" / f"{rid}.jsonl").read_text()
        assert got.splitlines() == text.splitlines()
        assert len(got.splitlines()) == 9
    # accuracy: the report's counts agree with vdtools.metrics.evaluate on the merged files
    from vdtools.metrics.evaluate import evaluate_jsonl
    tp = fp = veh = 0
    for rid, seed in (("rec0", 21), ("rec1", 22)):
        e = evaluate_jsonl(out / "recordings" / f"{rid}.jsonl", d / f"c{seed}" / "annotations.json")
        tp, fp, veh = tp + e["tp"], fp + e["fp"], veh + e["vehicles"]
    a = rep["accuracy"]["all"]
    assert (a["tp"], a["fp"], a["vehicles"], a["frames_annotated"]) == (tp, fp, veh, 18)
    assert veh > 0
    assert rep["accuracy"]["camera=cam0"]["vehicles"] + rep["accuracy"]["camera=cam1"]["vehicles"] == veh
    # mining: one crop per false positive and per missed vehicle, readable by the training tools
    assert rep["mined"] == {"crops": fp + veh - tp, "fp": fp, "miss": veh - tp}
    recs = dataset._load_coco(mine / "annotations.json", mine / "images", "mined", lambda fn: "mined")
    assert len(recs) == fp + veh - tp
    doc = json.loads((mine / "annotations.json").read_text())
    for im, r in zip(sorted(doc["images"], key=lambda i: i["filename"]), recs):
        assert (mine / "images" / im["filename"]).exists()
        assert im["kind"] != "miss" or r.vehicles   # a miss's crop holds its vehicle
        assert im["frame"].endswith(".pgm") and im["recording"] in ("rec0", "rec1")
        assert Path(im["frame_path"]).name == im["frame"] and Path(im["frame_path"]).is_file()

    # resume: nothing runs again
    rep2 = fleet.run(manifest, out, shard_frames=SHARD, mine=mine, client=client,
                     shard_fn=lambda s, m: counting(s, m, str(marks)), log=lambda m: None)
    assert list(marks.glob("ran-*")) == [] and rep2["frames"] == 27 and rep2["frames_run"] == 0
    # an incomplete shard (no metrics: killed before its last rename) runs again, alone
    (out / "shards" / "rec1" / "00001.json").unlink()
    (out / "shards" / "rec1" / "00001.jsonl").write_text("partial\n")
    # (through the scheduler's address, as --scheduler does)
    rep3 = fleet.run(manifest, out, shard_frames=SHARD, mine=mine, scheduler=client.scheduler.address,
                     shard_fn=lambda s, m: counting(s, m, str(marks)), log=lambda m: None)
    assert sorted(p.name for p in marks.glob("ran-*")) == ["ran-rec1-1"]
    assert rep3["frames_run"] == 4 and rep3["mined"] == rep["mined"]
    assert (out / "recordings" / "rec1.jsonl").read_text().splitlines() == ref["rec1"].splitlines()

    # a frame twice fails loudly
    j = out / "shards" / "rec2" / "00000.jsonl"
    j.write_text(j.read_text() + j.read_text().splitlines(keepends=True)[0])
    with pytest.raises(fleet.FleetError, match="exactly-once"):
        fleet.run(manifest, out, shard_frames=SHARD, client=client, log=lambda m: None)


def test_manifest_csv_and_plan(tmp_path):
    (tmp_path / "r").mkdir()
    for n in ("b.pgm", "a.pgm", "c.png", "notes.md", ".hidden.pgm"):
        (tmp_path / "r" / n).write_bytes(b"")
    (tmp_path / "m.csv").write_text("id,input,camera,daynight\nx,r,cam7,day\n")
    recs = fleet.read_manifest(tmp_path / "m.csv")
    assert recs[0]["id"] == "x" and recs[0]["meta"] == {"camera": "cam7", "daynight": "day"}
    shards = fleet.plan(recs, 2)
    assert [s["names"] for s in shards] == [["a.pgm", "b.pgm"], ["c.png"]]
    assert [s["names"] for s in fleet.plan(recs, 0)] == [["a.pgm", "b.pgm", "c.png"]]


def test_settings_follow_the_demo():
    fields, cnn, dbn, desc = fleet.resolve({})
    assert desc == {"sources": "cnn", "cnn_model": "vd_cnn.vdm", "cnn_model2": "vd_cnn2.vdm"} and dbn is None
    assert isinstance(cnn, tuple) and len(cnn) == 2
    # the demo's defaults: the pair of networks with the fused flip pass, the larger top-K (100) as
    # candidates and the library's 32 detections (tools/demo/common/models.c: under 256 KiB of workspace)
    assert fields["cnn_flip"] == 1 and fields["max_candidates"] == 100 and fields["max_detections"] == 32
    fields = fleet.resolve({"cnn-flip": "off"})[0]
    assert fields["cnn_flip"] == 0 and fields["max_candidates"] == 100 and fields["max_detections"] == 32
    assert "cnn_res" not in fields and fleet.resolve({"cnn-full-res": "on"})[0]["cnn_res"] == 1
    with pytest.raises(fleet.FleetError, match="switch"):
        fleet.resolve({"cnn-full-res": "maybe"})
    # auto (the default, as the demo's) sets no field: run() measures each recording (auto_resolution)
    assert "cnn_res" not in fleet.resolve({"cnn-full-res": "auto"})[0]
    assert fleet.resolve({"cnn-full-res": "off"})[0]["cnn_res"] == 0
    # cnn-res: half / full / quarter are cfg.cnn_res 0 / 1 / 2, auto as cnn-full-res auto; the later one wins
    assert [fleet.resolve({"cnn-res": v})[0]["cnn_res"] for v in ("half", "full", "quarter")] == [0, 1, 2]
    assert "cnn_res" not in fleet.resolve({"cnn-res": "auto"})[0]
    assert fleet.resolve({"cnn-full-res": "on", "cnn-res": "quarter"})[0]["cnn_res"] == 2
    assert "cnn_res" not in fleet.resolve({"cnn-res": "quarter", "cnn-full-res": "auto"})[0]
    with pytest.raises(fleet.FleetError, match="cnn-res"):
        fleet.resolve({"cnn-res": "eighth"})
    fields, cnn, dbn, desc = fleet.resolve({"cnn-model2": "none"})   # one network: room for both passes' top-K
    assert desc == {"sources": "cnn", "cnn_model": "vd_cnn.vdm"} and isinstance(cnn, bytes)
    assert fields["max_candidates"] == 200 and fields["max_detections"] == 100
    fields, cnn, dbn, desc = fleet.resolve({"cnn-model": str(fleet.clib.REPO / "models" / "vd_cnn.vdm")})
    assert "cnn_model2" not in desc   # a named first network runs alone unless cnn-model2 is named too
    fields, cnn, dbn, desc = fleet.resolve({"sources": "hotspot", "temporal": "off"})
    assert cnn is None and desc["dbn_model"] == "vd_dbn_grey.vdm" and fields["temporal"] is False
    assert fleet.resolve({"cnn_thr": 0.35})[0]["cnn_score_thr_q15"] == 11469   # round(0.35 * 32768)
    # --track-confirm HI[,LO] as settings.c reads it: LO left out is HI - 0.07; LO > HI is refused
    f = fleet.resolve({"track-confirm": "0.4"})[0]
    assert (f["temporal_cfg.confirm_hi_q15"], f["temporal_cfg.confirm_lo_q15"]) == (13107, 10813)  # 0.4, 0.33
    f = fleet.resolve({"track_confirm": "0.5,0.25"})[0]
    assert (f["temporal_cfg.confirm_hi_q15"], f["temporal_cfg.confirm_lo_q15"]) == (16384, 8192)
    for bad in ("0.3,0.4", "1.5", "x", "0.4,0.3,0.2", "0"):
        with pytest.raises(fleet.FleetError, match="track-confirm"):
            fleet.resolve({"track-confirm": bad})
    # --grey-window / --grey-tail as settings.c reads them; auto (the default) sets no field: run() decides
    # per recording (grey_decision)
    assert "grey_mode" not in fleet.resolve({})[0] and "grey_mode" not in fleet.resolve({"grey-window": "auto"})[0]
    assert fleet.resolve({"grey-window": "frame"})[0]["grey_mode"] == 1
    assert fleet.resolve({"grey_window": "fixed", "grey-tail": 2.5})[0]["grey_tail_permille"] == 25
    for k, bad in (("grey-window", "median"), ("grey-tail", "50"), ("grey-tail", "0.04")):
        with pytest.raises(fleet.FleetError, match=k):
            fleet.resolve({k: bad})
    # --cnn-polarity: auto sets no field (run() measures each recording, as for the resolution); the default is
    # the demo's
    assert fleet.resolve({"cnn-polarity": "black-hot"})[0]["cnn_invert"] == 1
    assert fleet.resolve({"cnn-polarity": "white-hot"})[0]["cnn_invert"] == 0
    assert "cnn_invert" not in fleet.resolve({"cnn-polarity": "auto"})[0]
    assert ("cnn_invert" not in fleet.resolve({})[0]) == (fleet.DEFAULT_POLARITY == "auto")
    with pytest.raises(fleet.FleetError, match="cnn-polarity"):
        fleet.resolve({"cnn-polarity": "grey-hot"})
    with pytest.raises(fleet.FleetError, match="not supported"):
        fleet.resolve({"window-preset": "msrs"})
