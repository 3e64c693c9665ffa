# SPDX-License-Identifier: MIT
"""tools/vdtools is layered (docs/architecture.md, "tools" rows): a module imports only from its own
subpackage or from a lower layer, and the modules of one subpackage import each other without a
cycle, so vdtools has no import cycle at all; only vdtools.bindings knows C struct layouts and
prototypes.

    bindings (0) < data, metrics (1) < formats (2) < training (3) < evaluation (4) < generators, adapt (5)

Every import statement is read with ast (lazy imports inside functions included: an import moved
into a function to dodge a cycle is still a cycle); an upward or sideways import, or a cycle inside a
subpackage, fails with the importing files and lines. (Issue 15 item 3, issue 37 item 6.)
"""
import ast
from pathlib import Path

PKG = Path(__file__).resolve().parents[2] / "tools" / "vdtools"
LAYER = {"bindings": 0, "data": 1, "metrics": 1, "formats": 2, "training": 3, "evaluation": 4, "generators": 5, "adapt": 5}


def _imports(path):
    """(line, imported vdtools subpackage or None for vdtools itself / a flat module name) of a file."""
    sub = path.relative_to(PKG).parts[0]
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.ImportFrom):
            if node.level:   # relative: resolve against the file's own package
                parts = ["vdtools", sub][:max(0, 2 - (node.level - 1))] + (node.module or "").split(".")
                mod = ".".join(p for p in parts if p)
            else:
                mod = node.module or ""
            names = [mod + "." + a.name for a in node.names] if mod == "vdtools" else [mod]
        elif isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        else:
            continue
        for name in names:
            parts = name.split(".")
            if parts[0] == "vdtools":
                yield node.lineno, parts[1] if len(parts) > 1 else None


def _modules():
    return sorted(p for p in PKG.rglob("*.py") if p.parent != PKG)


def _name(path):
    """Dotted module name of a file ("vdtools.training.cnn_train"; a package's __init__.py: the package)."""
    parts = ("vdtools",) + path.relative_to(PKG).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _module_imports(path, known):
    """(line, dotted name of a vdtools module or package in `known`) per import of a file: `from P import m`
    names module P.m when that is a module, else P itself; relative imports resolved."""
    package = _name(path) if path.name == "__init__.py" else _name(path).rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = package.split(".")[:len(package.split(".")) - (node.level - 1)]
                base = ".".join(up + ([base] if base else []))
            for a in node.names:
                target = base + "." + a.name
                yield node.lineno, target if target in known else base
        elif isinstance(node, ast.Import):
            for a in node.names:
                yield node.lineno, a.name


def test_no_import_cycle_inside_a_subpackage():
    """Imports between the modules of one subpackage form no cycle (between subpackages the layers
    above rule cycles out)."""
    paths = {_name(p): p for p in _modules()}
    edges = {}   # module -> {imported module of the same subpackage: first line}
    for name, path in paths.items():
        sub = name.split(".")[1]
        for line, target in _module_imports(path, paths):
            if target in paths and target != name and target.split(".")[1] == sub:
                edges.setdefault(name, {}).setdefault(target, line)
    cycles, state = [], {}   # state: 1 = on the current path, 2 = done

    def visit(m, stack):
        state[m] = 1
        stack.append(m)
        for t in sorted(edges.get(m, {})):
            if state.get(t) == 1:
                loop = stack[stack.index(t):] + [t]
                cycles.append(" -> ".join(f"{paths[a].relative_to(PKG)}:{edges[a][b]}"
                                          for a, b in zip(loop, loop[1:])) + f" -> {paths[t].relative_to(PKG)}")
            elif t not in state:
                visit(t, stack)
        stack.pop()
        state[m] = 2

    for m in sorted(paths):
        if m not in state:
            visit(m, [])
    assert not cycles, "import cycles:\n" + "\n".join(cycles)


def test_every_module_is_in_a_layer():
    flat = sorted(p.name for p in PKG.glob("*.py") if p.name != "__init__.py")
    assert not flat, f"modules outside the layers: {flat}"
    subs = sorted(p.name for p in PKG.iterdir() if p.is_dir() and (p / "__init__.py").exists())
    assert subs == sorted(LAYER), subs


def test_no_upward_or_sideways_import():
    bad = []
    for path in _modules():
        sub = path.relative_to(PKG).parts[0]
        for line, target in _imports(path):
            if target == sub:
                continue
            if target not in LAYER:
                bad.append(f"{path.relative_to(PKG)}:{line}: imports vdtools.{target} (not a layer)")
            elif LAYER[target] >= LAYER[sub]:
                bad.append(f"{path.relative_to(PKG)}:{line}: {sub} (layer {LAYER[sub]}) imports "
                           f"{target} (layer {LAYER[target]})")
    assert not bad, "\n".join(bad)


def test_only_bindings_declare_c_prototypes():
    """ctypes structs and argtypes/restype declarations live in vdtools.bindings only."""
    bad = []
    for path in _modules():
        if path.relative_to(PKG).parts[0] == "bindings":
            continue
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Attribute) and node.attr in ("argtypes", "restype", "Structure", "CDLL"):
                bad.append(f"{path.relative_to(PKG)}:{node.lineno}: {node.attr}")
    assert not bad, "\n".join(bad)
