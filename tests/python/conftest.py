# SPDX-License-Identifier: MIT
"""Shared fixtures: the C library through ctypes and the real data sets.
Tests that need ../shared/data or the shared build skip with a clear message."""
import pytest

from vdtools import clib


@pytest.fixture(scope="session")
def vdlib():
    try:
        return clib.load()
    except OSError as e:
        pytest.skip(f"shared build not found at {clib.lib_path()} ({e}); build with cmake first")


@pytest.fixture(scope="session")
def data_dir():
    if not clib.DATA_DIR.is_dir():
        pytest.skip(f"real thermal data not found at {clib.DATA_DIR} (../shared/data beside the project)")
    return clib.DATA_DIR
