# SPDX-License-Identifier: MIT
"""vdtools.data.sequences (issue 38): short sequences of HIT-UAV frames, grouped by flight `T_H_A` with index
gaps <= 10, each keeping its flight's split. Hand-made file names, no data; one check on ../shared/data
(skipped when it is absent)."""
import json
from pathlib import Path

from vdtools.data import sequences as S
from vdtools.data.dataset import FrameRec


def hit(name, nveh=1):
    """A HIT-UAV frame record as vdtools.data.dataset makes it (group "hit:T_H_A")."""
    return FrameRec("hit", name, Path("images") / name, "hit:" + "_".join(name.split("_")[:3]),
                    vehicles=[(0, 0, 10, 10)] * nveh)


# Flight 0_60_30 (val): 100, 105, 115 (gaps 5 and 10: one sequence), 126 (gap 11: alone), 200, 201.
# Flight 1_80_50 (train): 5, 7, then 50 (gap 43: alone). Given out of order, with an MSRS frame that is skipped.
FRAMES = [hit("0_60_30_0_00115.jpg"), hit("1_80_50_0_00007.jpg", 2), hit("0_60_30_0_00100.jpg"),
          hit("0_60_30_0_00201.jpg", 3), hit("0_60_30_0_00126.jpg"), hit("1_80_50_0_00050.jpg"),
          FrameRec("msrs", "00001D.png", Path("00001D.png"), "msrs:0"), hit("0_60_30_0_00105.jpg"),
          hit("1_80_50_0_00005.jpg"), hit("0_60_30_0_00200.jpg")]
SPLITS = {"hit:0_60_30": "val", "hit:1_80_50": "train", "msrs:0": "test"}


def names(frames):
    return [f.name for f in frames]


def test_frame_index_and_flight():
    assert S.frame_index("0_60_30_0_00115.jpg") == 115
    assert S.frame_index("images/1_80_50_1_03585.jpg") == 3585
    assert S.flight_of("1_80_50_1_03585.jpg") == "1_80_50"


def test_grouping_by_flight_and_gap():
    seqs, single = S.find_sequences(FRAMES, split_of=SPLITS)
    # train before val; within a split by flight, then first index
    assert [s["id"] for s in seqs] == ["1_80_50-00005", "0_60_30-00100", "0_60_30-00200"]
    assert [s["split"] for s in seqs] == ["train", "val", "val"]
    assert [s["flight"] for s in seqs] == ["1_80_50", "0_60_30", "0_60_30"]
    assert [s["indices"] for s in seqs] == [[5, 7], [100, 105, 115], [200, 201]]
    assert [s["gaps"] for s in seqs] == [[2], [5, 10], [1]]   # a gap of exactly 10 stays in the sequence
    assert names(seqs[1]["frames"]) == ["0_60_30_0_00100.jpg", "0_60_30_0_00105.jpg", "0_60_30_0_00115.jpg"]
    assert sorted(names(single)) == ["0_60_30_0_00126.jpg", "1_80_50_0_00050.jpg"]   # gaps 11 and 43


def test_max_gap_and_min_len():
    seqs, single = S.find_sequences(FRAMES, split_of=SPLITS, max_gap=4)
    # 100 -> 105 is 5 > 4: 100, 105, 115, 126 are each alone; 5, 7 and 200, 201 stay
    assert [s["indices"] for s in seqs] == [[5, 7], [200, 201]]
    assert len(single) == 5
    seqs, single = S.find_sequences(FRAMES, split_of=SPLITS, min_len=3)
    assert [s["indices"] for s in seqs] == [[100, 105, 115]]
    assert len(single) == 6   # 5, 7, 50, 126, 200, 201


def test_split_kept_per_flight():
    # Whatever split a flight has, all its sequences and singletons have it: no flight is cut across splits.
    for sp in ("train", "val", "test"):
        seqs, _ = S.find_sequences(FRAMES, split_of={**SPLITS, "hit:0_60_30": sp})
        assert {s["split"] for s in seqs if s["flight"] == "0_60_30"} == {sp}
        assert {s["split"] for s in seqs if s["flight"] == "1_80_50"} == {"train"}


def test_summary_reports_gaps():
    seqs, single = S.find_sequences(FRAMES, split_of=SPLITS)
    r = S.summary(seqs, single, SPLITS)
    assert r["val"] == dict(flights=1, sequences=2, frames=5, vehicles=1 + 1 + 1 + 1 + 3, singletons=1,
                            gaps={1: 1, 5: 1, 10: 1}, min_len=2, max_len=3)
    assert r["train"] == dict(flights=1, sequences=1, frames=2, vehicles=3, singletons=1, gaps={2: 1}, min_len=2,
                              max_len=2)
    assert "test" not in r


def test_manifest(tmp_path):
    seqs, _ = S.find_sequences(FRAMES, split_of=SPLITS)
    m = S.write_manifest(seqs, tmp_path / "data", tmp_path / "out")
    rows = [json.loads(line) for line in m.read_text().splitlines()]
    assert [r["id"] for r in rows] == [s["id"] for s in seqs]
    assert rows[1]["input"] == "lists/0_60_30-00100.lst" and rows[1]["split"] == "val"
    assert rows[1]["daynight"] == "day" and rows[0]["daynight"] == "night"   # T = 0 day, 1 night
    lst = (tmp_path / "out" / rows[1]["input"]).read_text().splitlines()
    assert [Path(p).name for p in lst] == ["0_60_30_0_00100.jpg", "0_60_30_0_00105.jpg", "0_60_30_0_00115.jpg"]


def test_shared_data_sequences(data_dir):
    """On ../shared/data: every sequence is one flight's, of one split, in index order with gaps 1..10; no
    flight has sequences in two splits."""
    seqs, single, split_of = S.load(data_dir)
    assert seqs, "no HIT-UAV sequences in the shared data"
    split_of_flight = {}
    for s in seqs:
        assert {S.flight_of(f.name) for f in s["frames"]} == {s["flight"]}
        assert all(1 <= g <= S.MAX_GAP for g in s["gaps"])
        assert len(s["frames"]) >= S.MIN_LEN
        assert split_of_flight.setdefault(s["flight"], s["split"]) == s["split"]
    for f in single:
        fl = S.flight_of(f.name)
        assert split_of_flight.get(fl, split_of[f.group]) == split_of[f.group]
