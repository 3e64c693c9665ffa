# SPDX-License-Identifier: MIT
"""The include rules of lib/ (docs/architecture.md), checked on every file under lib/ (walked
recursively, so files may move between folders of lib/src without touching this test):

- an angle-bracket include names one of the standard headers that docs/architecture.md lists in its
  sentence "`lib/` includes only `<stdint.h> ...`" (read from the document, so the two cannot drift);
  the one named exception: x86 back-end files (a path below lib/ with the word "x86" in a folder or file
  name, as lib/src/models/cnn/kernels/conv_x86.c) may include <immintrin.h> and <cpuid.h>, and CMSIS-NN back-end files
  (the word "cmsis") CMSIS-NN's own headers;
- a quoted include resolves to a file of lib/ (the including file's folder, lib/include, lib/src or
  any other folder of lib/),
  except the user configuration hook of vd/config.h ("vd_user_config.h", VD_USER_CONFIG_FILE): nothing
  in lib/ includes port/, tools/ or a header from outside;
- the include graph of lib/ (files as nodes, quoted includes as edges) has no cycle;
- a quoted include of port/ names a file of port/ or a public header of lib/ (lib/include), never
  lib/src or tools/: the arrows point down, tools/ -> port/ -> lib/.

Each check runs on lib/ and, to show it catches what it claims to, on a small fake tree with a violation.
(Issue 37 item 3.)
"""
import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
LIB = REPO / "lib"
ARCH = REPO / "docs" / "architecture.md"

INCLUDE = re.compile(r'^\s*#\s*include\s*(?:<([^>]+)>|"([^"]+)"|(\w+))', re.M)
BACKENDS = {   # word in a path below lib/ -> the extra angle-bracket headers its files may include
    "x86": {"immintrin.h", "cpuid.h"},
    "cmsis": {"arm_nnfunctions.h", "arm_nnsupportfunctions.h", "arm_nn_types.h", "arm_nn_math_types.h",
              "arm_math_types.h", "arm_acle.h"},   # arm_acle.h: the DSP intrinsics of vd's own M-profile kernels
}
USER_CONFIG = {"vd_user_config.h", "VD_USER_CONFIG_FILE"}   # vd/config.h's hook for firmware settings


def allowed_std_headers(text=None):
    """The standard headers of the rule sentence in docs/architecture.md."""
    text = ARCH.read_text() if text is None else text
    m = re.search(r"`lib/` includes only ([`<>\w./ ,]+)", text)
    assert m, "docs/architecture.md no longer states the include rule ('`lib/` includes only `<...>`')"
    return set(re.findall(r"<([\w./]+)>", m.group(1)))


def sources(root):
    return sorted(p for p in root.rglob("*") if p.suffix in (".c", ".h") and p.is_file())


def includes(path):
    """(line, kind, name) of every #include of a file: kind 'sys' (<...>), 'local' ("...") or 'macro'."""
    text = path.read_text(errors="replace")
    for m in INCLUDE.finditer(text):
        line = text.count("\n", 0, m.start()) + 1
        if m.group(1):
            yield line, "sys", m.group(1)
        elif m.group(2):
            yield line, "local", m.group(2)
        else:
            yield line, "macro", m.group(3)


def backend_words(path, root):
    words = set(re.split(r"[/_.\-]", path.relative_to(root).as_posix().lower()))
    return {w for w in BACKENDS if w in words}


def resolve(path, name, root, bases=("include", "src"), anywhere=True):
    """The file of root that a quoted include names, or None (the compiler's search order: the
    including file's folder, then root/<base> for each base, then any folder of root)."""
    for base in (path.parent, *(root / b for b in bases)):
        cand = (base / name).resolve()
        if cand.is_file() and root.resolve() in cand.parents:
            return cand
    if not anywhere:
        return None
    # a folder of root that the build may add to the include path (files move between sub-folders)
    found = sorted(p.resolve() for p in root.rglob(Path(name).name) if p.as_posix().endswith("/" + name))
    return found[0] if found else None


def violations(root, std):
    """Breaches of the include rule in the tree `root` (laid out like lib/)."""
    bad = []
    for path in sources(root):
        rel = path.relative_to(root.parent).as_posix()
        extra = set().union(*(BACKENDS[w] for w in backend_words(path, root)))
        for line, kind, name in includes(path):
            if kind == "sys" and name not in std | extra:
                bad.append(f"{rel}:{line}: #include <{name}> (lib/ includes only {sorted(std)}; "
                           f"x86/CMSIS-NN back-end files also their intrinsics headers)")
            elif kind in ("local", "macro") and name not in USER_CONFIG and resolve(path, name, root) is None:
                bad.append(f"{rel}:{line}: #include {name!r} is not a file of lib/")
    return bad


def port_violations(port, lib):
    """Quoted includes of the tree `port` that are neither its own files nor public headers of `lib`."""
    bad = []
    for path in sources(port):
        for line, kind, name in includes(path):
            if kind != "sys" and resolve(path, name, port, ("include",)) is None \
                    and resolve(path, name, lib, ("include",), anywhere=False) is None:
                bad.append(f"{path.relative_to(port.parent).as_posix()}:{line}: #include {name!r} is neither "
                           "a file of port/ nor a public header of lib/")
    return bad


def include_graph(root):
    """{file: [files it includes]} over the tree `root`, quoted includes that resolve inside it."""
    graph = {}
    for path in sources(root):
        graph[path.resolve()] = [t for _, kind, name in includes(path) if kind == "local"
                                 for t in [resolve(path, name, root)] if t is not None]
    return graph


def find_cycle(graph):
    """One cycle of the graph as a list of nodes (first == last), or None; iterative DFS."""
    state = {}   # node -> 1 on the current path, 2 done
    for start in sorted(graph):
        if state.get(start):
            continue
        path, iters = [start], [iter(graph.get(start, ()))]
        state[start] = 1
        while path:
            nxt = next(iters[-1], None)
            if nxt is None:
                state[path.pop()] = 2
                iters.pop()
            elif state.get(nxt) == 1:
                return path[path.index(nxt):] + [nxt]
            elif not state.get(nxt):
                state[nxt] = 1
                path.append(nxt)
                iters.append(iter(graph.get(nxt, ())))
    return None


def _fake_lib(tmp_path, files):
    root = tmp_path / "lib"
    for rel, text in files.items():
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        (root / rel).write_text(text)
    return root


# --- lib/ itself -----------------------------------------------------------------------------------

def test_rule_is_stated_as_tested():
    assert allowed_std_headers() == {"stdint.h", "stddef.h", "stdbool.h", "string.h", "limits.h"}


def test_lib_includes_follow_the_rule():
    files = sources(LIB)
    assert len(files) > 30 and any(p.name == "detector.h" for p in files), "lib/ not found where expected"
    bad = violations(LIB, allowed_std_headers())
    assert not bad, "include rule of docs/architecture.md broken:\n" + "\n".join(bad)


def test_lib_include_graph_has_no_cycle():
    graph = include_graph(LIB)
    assert sum(map(len, graph.values())) > 100, "too few includes resolved: is the parser broken?"
    cycle = find_cycle(graph)
    assert cycle is None, "include cycle in lib/: " + " -> ".join(p.relative_to(REPO).as_posix() for p in cycle)


def test_port_includes_only_itself_and_public_lib_headers():
    assert len(sources(REPO / "port")) > 8
    bad = port_violations(REPO / "port", LIB)
    assert not bad, "\n".join(bad)


# --- the checks catch what they claim to -------------------------------------------------------------

def test_rule_catches_os_header_and_port_include(tmp_path):
    root = _fake_lib(tmp_path, {
        "include/vd/a.h": "#include <stdint.h>\n",
        "src/sub/dir/a.c": '#include <stdio.h>\n#include "vd/a.h"\n#include "vd_port/capture.h"\n',
        "src/ok.c": '#include <string.h>\n#include "vd/a.h"\n#include "sub/dir/a.c"\n',
    })
    bad = violations(root, allowed_std_headers())
    assert len(bad) == 2, bad
    assert "lib/src/sub/dir/a.c:1: #include <stdio.h>" in bad[0] and "vd_port/capture.h" in bad[1]


def test_rule_names_one_exception_x86_and_cmsis_back_ends(tmp_path):
    root = _fake_lib(tmp_path, {
        "src/models/cnn/conv_x86.c": "#include <immintrin.h>\n",
        "src/x86/pool.c": "#include <immintrin.h>\n",
        "src/cnn_cmsis.c": "#include <arm_nnfunctions.h>\n",
        "src/cnn.c": "#include <immintrin.h>\n",                   # not a back-end file
        "src/cnn_x86_more.c": "#include <stdlib.h>\n",            # a back end, but not its header
        "src/max86.c": "#include <immintrin.h>\n",                # "x86" only as part of a word
    })
    bad = violations(root, allowed_std_headers())
    assert sorted(b.split(":")[0] for b in bad) == ["lib/src/cnn.c", "lib/src/cnn_x86_more.c", "lib/src/max86.c"], bad


def test_rule_is_read_from_the_document():
    assert allowed_std_headers("x\n`lib/` includes only `<stdint.h> <string.h>`; OS headers") == {"stdint.h", "string.h"}


def test_cycle_is_found(tmp_path):
    root = _fake_lib(tmp_path, {
        "include/vd/a.h": '#include "vd/b.h"\n',
        "include/vd/b.h": '#include <stdint.h>\n#include "internal/c.h"\n',
        "src/internal/c.h": '#include "vd/a.h"\n',
        "src/a.c": '#include "vd/a.h"\n',
    })
    cycle = find_cycle(include_graph(root))
    assert cycle is not None and [p.name for p in cycle] == ["a.h", "b.h", "c.h", "a.h"], cycle
    (root / "src/internal/c.h").write_text("#include <stdint.h>\n")
    assert find_cycle(include_graph(root)) is None


def test_port_rule_catches_internal_and_tools_includes(tmp_path):
    lib = _fake_lib(tmp_path, {"include/vd/a.h": "", "src/internal/x.h": ""})
    port = tmp_path / "port"
    for rel, text in {"include/vd_port/p.h": '#include "vd/a.h"\n',
                      "file/f.c": '#include "vd_port/p.h"\n#include "internal/x.h"\n#include "f.h"\n'
                                  '#include "demo/args.h"\n#include <stdio.h>\n',
                      "file/f.h": ""}.items():
        (port / rel).parent.mkdir(parents=True, exist_ok=True)
        (port / rel).write_text(text)
    bad = port_violations(port, lib)
    assert [b.split(" #")[0] for b in bad] == ["port/file/f.c:2:", "port/file/f.c:4:"], bad
