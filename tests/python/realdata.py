# SPDX-License-Identifier: MIT
"""Paths of the real thermal frames in ../shared/data, shared by the oracle tests."""
import pytest


def frame_paths(data_dir):
    """(MSRS PNG paths, HIT-UAV JPEG paths), each sorted; skips the test when either set is missing."""
    msrs = sorted((data_dir / "msrs" / "images").glob("*.png"))
    uav = sorted((data_dir / "hit-uav" / "frames" / "images").glob("*.jpg"))
    if not msrs or not uav:
        pytest.skip(f"MSRS or HIT-UAV frames missing under {data_dir}")
    return msrs, uav


def frames_in_test_split(data_dir):
    """The annotated real frames of the test split (vdtools.data.dataset: stable, group-wise split), in the
    data set's order; skips the test when there are none."""
    from vdtools.data import dataset as D
    frames = D.all_frames(data_dir, synth=False)
    split = D.assign_splits(frames)
    out = [f for f in frames if split[f.group] == "test"]
    if not out:
        pytest.skip(f"no test-split frames under {data_dir}")
    return out
