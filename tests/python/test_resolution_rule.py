# SPDX-License-Identifier: MIT
"""The unlabelled resolution rule's arithmetic (vdtools.adapt.measure: score_q8, mean_box_score, flip_agreement on
given runs; vdtools.adapt.resolution_evidence: the rules compared and their summary), on hand-worked inputs.
The demo's figures against these functions on real frames: test_demo_autores.py."""
import pytest

from vdtools.adapt import measure as M
from vdtools.adapt import resolution_evidence as RE


def test_score_q8_is_the_detectors_rounding():
    # (q15 + 64) >> 7, at most 255 (detector_cnn.c score_q8_of)
    assert M.score_q8(16384 / 32768) == 128          # 16448 >> 7
    assert M.score_q8(16447 / 32768) == 128 and M.score_q8(16448 / 32768) == 129
    assert M.score_q8(1.0) == 255 and M.score_q8(0.0) == 0
    assert M.score_q8(63 / 32768) == 0 and M.score_q8(64 / 32768) == 1


def _runs(a, b):
    """flip_runs' shape: [(family, frame, [(box, score)], ground truth)] for the frames and the mirrors."""
    return [("x", None, d, None) for d in a], [("x", None, d, None) for d in b]


def test_mean_box_score_and_agreement_on_given_runs():
    box = (10, 10, 20, 20)
    far = (100, 100, 20, 20)
    # frame 1: one box 0.5 (q8 128) matched by the mirror's 0.75 (q8 192); a box under the threshold is left out
    # frame 2: the frame's box 1.0 (255) has no partner in the mirror's far box 0.5 (128)
    runs = _runs([[(box, 0.5), (far, 0.1)], [(box, 1.0)]], [[(box, 0.75)], [(far, 0.5)]])
    assert M.mean_box_score(None, None, 0.3, runs=runs) == pytest.approx((128 + 192 + 255 + 128) / (255 * 4))
    assert M.flip_agreement(None, None, 0.3, runs=runs) == pytest.approx(2 * 1 / 4)
    assert M.mean_box_score(None, None, 0.3, runs=_runs([[(box, 0.2)]], [[]])) is None


def _row(ap_h, ap_f, s_h, s_f, a_h, a_f):
    return dict(half=dict(ap=ap_h, score=s_h, agreement=a_h), full=dict(ap=ap_f, score=s_f, agreement=a_f))


def test_rules_choose_and_summarise():
    rows = {
        # agreement says full (0.6 > 0.5), score says half; 1/8: 0.45 + 0.0625 = 0.5125 vs 0.40 + 0.075 = 0.475
        "val a 1 none": _row(0.8, 0.5, 0.45, 0.40, 0.5, 0.6),
        # no box at half: rates 0, so full wins under every rule
        "val a 2 down33": _row(0.1, 0.7, None, 0.40, None, 0.5),
        # score says full by 0.01, agreement half by 0.2: 1/8 gives half (0.55 vs 0.535)
        "val a 3 down50": _row(0.3, 0.6, 0.45, 0.46, 0.8, 0.6),
    }
    assert [RE.choose(v, None) for v in rows.values()] == [True, True, False]
    assert [RE.choose(v, 0.0) for v in rows.values()] == [False, True, True]
    assert [RE.choose(v, 0.125) for v in rows.values()] == [False, True, False]
    s = RE.summary(rows, weights=(None, 0.0, 0.125))
    assert s["flip agreement"]["right"] == 1 and s["flip agreement"]["lost"] == pytest.approx(0.3 + 0.3)
    assert s["mean box score"]["right"] == 3 and s["mean box score"]["lost"] == 0
    assert s["mean box score"]["mean_ap"] == pytest.approx((0.8 + 0.7 + 0.6) / 3)
    assert s["score + 0.125 x agreement"]["per_shift"]["down50"] == [0, 1, pytest.approx(0.3)]
    table = RE.render(rows)
    assert "| mean box score | 3 / 3 | 70.0 | 0 |" in table and "| flip agreement | 1 / 3 |" in table


def test_first_highest_ties_to_the_lowest_index():
    """The choice among ratings (fleet.auto_resolution, resolution_evidence.choose_res): the highest, ties to the
    lower cfg.cnn_res, no box (None) as 0."""
    from vdtools.metrics.evaluate import first_highest
    assert first_highest([0.5, 0.6, 0.6]) == 1
    assert first_highest([None, 0.1, None]) == 1
    assert first_highest([0.0, None, 0.0]) == 0 and first_highest([None, None, None]) == 0
    assert RE.choose_res(dict(_row(0.1, 0.7, None, 0.40, None, 0.5), quarter=dict(ap=0.2, score=0.5, agreement=0.6)),
                         0.25) == "quarter"


def test_demo_weight_is_the_python_weight():
    """The demo's DEMO_AUTORES_AGREE_WEIGHT and the Python rule's weight are one number."""
    import re
    from vdtools.bindings.clib import REPO
    from vdtools.evaluation import fleet
    h = (REPO / "tools" / "demo" / "common" / "flipagree.h").read_text()
    w = float(re.search(r"#define DEMO_AUTORES_AGREE_WEIGHT ([\d.]+)", h).group(1))
    assert w == M.AGREE_WEIGHT == fleet.AUTO_AGREE_WEIGHT


def test_figure_is_written(tmp_path):
    rows = {"val a 1 none": _row(0.8, 0.5, 0.45, 0.40, 0.5, 0.6),
            "val a 2 down33": _row(0.1, 0.7, None, 0.40, None, 0.5),
            "val a 4 none": _row(float("nan"), float("nan"), None, None, None, None)}   # no vehicle: left out
    RE.figure(rows, tmp_path / "f.png")
    assert (tmp_path / "f.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def _frame(group, qsum, m, gts=()):
    """One frame of window_evidence's per-frame measures: boxes for AP (one box per vehicle, score 0.9) and the
    rating's counts (score_q8 sum; matched, boxes)."""
    return dict(name=f"{group}_{qsum}", group=group, dets=[(g[:4], 0.9) for g in gts], gts=list(gts), qsum=qsum,
                m=m)


def test_flip_counts_hand_worked():
    """window_evidence.flip_counts: boxes below the threshold are left out of both the score sum and the
    matching; a frame without a box above it has m None."""
    from vdtools.adapt import window_evidence as WE
    box, far = (0, 0, 10, 10), (50, 50, 10, 10)
    ra = [("f0", None, [(box, 0.8), (far, 0.2)]), ("f1", None, [(far, 0.1)])]
    rb = [("f0", None, [(box, 0.6), (far, 0.5)]), ("f1", None, [])]
    c = WE.flip_counts(ra, rb, 0.4)
    # frame 0: a = [box 0.8], b = [box 0.6, far 0.5]: one match of 3 boxes
    assert c[0]["qsum"] == sum(M.score_q8(s) for s in (0.8, 0.6, 0.5)) and tuple(c[0]["m"]) == (1, 3)
    assert c[1] == dict(qsum=0, m=None)


def test_window_rating_pools_counts_as_the_demo():
    """window_evidence.rating: score_q8 sum / (255 boxes) + 1/4 x 2 matched / boxes over the frames it is given;
    no box anywhere rates 0."""
    from vdtools.adapt import window_evidence as WE
    per = [_frame("a", 255, (1, 2)), _frame("a", 0, None), _frame("a", 51, (0, 2))]
    # boxes 4, score sum 306 -> 0.3; matched 1 of 4 -> agreement 0.5 -> 0.3 + 0.125
    assert WE.rating(per, [0, 1, 2]) == pytest.approx(306 / (255 * 4) + 0.25 * 0.5)
    assert WE.rating(per, [1]) == 0.0
    assert WE.rating(per, [0]) == pytest.approx(255 / (255 * 2) + 0.25 * 1.0)


def test_window_positions_are_the_demos_sample():
    """The 'spread 64' window is fleet.auto_sample (the demo's demo_autores_sample); 'first 32' the rule before."""
    from vdtools.adapt import window_evidence as WE
    from vdtools.evaluation import fleet
    w = WE.windows(200)
    assert w["first 32"] == list(range(32)) and w["all"] == list(range(200))
    assert w["spread 64"] == fleet.auto_sample(200) and w["spread 16"][:2] == [6, 18]   # 200 // 32, 600 // 32
    assert WE.windows(20)["spread 64"] == list(range(20)) == WE.windows(20)["first 32"]


def test_window_summary_hand_worked():
    """A two-scene recording whose first scene rates full higher and whose second (and whole) rates half higher:
    the first 32 frames choose wrong and lose the AP difference; spread and all choose right."""
    from vdtools.adapt import window_evidence as WE
    rows = [dict(kind="multi-scene", shift="none", family="hit", groups=["a", "b"], frames=64, ap=[0.8, 0.5],
                 rating={"first 32": [0.60, 0.65], "spread 64": [0.62, 0.58], "all": [0.62, 0.58]}),
            dict(kind="multi-scene", shift="down50", family="hit", groups=["a", "b"], frames=20, ap=[0.3, 0.6],
                 rating={"first 32": [0.5, 0.6], "spread 64": [0.5, 0.6], "all": [0.5, 0.6]})]
    s = WE.summary(rows)["multi-scene"]["hit"]
    assert s["first 32"] == dict(right=1, n=2, lost=pytest.approx(30.0))
    assert s["spread 64"] == s["all"] == dict(right=2, n=2, lost=0.0)
    rep = dict(split="val", summary=WE.summary(rows), phase_loss={str(w): 0.0 for w in WE.SPREAD})
    table = WE.render([rep])
    assert "| val | multi-scene | hit | 1 / 2 (30) | 2 / 2 (0) | 2 / 2 (0) |" in table and "spread 96" in table
    # fewer than 16 frames measured: half whatever the ratings say
    rows[1]["frames"] = 15
    assert WE.summary(rows)["multi-scene"]["hit"]["all"] == dict(right=1, n=2, lost=pytest.approx(30.0))


def test_window_recordings_and_scores_on_built_measures():
    """recordings: scene groups of >= 16 frames, the whole split, and multi-scene sets of >= 40 frames (the same
    draws for every change); score: AP@0.5 over all the recording's frames at each resolution."""
    from vdtools.adapt import window_evidence as WE
    box = (0.0, 0.0, 10.0, 10.0, True, False)   # evaluate.match_flags' ground truth: x, y, w, h, vehicle, ignore
    half = [_frame(g, 100, (1, 2), [box]) for g in ("a",) * 20 + ("b",) * 30 + ("c",) * 10]
    full = [dict(f, dets=[]) for f in half]   # full finds nothing: AP 0
    res = {("none", "hit", "half"): half, ("none", "hit", "full"): full}
    recs = WE.recordings(res)
    kinds = [(k, g) for k, _, _, g, _ in recs]
    assert ("scene", ["a"]) in kinds and ("scene", ["b"]) in kinds and ("scene", ["c"]) not in kinds
    assert ("whole split", ["a", "b", "c"]) in kinds
    multi = [(g, len(i)) for k, _, _, g, i in recs if k == "multi-scene"]
    assert sorted(multi) == [(["a", "b"], 50), (["a", "b", "c"], 60), (["b", "c"], 40)]   # a + c: 30 < 40
    rows = WE.score(res, recs)
    assert all(r["ap"] == [pytest.approx(1.0), 0.0] for r in rows)


def test_polarity_rule_hand_worked():
    """--cnn-polarity auto (flipagree.c demo_autores_decide; fleet.polarity_choice): the other polarity only when its
    best rating over the resolutions measured beats the best of the frames as they are by more than the margin,
    and only on at least 16 frames; no box (None) rates 0. The demo's margin is the Python one."""
    import re
    from vdtools.bindings.clib import REPO
    from vdtools.evaluation import fleet
    h = (REPO / "tools" / "demo" / "common" / "flipagree.h").read_text()
    m = float(re.search(r"#define DEMO_AUTORES_INVERT_MARGIN ([\d.]+)", h).group(1))
    assert m == fleet.AUTO_INVERT_MARGIN > 0
    # best as is 0.60 (full), best inverted 0.60 + m + 0.001 (quarter): inverted; by exactly m: as is
    assert fleet.polarity_choice([0.5, 0.6, None], [0.1, 0.2, 0.601 + m], 16)
    assert not fleet.polarity_choice([0.5, 0.6, None], [0.1, 0.2, 0.6 + m], 16)
    assert not fleet.polarity_choice([0.5, 0.6, None], [0.9, 0.9, 0.9], 15)   # too few frames
    assert fleet.polarity_choice([None, None, None], [0.3], 16) and not fleet.polarity_choice([None], [None], 64)


def test_polarity_evidence_margin_hand_worked():
    """polarity_evidence.margins: max over the resolutions as they are - max inverted, and the configuration of
    the highest rating of all six (ties to as is, then to the lower cfg.cnn_res)."""
    from vdtools.adapt import polarity_evidence as PE
    r = lambda *v: {k: dict(rating=x) for k, x in zip(("half", "full", "quarter"), v)}
    m, c = PE.margins(dict(as_is=r(0.5, 0.7, 0.0), inverted=r(0.6, 0.2, 0.65)))
    assert m == pytest.approx(0.05) and c == ("full", "as is")
    m, c = PE.margins(dict(as_is=r(0.5, 0.6, 0.0), inverted=r(0.6, 0.2, 0.65)))
    assert m == pytest.approx(-0.05) and c == ("quarter", "inverted")
    assert PE.margins(dict(as_is=r(0.6, 0.6, 0.6), inverted=r(0.6, 0.6, 0.6)))[1] == ("half", "as is")


def test_polarity_figure_and_table(tmp_path):
    """polarity_evidence --render: the table per camera change (recordings rated higher inverted, the smallest
    margin) and the figure, on hand-made rows."""
    from vdtools.adapt import polarity_evidence as PE
    rows = {"val hit a none": dict(margin=0.05, vehicles=3, choice=["half", "as is"]),
            "val hit b none": dict(margin=-0.01, vehicles=2, choice=["full", "inverted"]),
            "train msrs c down33": dict(margin=0.2, vehicles=0, choice=["full", "as is"])}
    table = PE.render_recordings(rows)
    assert "| none | 2 | 1 | -0.010 | full 1, half 1 |" in table and "| down33 | 1 | 0 | +0.200 | full 1 |" in table
    PE.figure(rows, tmp_path / "p.png", 0.025)
    assert (tmp_path / "p.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
