# SPDX-License-Identifier: MIT
"""tools/vdtools is layered (docs/architecture.md, "tools" rows): a module imports only from its own
subpackage or from a lower layer, so there are no import cycles between layers and only
vdtools.bindings knows C struct layouts and prototypes.

    bindings (0) < data, metrics (1) < formats (2) < training (3) < evaluation (4) < generators (5)

Every import statement is read with ast (lazy imports inside functions included); an upward or
sideways import fails with the importing file and line. (Issue 15 item 3.)
"""
import ast
from pathlib import Path

PKG = Path(__file__).resolve().parents[2] / "tools" / "vdtools"
LAYER = {"bindings": 0, "data": 1, "metrics": 1, "formats": 2, "training": 3, "evaluation": 4, "generators": 5}


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
