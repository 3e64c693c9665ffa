# SPDX-License-Identifier: MIT
"""Embedded budgets of vd: code/data size per module and worst-case stack per
public function for a Cortex-M7 -Os build, soft-float and heap checks for the
Cortex-M0+ build, and the detector workspace for 640x512.

    python3 tools/embedded_report.py            # print the report
    python3 tools/embedded_report.py --write    # also write docs/embedded.md
    python3 tools/embedded_report.py --check    # exit 1 if a budget is broken

Stack depth comes from GCC's -fstack-usage / -fcallgraph-info=su: each
function's own frame plus the deepest path through its callees (lib/ has no
recursion and no function pointers in the detector path, so the graph is a
DAG; a cycle or an indirect call is reported, never silently ignored).
"""
import argparse
import ctypes as C
import re
import shutil
import subprocess
import sys
from collections import defaultdict
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
STACK_BUDGET = {"vd_detector_run": 2048}
WORKSPACE_GOAL = 256 * 1024
SOFT_FLOAT = re.compile(r"^__aeabi_[fd]|^__(add|sub|mul|div|fix|float|extend|trunc)\w*[sd]f")
HEAP = re.compile(r"^(malloc|calloc|realloc|free|aligned_alloc|posix_memalign)$")


def run(cmd, **kw):
    return subprocess.run(cmd, check=True, capture_output=True, text=True, **kw).stdout


def build(name, toolchain, extra_flags=""):
    bdir = REPO / f"build-report-{name}"
    run(["cmake", "-S", str(REPO), "-B", str(bdir), "-G", "Ninja",
         f"-DCMAKE_TOOLCHAIN_FILE={REPO / 'tools' / 'toolchains' / (toolchain + '.cmake')}",
         "-DCMAKE_BUILD_TYPE=MinSizeRel", f"-DCMAKE_C_FLAGS={extra_flags}"])
    run(["cmake", "--build", str(bdir), "--target", "vd", "--clean-first"])
    return bdir


def objects(bdir):
    return sorted((bdir / "CMakeFiles" / "vd.dir").rglob("*.obj")) + \
        sorted((bdir / "CMakeFiles" / "vd.dir").rglob("*.o"))


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
    for ci in (bdir / "CMakeFiles" / "vd.dir").rglob("*.ci"):
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
    return frame, edges, dynamic


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


def detector_workspace():
    """Workspace bytes of the default detector config at 640x512, through the shared build."""
    lib_path = REPO / "build" / "libvd.so"
    if not lib_path.exists():
        return None
    try:
        sys.path.insert(0, str(REPO / "tools"))
        from vdtools import detector  # noqa: E402  (bindings of the detector module)
        return detector.workspace_size(640, 512)
    except Exception as e:  # the report still works without the detector bindings
        print(f"note: detector workspace not measured ({e})", file=sys.stderr)
        return None


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--write", action="store_true", help="write docs/embedded.md")
    ap.add_argument("--check", action="store_true", help="exit 1 when a budget is broken")
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
        if fn not in frame and (REPO / "lib" / "src" / "detector.c").exists():
            problems.append(f"{fn}: not found in the call graph")
    if dynamic:
        problems.append("functions with dynamic stack (VLA/alloca): " + ", ".join(sorted(dynamic)))

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

    ws = detector_workspace()
    if ws is not None and ws > WORKSPACE_GOAL:
        print(f"note: detector workspace {ws} B is above the {WORKSPACE_GOAL} B goal")

    lines = ["# Embedded budgets", "",
             "Generated by `python3 tools/embedded_report.py --write` (do not edit by hand);",
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
    lines += ["", "## Checks", "",
              f"- Cortex-M0+ (no FPU) soft-float helpers referenced: {', '.join(soft) if soft else 'none'}",
              f"- heap functions referenced: {', '.join(heap) if heap else 'none'}",
              f"- functions with a dynamic stack frame: {', '.join(sorted(dynamic)) if dynamic else 'none'}"]
    if ws is not None:
        lines.append(f"- detector workspace, 640×512, default config: {ws} bytes ({ws / 1024:.1f} KiB; goal ≤ 256 KiB)")
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
