# SPDX-License-Identifier: MIT
"""Shared fixtures: the C library through ctypes and the real data sets.
Tests that need ../shared/data or the shared build skip with a clear message."""
import pytest

from vdtools.bindings import clib

from buildpaths import build_dir


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


@pytest.fixture(scope="session")
def demo():
    """The vd_fir_demo of the build under test."""
    exe = build_dir() / "tools" / "vd_fir_demo"
    if not exe.is_file():
        pytest.skip(f"vd_fir_demo not built at {exe} (cmake --build build); set VD_BUILD_DIR")
    return exe
