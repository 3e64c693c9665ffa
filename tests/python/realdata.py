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
