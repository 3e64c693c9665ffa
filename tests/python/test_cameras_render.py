# SPDX-License-Identifier: MIT
"""vdtools.evaluation.cameras.render on made-up reports (no data, no model): the output's AP is shown when a
report has it and left out for reports written before it existed."""
from vdtools.evaluation import cameras


def test_render_shows_the_output_ap_when_the_report_has_it():
    new = {"shifts": {s: {"hit": dict(ap=0.872, ap_out=0.803, tp_rate=0.817, fp_rate=0.161),
                          "msrs": dict(ap=0.555, ap_out=0.413, tp_rate=0.441, fp_rate=0.25)}
                      for s in cameras.SHIFTS}}
    old = {"shifts": {s: {"hit": dict(ap=0.5, tp_rate=0.5, fp_rate=0.1)} for s in cameras.SHIFTS}}
    lines = cameras.render({"new": new, "old": old}).splitlines()
    assert lines[0].startswith("| change | new: drone AP")
    assert len(lines) == 2 + len(cameras.SHIFTS)
    first = lines[2].split(" | ")
    assert first[0] == "| " + cameras.SHIFTS[0]
    assert first[1] == "87.2 (output 80.3), 82 / 16 %" and first[2] == "55.5 (output 41.3), 44 / 25 %"
    assert first[3] == "50.0, 50 / 10 %" and first[4].rstrip(" |") == "–"
