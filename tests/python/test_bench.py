# SPDX-License-Identifier: MIT
"""vdtools.evaluation.bench: where results go. A run must not overwrite the committed record unless asked."""
from pathlib import Path

from vdtools.evaluation import bench


def test_a_run_writes_out_unless_the_record_is_named():
    assert bench.result_path(None, markdown=False) == Path("out") / "bench.json"
    assert bench.result_path("../docs/results/bench.json", markdown=False) == Path("../docs/results/bench.json")


def test_markdown_reads_the_committed_record(capsys):
    assert bench.result_path(None, markdown=True) == bench.RECORD
    assert bench.RECORD.is_file()
    assert bench.main(["--markdown"]) == 0
    out = capsys.readouterr().out
    assert "|" in out and "msrs-night" in out
