# SPDX-License-Identifier: MIT
"""Where the tests find the build, and how they run vd_fir_demo (shared by the end-to-end tests)."""
import os
import subprocess
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def build_dir():
    """$VD_BUILD_DIR, else the directory of $VD_LIB, else build/ of this checkout."""
    if os.environ.get("VD_BUILD_DIR"):
        return Path(os.environ["VD_BUILD_DIR"])
    if os.environ.get("VD_LIB"):
        return Path(os.environ["VD_LIB"]).parent
    return REPO / "build"


def run_demo(demo, *args, check=True, timeout=300):
    """Runs vd_fir_demo with args (any objects, str()-ed); raises with its stderr when check and it fails."""
    p = subprocess.run([str(demo), *map(str, args)], capture_output=True, text=True, timeout=timeout)
    if check and p.returncode != 0:
        raise AssertionError(f"vd_fir_demo failed ({p.returncode}): {p.stderr}")
    return p
