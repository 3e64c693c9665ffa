# SPDX-License-Identifier: MIT
"""The bare-metal firmware example (tools/firmware/) on emulated Arm MPS2 boards:
qemu-system-arm runs it from reset (mps2-an500 = Cortex-M7, mps2-an386 = Cortex-M4)
and its JSON Lines must equal, byte for byte, what vd_fir_demo prints on the host
for the same frames, model and settings. A build whose model array has one byte
inverted must print the vd_status_str() text of VD_ERR_MODEL and exit 2, not fault.

Where ../shared/vendor/cmsis-nn is present (it is in CI) both boards' builds have the CMSIS-NN back end
(CMake VD_CNN_CMSIS, on by default for Cortex-M with the DSP extension), so the byte-for-byte check covers
it; vd_fw_cnn_layers.elf then compares every output row of every weighted layer of the model, portable
kernels and CMSIS-NN, with the network's own tensors on the board.

Skipped only when qemu-system-arm is absent (tools/setup.sh installs it). The
firmware builds into <repo>/build-fw-m7, build-fw-m4 (-Os) and build-fw-m7-release (-O3) (~30 s each the
first time; $VD_FW_BUILD_PREFIX changes build-fw)."""
import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest
from buildpaths import build_dir

# This checkout (vdtools may be installed from another one).
REPO = Path(__file__).resolve().parents[2]

# Build directories <repo>/<prefix>-m7, -m4 ($VD_FW_BUILD_PREFIX, default build-fw: a run beside another
# one in the same checkout can take its own).
PREFIX = os.environ.get("VD_FW_BUILD_PREFIX", "build-fw")
BOARDS = {  # toolchain file -> QEMU machine and CPU
    "cortex-m7": ("mps2-an500", "cortex-m7", f"{PREFIX}-m7"),
    "cortex-m4": ("mps2-an386", "cortex-m4", f"{PREFIX}-m4"),
}
QEMU_TIMEOUT = 120  # seconds; one run takes about 1 s


@pytest.fixture(scope="module")
def qemu():
    exe = shutil.which("qemu-system-arm")
    if exe is None:
        pytest.skip("qemu-system-arm not found: the firmware test needs it (Debian qemu-system-arm, tools/setup.sh)")
    return exe


# (toolchain, build type) of the firmware checks: both boards at -Os (CMSIS-NN's own kernels), and the
# Cortex-M7 at -O3, where the back end runs vd's DSP kernels with their prepared areas and the streamed
# executor's taller bands (docs/architecture.md): a different code path to the same bytes.
BUILDS = [("cortex-m4", "MinSizeRel"), ("cortex-m7", "MinSizeRel"), ("cortex-m7", "Release")]


def build_firmware(toolchain, build_type="MinSizeRel"):
    bdir = REPO / (BOARDS[toolchain][2] + ("" if build_type == "MinSizeRel" else "-" + build_type.lower()))
    subprocess.run(["cmake", "-S", str(REPO / "tools" / "firmware"), "-B", str(bdir), "-G", "Ninja",
                    f"-DCMAKE_TOOLCHAIN_FILE={REPO / 'tools' / 'toolchains' / (toolchain + '.cmake')}",
                    f"-DCMAKE_BUILD_TYPE={build_type}"], check=True, capture_output=True, text=True)
    subprocess.run(["cmake", "--build", str(bdir), "-j", "2"], check=True, capture_output=True, text=True)
    return bdir


def run_qemu(qemu_exe, toolchain, elf, icount=False):
    machine, cpu, _ = BOARDS[toolchain]
    cmd = [qemu_exe, "-M", machine, "-cpu", cpu, "-nographic", "-semihosting", "-kernel", str(elf)]
    if icount:
        cmd[1:1] = ["-icount", "shift=0"]
    # QEMU writes the semihosting console to its stderr.
    return subprocess.run(cmd, capture_output=True, text=True, timeout=QEMU_TIMEOUT, stdin=subprocess.DEVNULL)


@pytest.mark.parametrize("toolchain,build_type", BUILDS)
def test_firmware_matches_demo(qemu, toolchain, build_type, tmp_path):
    demo = build_dir() / "tools" / "vd_fir_demo"
    if not demo.is_file():
        pytest.skip(f"vd_fir_demo not built at {demo} (cmake --build build); set VD_BUILD_DIR")
    bdir = build_firmware(toolchain, build_type)
    r = run_qemu(qemu, toolchain, bdir / "vd_fw.elf")
    assert r.returncode == 0, r.stderr[-2000:]
    fw_lines = [ln for ln in r.stderr.splitlines(keepends=True) if not ln.startswith("#")]
    meas = dict(re.findall(r"(\w+) (\d+)", "".join(ln for ln in r.stderr.splitlines() if ln.startswith("# vd_fw workspace"))))

    out = tmp_path / "demo.jsonl"
    subprocess.run([str(demo), "--input", str(bdir / "frames"), "--cnn-model", str(REPO / "models" / "vd_cnn_compact.vdm"),
                    "--cnn-flip", "off", "--json", str(out), "--quiet"], check=True, capture_output=True, text=True)
    host = out.read_text()
    assert "".join(fw_lines) == host
    # One line per frame (three by default), with vehicles: not two empty outputs compared.
    assert len(fw_lines) == len(list((bdir / "frames").glob("*.pgm"))) >= 1
    assert sum(ln.count('"box"') for ln in fw_lines) > 0
    # The workspace fits its static buffer, the stack its 16 KiB with room to spare.
    assert int(meas["workspace_bytes"]) <= int(meas["workspace_reserved"])
    assert 0 < int(meas["stack_used"]) < int(meas["stack_size"]) // 2


CMSIS_NN = REPO.parent / "shared" / "vendor" / "cmsis-nn"


def cmsis_on(bdir):
    """Whether the firmware build in bdir compiled the CMSIS-NN back end (its CMake cache)."""
    return "VD_CNN_CMSIS:BOOL=ON" in (bdir / "CMakeCache.txt").read_text()


@pytest.mark.parametrize("toolchain,build_type", BUILDS)
def test_firmware_cnn_layers_bit_exact(qemu, toolchain, build_type):
    bdir = build_firmware(toolchain, build_type)
    # The back end is on wherever CMSIS-NN is at hand, so the JSON check above covers it too.
    assert cmsis_on(bdir) == (CMSIS_NN / "Include" / "arm_nnfunctions.h").is_file()
    r = run_qemu(qemu, toolchain, bdir / "vd_fw_cnn_layers.elf")
    assert r.returncode == 0, r.stderr[-2000:]
    layers = [dict(re.findall(r"(\w+) (\d+)", ln)) for ln in r.stderr.splitlines() if ln.startswith("# vd_fw_layer ")]
    summary = dict(re.findall(r"(\w+) (\d+)", next(ln for ln in r.stderr.splitlines() if ln.startswith("# vd_fw_layers"))))
    assert len(layers) >= 10 and all(d["bad_rows"] == "0" for d in layers)
    assert summary["cmsis"] == ("1" if cmsis_on(bdir) else "0") and summary["bad_rows"] == "0"


def test_firmware_corrupted_model(qemu):
    bdir = build_firmware("cortex-m7")
    r = run_qemu(qemu, "cortex-m7", bdir / "vd_fw_badmodel.elf")
    # vd_status_str(VD_ERR_MODEL) is "invalid model" (lib/src/core/status.c); exit 2 = reported error, 3 = fault.
    assert r.returncode == 2, r.stderr[-2000:]
    assert r.stderr == "vd_fw: vd_cnn_load: invalid model\n"
