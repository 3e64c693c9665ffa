# SPDX-License-Identifier: MIT
"""Embedded budgets of vd: code/data size per module and worst-case stack per
public function for a Cortex-M7 -Os build, soft-float and heap checks for the
Cortex-M0+ build, the detector workspace for 640x512 (total and per part) and,
with --runs or --write, the distribution of labelling run counts on the real
frames of ../shared/data (what the detector's run budget max_runs must hold).

    python3 -m vdtools.generators.embedded_report            # print the report
    python3 -m vdtools.generators.embedded_report --write    # also measure runs, write docs/embedded.md
    python3 -m vdtools.generators.embedded_report --check    # exit 1 if a budget is broken

The workspace figures come from a host build of the shared library in
build-report-host (or $VD_LIB when set), through tools/vdtools. Build directories are
<repo>/build-report-* ($VD_REPORT_BUILD_PREFIX replaces build-report, for a run beside another).

The Cortex-M0+ size is the whole library's (every source, -Os) as `size` counts it (.text + .rodata of
every object), and what an M0+ image links of it (--gc-sections) for a few sets of entry points. With
--firmware (or --write) the firmware of tools/firmware runs on both emulated boards, -Os and -O3, with
vd's portable CNN kernels and with the CMSIS-NN back end (issue 36), and vd_fw_cnn_layers.elf gives the
instructions of every weighted layer with both.

Stack depth comes from GCC's -fstack-usage / -fcallgraph-info=su: each
function's own frame plus the deepest path through its callees (lib/ has no
recursion, so the graph is a DAG; a cycle is reported). Indirect calls that
lib/ makes to its own code (vd_temporal_update -> the detector's recovery
probe, the window walk -> its visitors, the streamed CNN's input rows -> the
detector's row maker) are resolved through INDIRECT; the others are user callbacks (the
detector's clock_us, a probe passed to vd_temporal_update directly), listed in
the report and counted as 0 bytes.
"""
import argparse
import os
import re
import shutil
import subprocess
import sys
from collections import defaultdict
from pathlib import Path

REPO = Path(__file__).resolve().parents[3]
PREFIX = os.environ.get("VD_REPORT_BUILD_PREFIX", "build-report")
CMSIS_NN = REPO.parent / "shared" / "vendor" / "cmsis-nn"
M0_TEXT_BUDGET = 64 * 1024   # issue 36: the whole library on a Cortex-M0+, -Os, .text + .rodata
STACK_BUDGET = {"vd_detector_run": 2048}
# Indirect call sites resolved to the lib/ functions they reach (suffix of the .ci node title).
# A key names a global function, or "file.c:function" for a static one.
INDIRECT = {"vd_temporal_update": ["vd__detector_probe"], "temporal.c:unmatched_tracks": ["vd__detector_probe"],
            "temporal.c:recover_search": ["vd__detector_probe"], "windows.c:walk": [":collect", ":rank_visit"],
            "windows.c:rank_visit": [":window_visit"], "input.c:src_row": [":cnn_row"]}
WORKSPACE_GOAL = 256 * 1024
DATA = REPO.parent / "shared" / "data"
SOFT_FLOAT = re.compile(r"^__aeabi_[fd]|^__(add|sub|mul|div|fix|float|extend|trunc)\w*[sd]f")
HEAP = re.compile(r"^(malloc|calloc|realloc|free|aligned_alloc|posix_memalign)$")


def run(cmd, **kw):
    return subprocess.run(cmd, check=True, capture_output=True, text=True, **kw).stdout


def build(name, toolchain, extra_flags="", cmake_args=()):
    bdir = REPO / f"{PREFIX}-{name}"
    # CMAKE_C_FLAGS adds to the toolchain file's CMAKE_C_FLAGS_INIT only on a first configure: pass both.
    init = re.search(r'CMAKE_C_FLAGS_INIT "([^"]*)"',
                     (REPO / "tools" / "toolchains" / (toolchain + ".cmake")).read_text())[1]
    run(["cmake", "-S", str(REPO), "-B", str(bdir), "-G", "Ninja",
         f"-DCMAKE_TOOLCHAIN_FILE={REPO / 'tools' / 'toolchains' / (toolchain + '.cmake')}",
         "-DCMAKE_BUILD_TYPE=MinSizeRel", f"-DCMAKE_C_FLAGS={init} {extra_flags}".rstrip(), *cmake_args])
    run(["cmake", "--build", str(bdir), "--target", "vd", "--clean-first"])
    return bdir


def size_text(bdir):
    """(size's text = .text + .rodata, .text) bytes of every object of libvd.a in bdir."""
    tot = [0, 0]
    for obj in objects(bdir):
        t, r, _d, _b = section_sizes(obj)
        tot[0] += t + r
        tot[1] += t
    return tuple(tot)


# Entry points an M0+ image keeps, for the linked sizes (None: every public function).
FW_CALLS = ["vd_cnn_load", "vd_detector_cfg_default", "vd_detector_workspace_size", "vd_detector_init",
            "vd_detector_run", "vd_detector_last_stats", "vd_detection_source_name", "vd_detection_state_name",
            "vd_status_str"]
M0_LINKS = [("every public function", None),
            ("tools/firmware's calls (detector, CNN source)", FW_CALLS),
            ("the CNN alone (`vd_cnn_*`)", "vd_cnn_")]


def linked_size(bdir, keep):
    """(.text, .rodata) bytes of libvd.a in bdir that an M0+ image linking the functions `keep` (a list, a
    name prefix, or None for every public function) carries: -Os objects, --gc-sections, from its map."""
    lib = bdir / "libvd.a"
    defined = {ln.split()[-1] for ln in run(["arm-none-eabi-nm", "-g", "--defined-only", str(lib)]).splitlines()
               if " T " in ln}
    if keep is None:
        names = sorted(public_functions() & defined)
    elif isinstance(keep, str):
        names = sorted(n for n in public_functions() & defined if n.startswith(keep))
    else:
        names = sorted(set(keep) & defined)
    src = bdir / "m0_keep.c"
    src.write_text("".join(f"extern void {n}(void);\n" for n in names)
                   + "void (*const vd_keep[])(void) = {" + ", ".join(names) + "};\n"
                   + "void vd_keep_entry(void);\nvoid vd_keep_entry(void)\n{\n    for (;;) {\n    }\n}\n")
    cpu = ["-mcpu=cortex-m0plus", "-mthumb", "-mfloat-abi=soft"]
    run(["arm-none-eabi-gcc", *cpu, "-Os", "-ffunction-sections", "-fdata-sections", "-c", str(src),
         "-o", str(bdir / "m0_keep.o")])
    mapf = bdir / "m0_keep.map"
    run(["arm-none-eabi-gcc", *cpu, "-nostartfiles", "--specs=nano.specs", "-Wl,--gc-sections",
         "-Wl,-e,vd_keep_entry", "-Wl,-u,vd_keep", f"-Wl,-Map={mapf}", str(bdir / "m0_keep.o"), str(lib),
         "-o", str(bdir / "m0_keep.elf")])
    memory_map = mapf.read_text().split("Linker script and memory map", 1)[1]
    tot = {"text": 0, "rodata": 0}
    for m in re.finditer(r"^ \.(text|rodata)\S*\s*(?:\n\s+)?0x[0-9a-f]+\s+0x([0-9a-f]+)\s+(\S+)", memory_map, re.M):
        if "libvd.a(" in m.group(3):
            tot[m.group(1)] += int(m.group(2), 16)
    return tot["text"], tot["rodata"]


def objects(bdir):
    return sorted((bdir / "CMakeFiles" / "vd_objects.dir").rglob("*.obj")) + \
        sorted((bdir / "CMakeFiles" / "vd_objects.dir").rglob("*.o"))


def module_of(obj):
    return obj.name.split(".")[0]


def section_sizes(obj):
    """(.text, .rodata, .data, .bss) bytes of one object, from `size -A`."""
    out = run(["arm-none-eabi-size", "-A", str(obj)])
    sizes = defaultdict(int)
    for line in out.splitlines():
        parts = line.split()
        if len(parts) < 2 or not parts[1].isdigit():
            continue
        sec, n = parts[0], int(parts[1])
        for key in (".text", ".rodata", ".data", ".bss"):
            if sec == key or sec.startswith(key + "."):
                sizes[key] += n
    return sizes[".text"], sizes[".rodata"], sizes[".data"], sizes[".bss"]


def parse_callgraph(bdir):
    """Own frame size and callees per function from the .ci (VCG) files."""
    frame, edges, dynamic = {}, defaultdict(set), set()
    for ci in (bdir / "CMakeFiles" / "vd_objects.dir").rglob("*.ci"):
        text = ci.read_text()
        for m in re.finditer(r'node: \{ title: "([^"]+)" label: "([^"]*)"', text):
            title, label = m.group(1), m.group(2)
            sm = re.search(r"(\d+) bytes \((static|dynamic[^)]*)\)", label)
            if sm:
                frame[title] = int(sm.group(1))
                if sm.group(2) != "static":
                    dynamic.add(title)
            else:
                frame.setdefault(title, 0)  # external (libc such as memset/memcpy)
        for m in re.finditer(r'edge: \{ sourcename: "([^"]+)" targetname: "([^"]+)"', text):
            edges[m.group(1)].add(m.group(2))
    # Resolve the known indirect calls; keep the others as "__indirect_call" (user callbacks).
    for key, suffixes in INDIRECT.items():
        for caller in [c for c in list(edges) if c == key or c.endswith("/" + key)]:
            if "__indirect_call" not in edges[caller]:
                continue
            targets = [t for t in frame for suf in suffixes if t.endswith(suf)]
            if targets:
                edges[caller].discard("__indirect_call")
                edges[caller].update(targets)
    return frame, edges, dynamic


def deepest_path(fn, frame, edges):
    """The call chain that gives worst_stack(fn): [(function, own frame)]."""
    path, node = [], fn
    for _ in range(len(frame) + 1):  # a DAG: at most every node once
        path.append((node.split(":")[-1], frame.get(node, 0)))
        kids = sorted(edges.get(node, ()))  # sorted: equal depths give the same chain in every run
        if not kids:
            break
        node = max(kids, key=lambda c: worst_stack(c, frame, edges))
    return path


def worst_stack(fn, frame, edges):
    """Deepest frame sum from fn down; raises on a cycle (iterative DFS, memoised)."""
    memo, state = {}, {}
    stack = [(fn, False)]
    while stack:
        node, done = stack.pop()
        if done:
            best = max((memo[c] for c in edges.get(node, ())), default=0)
            memo[node] = frame.get(node, 0) + best
            state[node] = 2
            continue
        if state.get(node) == 2:
            continue
        if state.get(node) == 1:
            raise RuntimeError(f"call cycle through {node}")
        state[node] = 1
        stack.append((node, True))
        for c in edges.get(node, ()):
            if state.get(c) != 2:
                if state.get(c) == 1:
                    raise RuntimeError(f"call cycle through {c}")
                stack.append((c, False))
    return memo[fn]


def public_functions():
    names = set()
    for h in (REPO / "lib" / "include" / "vd").glob("*.h"):
        for m in re.finditer(r"^\w[\w\s\*]*?\b(vd_\w+)\s*\(", h.read_text(), re.M):
            names.add(m.group(1))
    return names


def host_library():
    """Path of a host libvd.so: $VD_LIB, else a fresh build in build-report-host."""
    import os
    if os.environ.get("VD_LIB"):
        return Path(os.environ["VD_LIB"])
    bdir = REPO / "build-report-host"
    run(["cmake", "-S", str(REPO), "-B", str(bdir), "-G", "Ninja", "-DCMAKE_BUILD_TYPE=Release",
         "-DVD_BUILD_TESTS=OFF", "-DVD_BUILD_PORT=OFF"])
    run(["cmake", "--build", str(bdir), "--target", "vd_shared", "-j", "2"])
    os.environ["VD_LIB"] = str(bdir / "libvd.so")
    return bdir / "libvd.so"


def _vdtools():
    sys.path.insert(0, str(REPO / "tools"))
    from vdtools.bindings import clib, components, detector, refine  # noqa: E402  (bindings of the C modules)
    return clib, components, detector, refine


def _aligned(n, a=8):
    return (n + a - 1) // a * a


def cnn_configs(path):
    """[(label, vd_detector_cfg_t fields)] the CNN workspace of the model at path is reported for: the
    library's defaults, the fused flip pass, and vd_fir_demo's own settings for that model (the demo's rules
    of tools/demo/common/models.c as fleet.resolve mirrors them: flip pass, temporal analysis on, candidates for
    both passes' top-K, detections the model's top-K)."""
    from vdtools.evaluation import fleet
    demo = fleet.resolve({"cnn-model": str(path)})[0]
    return [("default", {"sources": "cnn"}), ("flip pass", {"sources": "cnn", "cnn_flip": 1}), ("vd_fir_demo", demo)]


def cnn_workspace():
    """[(model, parameters, MACs at 320x256, frame, config, detector workspace bytes)] for the committed CNN
    models (cnn_configs)."""
    rows = []
    try:
        from vdtools.bindings import detector as det
        from vdtools.formats import cnn_vdm as V, cnn_ref as R
        for path in sorted((REPO / "models").glob("vd_cnn*.vdm")):
            desc = V.unpack(path.read_bytes())
            configs = cnn_configs(path)      # resolved once per model: they do not depend on the frame size
            for w, h in ((640, 512), (640, 480)):
                for label, cfg in configs:
                    rows.append((path.stem, R.params(desc), R.macs(desc, 320, 256), f"{w}×{h}", label,
                                 det.workspace_size(w, h, cnn_model=str(path), **cfg)))
        # The shipped pair (cfg.cnn_model2 = vd_cnn2, the demo's default): both networks' parameters and
        # multiply-adds; the demo's budgets are its own for a pair (fleet.resolve({}) = vd_fir_demo's defaults).
        p1, p2 = REPO / "models" / "vd_cnn.vdm", REPO / "models" / "vd_cnn2.vdm"
        if p1.is_file() and p2.is_file():
            from vdtools.evaluation import fleet
            d1, d2 = V.unpack(p1.read_bytes()), V.unpack(p2.read_bytes())
            configs = [("default", {"sources": "cnn"}), ("flip pass", {"sources": "cnn", "cnn_flip": 1}),
                       ("vd_fir_demo", fleet.resolve({})[0])]
            for w, h in ((640, 512), (640, 480)):
                for label, cfg in configs:
                    rows.append(("vd_cnn + vd_cnn2", R.params(d1) + R.params(d2),
                                 R.macs(d1, 320, 256) + R.macs(d2, 320, 256), f"{w}×{h}", label,
                                 det.workspace_size(w, h, cnn_model=str(p1), cnn_model2=str(p2), **cfg)))
    except Exception as e:  # report what is measurable; the page says so
        print(f"note: CNN workspace not measured ({e})", file=sys.stderr)
    return rows


def detector_workspace():
    """(total bytes, [(part, bytes, note)]) of the default detector at 640x512, or (None, [])."""
    try:
        host_library()
        _clib, cc, det, rf = _vdtools()
        total = det.workspace_size(640, 512)
        cfg = det.default_cfg()
        rw, rh = cfg["max_region_w"], cfg["max_region_h"]
        refine = rf.workspace_size(rw, rh)
        tracer = _aligned(rf.contour_workspace_size(rw, rh)) + _aligned(8 * (rw + rh) * 4) + _aligned(64 * 24)
        labelling = cc.workspace_size_runs(640, 512, cfg["max_runs"])
        region = 2 * _aligned(rw * rh) + max(_aligned(refine), tracer)
        fixed = [("components table", _aligned(28 * cfg["max_components"]), f"28 B x {cfg['max_components']}"),
                 ("candidates", _aligned(48 * cfg["max_candidates"]), f"48 B x {cfg['max_candidates']}"),
                 ("histogram", 1024, "256 x 4 B (adaptive threshold)")]
        parts = fixed + [
            ("overlay = max(A, B)", max(labelling, region), "A and B never live at once"),
            ("  A: labelling", labelling,
             f"{cfg['max_runs']} runs x 8 B + row buffers (components.h, no hot mask)"),
            ("  B: region buffers", region,
             f"crop + mask ({rw}x{rh} each) + max(refine {refine}, contour tracer {tracer})")]
        return total, parts
    except Exception as e:  # the report still works without a host build
        print(f"note: detector workspace not measured ({e})", file=sys.stderr)
        return None, []


FW_BOARDS = {"cortex-m7": ("mps2-an500", "Cortex-M7"), "cortex-m4": ("mps2-an386", "Cortex-M4")}
FW_FLASH = (".text", ".vd_model", ".vd_frames", ".ARM.exidx", ".data")
FW_RAM = (".data", ".bss", ".vd_workspace", ".stack")


def qemu_run(qemu, toolchain, elf):
    """stderr (QEMU's semihosting console) of elf on toolchain's board under -icount shift=0: the virtual
    clock advances 1 ns per executed instruction, so SysTick counts instructions (the firmware's
    calibration loop gives the ratio)."""
    machine, _ = FW_BOARDS[toolchain]
    r = subprocess.run([qemu, "-icount", "shift=0", "-M", machine, "-cpu", toolchain, "-nographic", "-semihosting",
                        "-kernel", str(elf)], capture_output=True, text=True, timeout=900, stdin=subprocess.DEVNULL)
    if r.returncode != 0:
        raise RuntimeError(f"{elf.name} exited {r.returncode}: {r.stderr[-500:]}")
    return r.stderr


def firmware(toolchain, build_type, cmsis):
    """Builds tools/firmware for `toolchain` with the CMSIS-NN back end on or off and runs it (and, with the
    back end, vd_fw_cnn_layers.elf) under qemu-system-arm -icount shift=0. Returns a dict of
    measurements, or None without qemu-system-arm (or, for cmsis, without ../shared/vendor/cmsis-nn)."""
    qemu = shutil.which("qemu-system-arm")
    if qemu is None:
        print("note: qemu-system-arm not found: firmware figures not measured", file=sys.stderr)
        return None
    if cmsis and not (CMSIS_NN / "Include" / "arm_nnfunctions.h").is_file():
        print(f"note: no CMSIS-NN at {CMSIS_NN}: CMSIS-NN figures not measured", file=sys.stderr)
        return None
    backend = "cmsis" if cmsis else "portable"
    bdir = REPO / f"{PREFIX}-fw-{toolchain}-{build_type.lower()}-{backend}"
    run(["cmake", "-S", str(REPO / "tools" / "firmware"), "-B", str(bdir), "-G", "Ninja",
         f"-DCMAKE_TOOLCHAIN_FILE={REPO / 'tools' / 'toolchains' / (toolchain + '.cmake')}",
         f"-DCMAKE_BUILD_TYPE={build_type}", f"-DVD_CNN_CMSIS={'ON' if cmsis else 'OFF'}"])
    run(["cmake", "--build", str(bdir), "-j", "2"])
    elf = bdir / "vd_fw.elf"
    machine, _ = FW_BOARDS[toolchain]
    out = qemu_run(qemu, toolchain, elf)
    frames = [(int(c), int(u)) for c, u in re.findall(r"^# vd_fw frame \d+ systick_cycles (\d+) cnn_stage_us (\d+)$",
                                                        out, re.M)]
    cal = re.search(r"^# vd_fw calib_insns (\d+) systick_cycles (\d+)$", out, re.M)
    meas = dict((k, int(v)) for k, v in re.findall(r"(\w+) (\d+)", re.search(r"^# vd_fw workspace.*$", out, re.M)[0]))
    insn_per_tick = int(cal[1]) / int(cal[2])
    layers, layer_sum = [], None
    if cmsis:   # per layer, portable and CMSIS-NN kernels of one binary (the same calibration)
        lo = qemu_run(qemu, toolchain, bdir / "vd_fw_cnn_layers.elf")
        for ln in lo.splitlines():
            d = {k: int(v) for k, v in re.findall(r"(\w+) (\d+)", ln)}
            if ln.startswith("# vd_fw_layer "):
                layers.append(d)
            elif ln.startswith("# vd_fw_layers"):
                layer_sum = d
    sizes = {}
    for line in run(["arm-none-eabi-size", "-A", str(elf)]).splitlines():
        f = line.split()
        if len(f) == 3 and f[0].startswith(".") and f[1].isdigit():
            sizes[f[0]] = int(f[1])
    mapped = (bdir / "vd_fw.map").read_text().splitlines()
    excerpt = []
    for i, line in enumerate(mapped):
        if re.match(r"^\.(vd_model|vd_frames|vd_workspace|stack)\s", line):
            excerpt.append(line.rstrip())
            excerpt += [ln.rstrip() for ln in mapped[i + 1:i + 6] if re.match(r"^ \.vd_\w+\s+0x|^\s+0x\w+\s+__stack", ln)]
    return {"toolchain": toolchain, "build_type": build_type, "machine": machine, "cmsis": cmsis,
            "gcc": run(["arm-none-eabi-gcc", "-dumpversion"]).strip(),
            "lines": [ln for ln in out.splitlines() if not ln.startswith("#")],
            "insns": [round(c * insn_per_tick) for c, _ in frames], "cnn_us": [u for _, u in frames],
            "insn_per_tick": insn_per_tick, "calib": (int(cal[1]), int(cal[2])), "sizes": sizes,
            "flash": sum(sizes.get(s, 0) for s in FW_FLASH), "ram": sum(sizes.get(s, 0) for s in FW_RAM),
            "map": excerpt, "layers": layers, "layer_sum": layer_sum, **meas}


OP_NAMES = {1: "conv 3×3", 2: "depthwise 3×3", 3: "pointwise", 5: "upsample", 6: "concat", 7: "conv 5×5"}
BAR_PER_MAC = 2.0       # issue 36: CNN stage instructions per MAC with CMSIS-NN (M7, Release)
BAR_FRAME_MS = 60.0     # issue 36: estimated frame time on a 480 MHz Cortex-M7
CLOCK_HZ = 480e6
# Instructions per output value of the back end's DSP kernels after the multiply-adds (ReLU layers'
# assembly: LDRD of the 64-bit constant, LDRD of multiplier and shift, SMLAL, ASR, SSAT, STRB; kernels/cmsis.h).
REQ_INSNS = 6
# The CNN stage before the second pass over the DSP kernels (commit ffde6a7, mps2-an500 Release, this report).
PREV_CNN_M, PREV_PER_MAC = 54.7, 3.83
# After the second pass (commit 014761a), before the third.
MID_CNN_M, MID_PER_MAC = 32.0, 2.24


def _cnn_insns(d):
    """The CNN stage's instructions per frame at camera rate: the largest over the frames after the first
    (the first frame's stage also sizes the streamed rings, which VD_CNN_REUSE_PLAN keeps for the next
    ones; otherwise the stage does not vary with the frame)."""
    later = d["cnn_us"][1:] or d["cnn_us"]
    return max(later) * 1000


def _first_extra(fw):
    """'x.x M instructions' (or a range): the first frame's CNN stage above the later frames' largest, per
    build of fw."""
    extra = [(d["cnn_us"][0] - max(d["cnn_us"][1:])) / 1e3 for d in fw if len(d["cnn_us"]) > 1]
    if not extra or max(abs(e) for e in extra) < 0.05:
        return "no"   # (within 0.05 M)
    lo, hi = min(extra), max(extra)
    return f"{lo:.1f} M instructions" if abs(hi - lo) < 0.05 else f"{lo:.1f}–{hi:.1f} M instructions"


def firmware_section(fw, cnn_rows, problems):
    """Markdown lines of the firmware measurements (list of firmware() dicts, M7 -Os portable first);
    appends broken budgets to problems."""
    m7 = fw[0]
    sz = m7["sizes"]
    nframes = len(m7["insns"])
    macs = next((d["layer_sum"]["macs"] for d in fw if d["layer_sum"]), None) or \
        next((m for name, _, m, _frame, _cfg, _ in cnn_rows if name == "vd_cnn_compact"), None)
    lines = ["", "## Firmware on an emulated board (tools/firmware, issues 16 and 36)", "",
             "The firmware example runs from reset on QEMU's Arm MPS2 boards (`mps2-an500` Cortex-M7,",
             "`mps2-an386` Cortex-M4): `models/vd_cnn_compact.vdm` as a `const` array in flash, the first",
             f"{nframes} frames of the bundled HIT-UAV clip (640×512, 8-bit) in flash, `vd_detector_run` with",
             "vd_fir_demo's settings, detections over semihosting (`tests/python/test_firmware.py` checks them",
             "byte for byte against vd_fir_demo, with the CMSIS-NN back end on). Measured by",
             "`python3 -m vdtools.generators.embedded_report --firmware` (arm-none-eabi-gcc " + m7["gcc"] + ", newlib-nano for",
             "`memcpy`/`memset`/`memmove` only), each board and build with vd's portable CNN kernels",
             "(`-DVD_CNN_CMSIS=OFF`) and with the CMSIS-NN back end (`-DVD_CNN_CMSIS=ON`, the default for",
             "Cortex-M4/M7 where `../shared/vendor/cmsis-nn` is; docs/architecture.md, \"CMSIS-NN CNN kernels\").", "",
             "| board | build | CNN kernels | flash (B) | RAM (B) | stack high-water (B) | instructions per frame "
             "| of which CNN stage | per MAC | CNN stage on a 480 MHz M7 (estimate) |",
             "|---|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    for d in fw:
        ins = d["insns"]
        cnn = _cnn_insns(d)
        per_mac = f"{cnn / macs:.2f}" if macs else "–"
        est = f"{cnn / CLOCK_HZ * 1e3:.0f} ms" if d["toolchain"] == "cortex-m7" else "–"
        lines.append(f"| `{d['machine']}` ({FW_BOARDS[d['toolchain']][1]}) | {d['build_type']} | "
                     f"{'CMSIS-NN' if d['cmsis'] else 'portable'} | {d['flash']} | "
                     f"{d['ram']} | {d['stack_used']} of {d['stack_size']} | "
                     f"{min(ins) / 1e6:.1f} M – {max(ins) / 1e6:.1f} M | "
                     f"{min(d['cnn_us']) / 1e3:.1f} M – {max(d['cnn_us']) / 1e3:.1f} M | {per_mac} | {est} |")
    lines += ["",
              f"Flash = {' + '.join(s for s in FW_FLASH)}: code and constants {sz['.text']} B (libvd and the",
              f"firmware, `{m7['machine']}` {m7['build_type']} {'CMSIS-NN' if m7['cmsis'] else 'portable'}), model "
              f"{sz['.vd_model']} B, frames {sz['.vd_frames']} B (test input only: a camera",
              f"delivers frames into RAM). RAM = {' + '.join(s for s in FW_RAM)}: the detector workspace",
              f"`vd_detector_workspace_size()` = {m7['workspace_bytes']} B in a {m7['workspace_reserved']} B static",
              f"buffer, {sz['.bss']} B of `.bss` (detector object, loaded model, detection array), a",
              f"{m7['stack_size']} B stack; the CMSIS-NN back end works in the portable kernels' scratch, so",
              "the workspace is the same with it. MinSizeRel is `-Os`; Release is `-O3` (and `lib/src/models/cnn/`",
              "and the CMSIS-NN files at `-O3`, VD_CNN_O3). \"Per MAC\" is the CNN stage's instructions over the",
              f"network's {macs / 1e6:.1f} M multiply-adds (320×256 input); the estimate divides instructions by"
              if macs else "network's multiply-adds; the estimate divides instructions by",
              "480 MHz (one instruction per cycle: no pipeline, cache or wait-state effects, no dual issue).", "",
              "Stack high-water mark: the reset handler paints the stack with 0xA5A5A5A5 and the firmware",
              "finds the deepest overwritten word after the last frame (the whole run: model load,",
              "detector init, every frame, the output formatting, the SysTick interrupt).", "",
              "Where the linker put the workspace and the model (excerpt of `vd_fw.map`, Cortex-M7 MinSizeRel;",
              "flash = SSRAM1 at 0x00000000, RAM = SSRAM2/3 at 0x20000000, `tools/firmware/mps2.ld`):", "",
              "```"] + m7["map"] + ["```", "",
              "**Instruction counts, not cycles.** Under `qemu-system-arm -icount shift=0` the virtual clock",
              "advances 1 ns per executed instruction; SysTick counts that clock (25 MHz), and a calibration loop",
              f"of {m7['calib'][0]} instructions gives {m7['calib'][1]} SysTick counts, so one count is",
              f"{m7['insn_per_tick']:.2f} instructions (resolution ±40 instructions). These are instructions an",
              "emulator executed: no pipeline, caches, wait states or dual issue; a real part's cycles differ.",
              "\"Of which CNN stage\" is `vd_detector_stats_t.time_us[VD_DETECTOR_STAGE_CNN]` through the detector's",
              "clock callback (1 µs = 1 000 instructions here): the network input rows, the network, the",
              "decoding; ranges are over the frames; the rest of `vd_detector_run` (merge, overlap",
              "suppression, temporal analysis) varies with the detections. The streamed rings' sizing (the row",
              "schedule's walk) is done at `vd_detector_init` for the largest frame and kept from frame to frame",
              "(`VD_CNN_REUSE_PLAN`): \"per MAC\" and the estimate use the frames after the first (the largest",
              f"of them); the first frame took {_first_extra(fw)} more."]
    lines += layers_section(fw, problems)
    ref = next((d for d in fw if d["toolchain"] == "cortex-m7" and d["build_type"] == "Release" and d["cmsis"]), None)
    port = next((d for d in fw if d["toolchain"] == "cortex-m7" and d["build_type"] == "Release" and not d["cmsis"]),
                None)
    if ref and macs:
        cnn = _cnn_insns(ref)
        per_mac = cnn / macs
        ms = cnn / CLOCK_HZ * 1e3
        worst = max((ly["stream_cmsis"] / ly["stream_portable"] for ly in ref["layers"]), default=0.0)
        lines += ["", "### Issue 36's bars (CNN stage, `mps2-an500` Cortex-M7, Release, CMSIS-NN)", "",
                  f"- ≤ {BAR_PER_MAC:.1f} instructions per MAC (≤ {BAR_PER_MAC * macs / 1e6:.1f} M per frame): "
                  f"{per_mac:.2f} ({cnn / 1e6:.1f} M) — "
                  + ("**met**" if per_mac <= BAR_PER_MAC else
                     f"**not met**, {per_mac / BAR_PER_MAC:.1f}× the bar"
                     + (f" (portable kernels: {_cnn_insns(port) / macs:.2f}, {_cnn_insns(port) / 1e6:.1f} M; "
                        f"the back end saves {1 - cnn / _cnn_insns(port):.0%})" if port else "")) + ";",
                  f"- ≤ 1.0× the portable kernels' instructions on every layer it maps: worst layer {worst:.2f}× — "
                  + ("**met**" if worst <= 1.0 else "**not met**") + ";",
                  f"- estimated frame time on a 480 MHz Cortex-M7 ≤ {BAR_FRAME_MS:.0f} ms: {ms:.0f} ms — "
                  + ("**met**" if ms <= BAR_FRAME_MS else f"**not met**, {ms / BAR_FRAME_MS:.1f}× the bar") + ";",
                  "- byte-equal output on both boards with the back end on, in CI: **met** (test_firmware.py; the",
                  "  CNN unit tests on Cortex-M7 code under qemu-arm in tests/cross_run.sh).",
                  "", "What the back end runs: vd's own Armv7E-M DSP kernels (`kernels/cmsis.h`, `dw3x3_cmsis.c`,",
                  "`conv_cmsis.c`) on the depthwise, pointwise (input channels a multiple of 4) and one-channel 3×3",
                  "layers whose clamp is [−128, 127] and whose shifts lie in −24..−1 (every layer of the shipped",
                  "networks), CMSIS-NN's `arm_depthwise_conv_3x3_s8` / `arm_nn_mat_mult_nt_t_s8` on any other layer.",
                  "On this network's shapes CMSIS-NN's depthwise kernel spent ~74 instructions per output value (9",
                  "multiply-adds: per-pixel set-up, the tap loop, ~15 of requantisation) and its GEMM ~2.4 per MAC",
                  "plus the requantisation. The DSP kernels widen the weights once per call (SXTB16 pairs in the",
                  "scratch the portable kernels' int16 weights use) and requantise with models/requant.h's",
                  "one-shift form, the bias, the input offset's weight sum and the output zero point folded into",
                  "one 64-bit constant per channel, so the sums start at 0 and a value costs one `SMLAL`, `ASR`",
                  f"and `SSAT` (~{REQ_INSNS} instructions with the constants' loads and the store; bit-exact, the",
                  "derivation is in cmsis.h). Before them (CMSIS-NN everywhere, commit a2f6e9f) the CNN stage took",
                  "73.7 M instructions per frame here (5.15 per MAC, 154 ms).", "",
                  f"Second and third passes (issue 36): {PREV_CNN_M:.1f} M → {MID_CNN_M:.1f} M → {cnn / 1e6:.1f} M "
                  f"instructions per frame ({PREV_PER_MAC:.2f} → {MID_PER_MAC:.2f} → {per_mac:.2f} per MAC, "
                  "bit-exact, same firmware output), measured by",
                  "`PYTHONPATH=tools python3 -m vdtools.generators.embedded_report --write`. What the second changed: the",
                  "requantisation constant above (it was one `SMLAL`, `ASR` and `USAT` after a bias load, ~10",
                  "instructions per value); the hot loops as assembly blocks (gcc 12 spilled tap pointers, widened",
                  "inputs and weights to the stack around them): the depthwise taps in pairs (`PKHBT`/`PKHTB` of",
                  "two input words, then `SXTB16` and one `SMLAD` per channel: 14 instructions per pair of taps and",
                  "four channels against 16), group-major runs of interior pixels with taps, requantisation and",
                  "pixel loop in one block (ReLU layers); the pointwise run of pixels (widening, per four channels",
                  "an `LDRD`/`SMLAD` loop started by `SMUAD`, eight input values per iteration, the requantisation,",
                  "for the head with its sign term) in one block; the one-channel 3×3 layer's nine taps in five",
                  "`SMLAD` (`PKHBT` of the middle column) with a row's interior pixels in one block; the per-call",
                  "set-up (streamed calls are one output row) with whole-word `SXTB16` widening and `SMLAD` weight",
                  "sums; and, outside the kernels, the half-resolution input rows (2×2 box average, made twice per",
                  "frame) four pixels at a time in 16-bit lanes (pixel/resample.c, Armv7E-M builds, also",
                  "-Os: the MinSizeRel rows above went from 82.1 M and 172.3 M).", "",
                  "The third (2026-11-28, evening), all outside the multiply-add loops: the DSP kernels' set-up",
                  "(widened weights, weight sums, requantisation constants) once per run into a per-layer prepared",
                  "area instead of on every one-row call (−1.7 M; `VD_CNN_PREP_CAP`, docs/architecture.md); the",
                  "streamed plan kept from frame to frame (`VD_CNN_REUSE_PLAN`: the ring-sizing walk, −0.8 M) and a",
                  "sub-step's rows per tensor computed, not stepped (−0.1 M); bands of 4 head and input rows for",
                  "networks whose workspace stays within 192 KiB (`VD_CNN_BAND_CAP`: fewer sub-steps and kernel",
                  "calls, −0.35 M; the shipped host pair keeps 1); the 2×2 box average as `UXTB16`/`UXTAB16`/`PKHBT`",
                  "assembly (~22 instructions per four outputs against ~36, −0.5 M); the decoder's concat copies",
                  "the shipped channel counts without a `memcpy` call per pixel (−0.2 M); the input histogram and",
                  "lookup four pixels per word (−0.1 M). Each step measured by this report's firmware run; the",
                  "firmware's output stayed byte-identical.", "",
                  "Where the instructions go: the compact network's layers are small, 9",
                  "multiply-adds per output value in the 3×3 and depthwise layers, 8–64 in the pointwise ones.",
                  requant_note(ref["layers"], macs),
                  f"The depthwise layers run at {dw_range(ref)} instructions per MAC (per pair of taps and four",
                  "channels two input loads, two `PKH`, four `SXTB16`, two weight `LDRD`, four `SMLAD`: 1.75 per",
                  "MAC before the requantisation); the pointwise inner loop at ~0.9 per MAC (per 16 MACs one `LDRD`",
                  "of the widened input, four `LDRD` of weights, eight `SMLAD`, half a loop test). The Cortex-M7's",
                  "14 allocatable registers bound the blocking (two output pixels per block would share the weight",
                  "loads but need eight sums beside the operands). The streamed calls' overhead (borders, the",
                  "prepared areas' filling once per run) is",
                  f"{(ref['layer_sum']['stream_cmsis'] - ref['layer_sum']['plane_cmsis']) * ref['insn_per_tick'] / 1e6:.1f}"
                  " M of the streamed kernels' instructions above the whole-plane calls. The",
                  "instructions outside the kernels (input rows from the frame, twice: the percentile histogram",
                  "and the network; upsample and concat, the decoder)",
                  f"are {(cnn - ref['layer_sum']['stream_cmsis'] * ref['insn_per_tick']) / 1e6:.1f} M of the stage. "
                  "The 0.5–0.9 MAC per cycle quoted for CMSIS-NN on a",
                  "Cortex-M7 counts cycles of a dual-issue core on larger layers, not emulated instructions."]
    return lines


def dw_range(d):
    """'a–b': the CMSIS-NN depthwise layers' instructions per MAC in firmware() dict d."""
    v = [ly["stream_cmsis"] * d["insn_per_tick"] / ly["macs"] for ly in d["layers"] if ly["op"] == 2]
    return f"{min(v):.1f}–{max(v):.1f}" if v else "–"


def requant_note(layers, macs):
    """A sentence: output values of the weighted layers and the instructions ~REQ_INSNS per value cost."""
    outs = sum(ly["wo"] * ly["ho"] * ly["cout"] for ly in layers)
    return (f"The network's weighted layers write {outs / 1e6:.2f} M output values per frame: at ~{REQ_INSNS} "
            f"instructions each that is ~{REQ_INSNS * outs / 1e6:.0f} M instructions before any multiply-add, against a "
            "budget of "
            f"{BAR_PER_MAC * macs / 1e6:.1f} M for everything.")


def layers_section(fw, problems):
    """Per-layer kernel instructions, portable against CMSIS-NN (vd_fw_cnn_layers.elf), Cortex-M7 Release."""
    ref = next((d for d in fw if d["toolchain"] == "cortex-m7" and d["build_type"] == "Release" and d["layers"]), None)
    if ref is None:
        return []
    k = ref["insn_per_tick"]
    lines = ["", "### CNN kernels per layer (`mps2-an500` Cortex-M7, Release)", "",
             "`vd_fw_cnn_layers.elf` (tools/firmware/cnn_layers.c) runs the model once whole plane on the first",
             "frame, then every weighted layer again from its input tensor, one output row per call on rings as",
             "tall as the detector's streamed plan makes them (the calls `vd_detector_run` makes), with the",
             "portable kernel and with the CMSIS-NN back end (its DSP kernels where they apply), and compares every output row with the network's own tensor",
             "(`bad_rows`: 0 on every layer, both boards; tests/python/test_firmware.py checks it). Instructions",
             "of the kernel calls only (the row copies that stand in for the producing layers are not counted).", "",
             "| layer | op | channels | output | MACs | portable (instructions) | CMSIS-NN | CMSIS-NN / portable "
             "| CMSIS-NN per MAC |", "|---:|---|---|---|---:|---:|---:|---:|---:|"]
    for ly in ref["layers"]:
        po, cm = ly["stream_portable"] * k, ly["stream_cmsis"] * k
        op = OP_NAMES.get(ly["op"], str(ly["op"])) + (" /2" if ly["stride"] == 2 else "")
        lines.append(f"| {ly['index']} | {op} | {ly['cin']} → {ly['cout']} | {ly['wo']}×{ly['ho']} | "
                     f"{ly['macs'] / 1e6:.2f} M | {po / 1e6:.2f} M | {cm / 1e6:.2f} M | {cm / po:.2f} | "
                     f"{cm / ly['macs']:.2f} |")
        if cm > po:
            problems.append(f"CMSIS-NN layer {ly['index']}: {cm / po:.2f}x the portable kernel's instructions")
    s = ref["layer_sum"]
    lines.append(f"| **all** | | | | **{s['macs'] / 1e6:.2f} M** | **{s['stream_portable'] * k / 1e6:.1f} M** | "
                 f"**{s['stream_cmsis'] * k / 1e6:.1f} M** | **{s['stream_cmsis'] / s['stream_portable']:.2f}** | "
                 f"**{s['stream_cmsis'] * k / s['macs']:.2f}** |")
    lines += ["", "Whole plane (one call per layer): portable "
              f"{s['plane_portable'] * k / 1e6:.1f} M, CMSIS-NN {s['plane_cmsis'] * k / 1e6:.1f} M. Other boards "
              "and builds (all layers, streamed calls):"]
    for d in fw:
        if d["layer_sum"] and d is not ref:
            t = d["layer_sum"]
            kk = d["insn_per_tick"]
            lines.append(f"`{d['machine']}` {d['build_type']}: portable {t['stream_portable'] * kk / 1e6:.1f} M, "
                         f"CMSIS-NN {t['stream_cmsis'] * kk / 1e6:.1f} M "
                         f"({t['stream_cmsis'] / t['stream_portable']:.2f}×);")
    for d in fw:
        if d["layer_sum"] and d["layer_sum"]["bad_rows"] != 0:
            problems.append(f"vd_fw_cnn_layers on {d['machine']} {d['build_type']}: {d['layer_sum']['bad_rows']} rows differ")
    return lines


def m0_section(m0_sum, m0_links, m0_cmsis):
    """Markdown lines of the Cortex-M0+ sizes: the whole library and what images link of it."""
    lines = ["", "## The whole library on a Cortex-M0+ (`-Os`, issue 36)", "",
             "Every source of `lib/` compiled for a Cortex-M0+ (`tools/toolchains/cortex-m0plus.cmake`, MinSizeRel),",
             "counted as `arm-none-eabi-size` counts `text` (.text + .rodata of every object of libvd.a), and",
             "what an M0+ image links of it with `-ffunction-sections` and `--gc-sections` for a set of entry",
             "points (libvd's input sections in the image's map; the C library's helpers not counted). Goal:",
             f"whole library ≤ 64 KiB ({M0_TEXT_BUDGET} B): "
             + ("**met**" if m0_sum[0] <= M0_TEXT_BUDGET else "**not met**")
             + f" ({M0_TEXT_BUDGET - m0_sum[0]:+d} B). Before issue 36: 65 829 B (the CNN in one file), 66 325 B",
             "after the CNN and long functions were split (more call sites); the DBN's sigmoid table then held",
             "its z ≤ 0 half (−2 048 B), since 2026-11-30 only the first index of each of its 128 steps (65 488 →",
             "63 753 B; `lib/src/models/dbn.c`, docs/fixed-point.md \"Sigmoid\").", "",
             "| configuration | CNN kernels | .text + .rodata (B) | .text (B) |", "|---|---|---:|---:|",
             f"| whole library (every object) | portable | {m0_sum[0]} | {m0_sum[1]} |"]
    for label, (t, r) in m0_links:
        lines.append(f"| linked: {label} | portable | {t + r} | {t} |")
    if m0_cmsis:
        (c_all, c_text), c_links = m0_cmsis
        lines.append(f"| whole library (every object) | CMSIS-NN (forced: `-DVD_CNN_CMSIS=ON`) | {c_all} | {c_text} |")
        for label, (t, r) in c_links:
            lines.append(f"| linked: {label} | CMSIS-NN (forced) | {t + r} | {t} |")
    whole = m0_links[0][1]
    lines += ["", f"The linker drops {m0_sum[0] - sum(whole)} B of the whole library when every public function is kept:",
              "no dead code is left, one kernel per file or not. What a firmware that uses the detector with the",
              "CNN source only still carries (the hot-spot labelling, region refinement, median, DBN, contrast and",
              "window sources) is reached from `vd_detector_run` itself: the sources are chosen at run time",
              "(`cfg.sources`), so the linker cannot tell them dead. The CMSIS-NN back end is off by default on",
              "the M0+ (no DSP extension: CMSIS-NN's plain-C loops, no faster than vd's) and adds the sizes above",
              "when forced."]
    return lines


def _percentile(v, q):
    """Nearest-rank percentile (no interpolation): the value with q % of the frames at or below it."""
    v = sorted(v)
    return v[max(0, min(len(v) - 1, -(-len(v) * q // 100) - 1))]


def run_counts():
    """Run counts of the hot-spot labelling on the real frames, per data set and threshold mode:
    {(set, mode): [runs per frame]}. Uses the C labeller (vd_components_label_thr_u8) at the
    detector's thresholds: constant 150 and adaptive max(96, p99)."""
    import cv2
    import numpy as np
    _clib, cc, _det, _rf = _vdtools()
    sets = {"MSRS night (…N.png)": sorted((DATA / "msrs" / "images").glob("*N.png")),
            "MSRS day (…D.png)": sorted((DATA / "msrs" / "images").glob("*D.png")),
            "HIT-UAV T=1 (night)": sorted((DATA / "hit-uav" / "frames" / "images").glob("1_*.jpg")),
            "HIT-UAV T=0 (day)": sorted((DATA / "hit-uav" / "frames" / "images").glob("0_*.jpg"))}
    out = {}
    for name, files in sets.items():
        if not files:
            continue
        res = {"constant 150": [], "adaptive": []}
        for f in files:
            img = cv2.imread(str(f), cv2.IMREAD_GRAYSCALE)
            hist = np.bincount(img.ravel(), minlength=256)
            t_ad = max(96, int(np.searchsorted(np.cumsum(hist), -(-img.size * 990 // 1000))))
            for mode, thr in (("constant 150", 150), ("adaptive", t_ad)):
                _c, st, stats = cc.label_thr(img, thr, cap=1)
                res[mode].append(stats["runs"])
        for mode, v in res.items():
            out[(name, mode)] = v
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--write", action="store_true", help="write docs/embedded.md")
    ap.add_argument("--check", action="store_true", help="exit 1 when a budget is broken")
    ap.add_argument("--runs", action="store_true", help="measure run counts on ../shared/data (implied by --write)")
    ap.add_argument("--firmware", action="store_true",
                    help="build tools/firmware and measure it under qemu-system-arm (implied by --write)")
    args = ap.parse_args()
    if not shutil.which("arm-none-eabi-gcc"):
        print("arm-none-eabi-gcc not found: install gcc-arm-none-eabi (tools/setup.sh)")
        return 1 if args.check else 0

    problems = []
    m7 = build("m7", "cortex-m7", "-fstack-usage -fcallgraph-info=su")
    rows, totals = [], [0, 0, 0, 0]
    for obj in objects(m7):
        s = section_sizes(obj)
        rows.append((module_of(obj), *s))
        totals = [a + b for a, b in zip(totals, s)]
    frame, edges, dynamic = parse_callgraph(m7)
    stacks = []
    for fn in sorted(public_functions()):
        if fn not in frame:
            continue  # inline or not compiled in this configuration
        try:
            depth = worst_stack(fn, frame, edges)
        except RuntimeError as e:
            problems.append(f"{fn}: {e}")
            continue
        stacks.append((fn, frame[fn], depth))
        budget = STACK_BUDGET.get(fn)
        if budget is not None and depth > budget:
            problems.append(f"{fn}: worst-case stack {depth} B > budget {budget} B")
    for fn, budget in STACK_BUDGET.items():
        if fn not in frame and (REPO / "lib" / "src" / "detector" / "detector.c").exists():
            problems.append(f"{fn}: not found in the call graph")
    if dynamic:
        problems.append("functions with dynamic stack (VLA/alloca): " + ", ".join(sorted(dynamic)))
    chains = {fn: deepest_path(fn, frame, edges) for fn in STACK_BUDGET if fn in frame}
    user_cb = sorted(n.split(":")[-1] for n, es in edges.items() if "__indirect_call" in es)

    m0 = build("m0plus", "cortex-m0plus")
    undefined = set()
    for obj in objects(m0):
        for line in run(["arm-none-eabi-nm", "-u", str(obj)]).splitlines():
            undefined.add(line.split()[-1])
    soft = sorted(u for u in undefined if SOFT_FLOAT.search(u))
    heap = sorted(u for u in undefined if HEAP.match(u))
    if soft:
        problems.append("Cortex-M0+ build references soft-float helpers: " + ", ".join(soft))
    if heap:
        problems.append("Cortex-M0+ build references the heap: " + ", ".join(heap))
    m0_sum = size_text(m0)
    if m0_sum[0] > M0_TEXT_BUDGET:
        problems.append(f"Cortex-M0+ whole library {m0_sum[0]} B (.text + .rodata) > {M0_TEXT_BUDGET} B")
    m0_links = [(label, linked_size(m0, keep)) for label, keep in M0_LINKS]
    m0_cmsis = None   # the back end forced on (off by default without DSP): --write only, one more build
    if args.write and (CMSIS_NN / "Include" / "arm_nnfunctions.h").is_file():
        m0c = build("m0plus-cmsis", "cortex-m0plus", cmake_args=["-DVD_CNN_CMSIS=ON"])
        m0_cmsis = (size_text(m0c), [(label, linked_size(m0c, keep)) for label, keep in M0_LINKS])

    ws, ws_parts = detector_workspace()
    if ws is not None and ws > WORKSPACE_GOAL:
        print(f"note: detector workspace {ws} B is above the {WORKSPACE_GOAL} B goal")
    runs = {}
    if (args.runs or args.write) and DATA.is_dir():
        runs = run_counts()

    lines = ["# Embedded budgets", "",
             "Generated by `python3 -m vdtools.generators.embedded_report --write` (do not edit by hand);",
             "`--check` (run by `tools/test.sh`) fails when a budget below is broken.", "",
             "## Code and data per module (Cortex-M7, `-Os`, arm-none-eabi-gcc "
             + run(["arm-none-eabi-gcc", "-dumpversion"]).strip() + ")", "",
             "| module | .text | .rodata | .data | .bss |", "|---|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r[0]} | {r[1]} | {r[2]} | {r[3]} | {r[4]} |")
    lines.append(f"| **total** | **{totals[0]}** | **{totals[1]}** | **{totals[2]}** | **{totals[3]}** |")
    lines += ["", "Model weights are not in these figures: a model lives in its own `const` array",
              "(`models/*_vdm.c`) or in a blob the firmware loads; see `models/*.md` for their sizes.", "",
              "## Worst-case stack per public function (Cortex-M7, `-Os`)", "",
              "From `-fstack-usage -fcallgraph-info=su`: own frame, and own frame plus the deepest call chain.", "",
              "| function | own frame (B) | worst case (B) | budget |", "|---|---:|---:|---|"]
    for fn, own, depth in stacks:
        b = STACK_BUDGET.get(fn)
        lines.append(f"| `{fn}` | {own} | {depth} | {('≤ ' + str(b)) if b else ''} |")
    for fn, chain in chains.items():
        lines += ["", f"Deepest chain of `{fn}`: " + " → ".join(f"{n} ({b})" for n, b in chain)
                  + f" = {sum(b for _, b in chain)} B."]
        depth = sum(b for _, b in chain)
        budget = STACK_BUDGET[fn]
        if depth > budget:
            big = sorted(chain, key=lambda t: -t[1])[:3]
            lines += ["", f"Over the budget by {depth - budget} B; the largest frames on that chain: "
                      + ", ".join(f"`{n}` {b} B" for n, b in big) + "."]
    lines += ["", "Indirect calls resolved: " + ", ".join(f"{k} → {', '.join(v)}" for k, v in INDIRECT.items())
              + "; user callbacks not counted (from " + (", ".join(user_cb) or "none") + ")."]
    lines += m0_section(m0_sum, m0_links, m0_cmsis)
    lines += ["", "## Checks", "",
              f"- Cortex-M0+ (no FPU) soft-float helpers referenced: {', '.join(soft) if soft else 'none'}",
              f"- heap functions referenced: {', '.join(heap) if heap else 'none'}",
              f"- functions with a dynamic stack frame: {', '.join(sorted(dynamic)) if dynamic else 'none'}"]
    if ws is not None:
        lines.append(f"- detector workspace, 640×512, default config: {ws} bytes ({ws / 1024:.1f} KiB; goal ≤ 256 KiB)")
        lines += ["", "## Detector workspace, 640×512, default config (no model)", "",
                  "`vd_detector_workspace_size(NULL, NULL, &bytes)`; parts from the modules' own size queries",
                  "(8-byte aligned slices). Before issue 5 the same call gave 1 658 376 bytes: a 1 B/px hot mask",
                  "(327 680) plus the labeller's worst-case run array (1 319 432, a checkerboard), with the",
                  "256×256 region buffers (~0.5 MiB) inside them.", "",
                  "| part | bytes | what |", "|---|---:|---|"]
        for part, b, note in ws_parts:
            lines.append(f"| {part} | {b} | {note} |")
        lines.append(f"| **total** | **{ws}** | {ws / 1024:.1f} KiB |")
        lines += ["", "What bounds it: the region buffers B, 7 bytes per pixel of `max_region_w × max_region_h`",
                  "(crop 1 + region mask 1 + refine workspace 5: the filtered region and the hole-filling",
                  "stack of 4 B/px in `refine.c`). The labelling workspace A (run budget) fits under B, so",
                  "`max_runs` up to (B − row buffers) / 8 costs nothing at this size. Nothing scales with the",
                  "frame except the labeller's row buffers (24 B per 2 columns + 4 B per 2 rows)."]
    cnn_rows = cnn_workspace()
    if cnn_rows:
        lines += ["", "## Detector workspace with the CNN source (issue 10)", "",
                  "`vd_detector_workspace_size` with `sources = cnn` and the committed CNN models. The detector",
                  "runs the network streamed (`VD_CNN_STREAM`, row bands as in MCUNetV2): every tensor is a ring of",
                  "the rows its consumers still read, sized at plan time by the row schedule (the head's consumer is",
                  "the decoder, which decides a row's peaks once the row below it exists: `VD_CNN_HEAD_RING`, 3 rows",
                  "of the shipped pair's 64 instead of all, since 2026-11-29), and the half-resolution input rows are",
                  "made from the frame on demand (`vd_cnn_run_rows_decode`), so there is no input plane and no",
                  "whole head (docs/architecture.md, \"Streamed CNN\"). The CNN's share",
                  "(`vd_cnn_workspace_size_ex(..., VD_CNN_STREAM | VD_CNN_HEAD_RING)` + decoded boxes) overlays the labelling",
                  "workspace (for `vd_cnn_compact` that is the larger part, so its total is the hot-spot",
                  "detector's without the components table and histogram). Goal ≤ 256 KiB",
                  f"({WORKSPACE_GOAL} B): **met** for both. Before (whole-plane liveness plan + an 80 KiB input",
                  "plane, commit a2a6141): `vd_cnn` 649200 B at 640×512 and 609520 B at 640×480, `vd_cnn_compact`",
                  "382960 B and 359920 B.", "",
                  "Configurations: the library's defaults (one pass, 64 candidates, 32 detections, no temporal",
                  "analysis), the fused flip pass (`cnn_flip = 1`: twice the decoded boxes in the overlay), and",
                  "`vd_fir_demo`'s own budgets (flip pass, temporal analysis with 32 tracks, candidates for both",
                  "passes' top-K, detections the model's top-K; `tools/demo/common/models.c`). A network-only detector",
                  "has no components table and no histogram (8 192 B at the defaults; since 2026-11-25).", "",
                  "| model | parameters | MACs at 320×256 | frame | configuration | detector workspace (bytes) | ≤ 256 KiB |",
                  "|---|---:|---:|---|---|---:|---|"]
        for name, params, macs, frame, label, b in cnn_rows:
            ok = "yes" if b <= WORKSPACE_GOAL else "**no**"
            lines.append(f"| `{name}` | {params} | {macs / 1e6:.1f} M | {frame} | {label} | {b} ({b / 1024:.0f} KiB) "
                         f"| {ok} |")
            if b > WORKSPACE_GOAL:
                problems.append(f"detector workspace with {name} at {frame} ({label}): {b} B > {WORKSPACE_GOAL} B")
    if runs:
        lines += ["", "## Labelling run counts on real frames", "",
                  "Horizontal runs of pixels ≥ threshold per frame (`vd_components_stats_t.runs`), measured with the",
                  "C labeller on every frame of `../shared/data` at the detector's two thresholds.",
                  "The detector's default budget `max_runs` = 24 576 runs; p99 = nearest-rank 99th percentile.", "",
                  "| frames | threshold | n | max | p99 | median |", "|---|---|---:|---:|---:|---:|"]
        for (name, mode), v in runs.items():
            lines.append(f"| {name} | {mode} | {len(v)} | {max(v)} | {_percentile(v, 99)} | {_percentile(v, 50)} |")
        allmax = max(max(v) for v in runs.values())
        lines += ["", f"Largest count of all: {allmax} runs, {24576 / allmax:.1f}× below the default budget."]
    if args.firmware or args.write:
        fw = [d for d in (firmware(tc, bt, cm) for tc in FW_BOARDS for bt in ("MinSizeRel", "Release")
                          for cm in (False, True)) if d]
        if fw:
            lines += firmware_section(fw, cnn_rows, problems)
            if any(d["stack_used"] > d["stack_size"] // 2 for d in fw):
                problems.append("firmware stack high-water mark above half of its 16 KiB stack")
    lines += ["", "Problems: " + ("; ".join(problems) if problems else "none"), ""]
    report = "\n".join(lines)
    print(report)
    if args.write:
        (REPO / "docs" / "embedded.md").write_text(report)
    if args.check and problems:
        print("embedded budget check FAILED", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
