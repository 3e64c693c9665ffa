# SPDX-License-Identifier: MIT
"""Every C snippet of README.md and docs/ (```c fenced blocks, docs/ walked recursively) compiles.

Each snippet becomes one translation unit, compiled by $CC (default cc) with
`-std=c99 -Wall -Wextra -Werror -Wno-unused-function -Wno-unused-parameter -fsyntax-only`
(a snippet may show a callback with a fixed signature, or a function the reader calls elsewhere):

1. `VD_NO_DEPRECATED` (snippets use the current names only), <stdio.h> and <string.h>, every public
   header `lib/include/vd/*.h`, every port header `port/include/vd_port/*.h` and every generated model
   header `models/*_vdm.h` (include path: lib/include, port/include, models, and tools/firmware for the
   bare-metal example's "board.h");
2. the snippet's own `#include` lines, hoisted to file scope (`<gst/...>` brings
   `pkg-config --cflags gstreamer-video-1.0`; without it the snippet is skipped);
3. the prelude below: the variables of the API-shape examples, declared `extern`;
4. the snippet. One that defines a function (a line at column 0 ending in `)`, then a line `{`) is
   file-scope code; any other is the body of `int snippet(int argc, char **argv)`, so it may use the
   prelude, `argv` and `return`.

A block that is deliberately not complete C (a template with placeholders) is fenced ```c fragment
(still highlighted as C, the second word is the marker) and only counted. `#line` directives point
compiler messages at the document's own lines. (Issue 37 item 3; docs/testing.md.)
"""
import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]

PRELUDE = """\
extern vd_detector_cfg_t cfg;        /* a detector configuration (vd_detector_cfg_default) */
extern vd_detector_t det;            /* a detector */
extern vd_dbn_model_t model;         /* a loaded verifier model (vd_dbn_load) */
extern void *ws;                     /* the caller's workspace buffer ... */
extern size_t bytes;                 /* ... and its size */
extern vd_frame_t frame;             /* a frame (vd_frame_t view of the camera's buffer) */
extern vd_detection_t dets[];        /* room for detections ... */
extern size_t cap, count;            /* ... its capacity, and how many a call wrote */
void run_detector(const vd_frame_t *frame, const char *name);   /* the reader's own per-frame work */
"""
FENCE = re.compile(r"^(\s*)(`{3,}|~{3,})\s*([^`\s]*)\s*(.*)$")
FUNCTION_DEF = re.compile(r"^[A-Za-z_][^;{}=]*\)[ \t]*\n\{", re.M)
PKG = {"gst/": "gstreamer-video-1.0"}


def documents():
    return [REPO / "README.md"] + sorted((REPO / "docs").rglob("*.md"))


def blocks(path):
    """(first line of code, info words, code) of every fenced block of a Markdown file."""
    lines = path.read_text().split("\n")
    i = 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        indent, fence, lang, rest = m.groups()
        j = i + 1
        while j < len(lines) and not re.match(rf"^\s*{fence[0]}{{{len(fence)},}}\s*$", lines[j]):
            j += 1
        code = [ln[len(indent):] if ln.startswith(indent) else ln.lstrip() for ln in lines[i + 1:j]]
        yield i + 2, [lang] + rest.split(), "\n".join(code) + "\n"
        i = j + 1


def snippets():
    """(document, first line, code, is_fragment) of every ```c block."""
    out = []
    for doc in documents():
        for line, info, code in blocks(doc):
            if info[0] == "c":
                out.append((doc.relative_to(REPO).as_posix(), line, code, "fragment" in info[1:]))
    return out


def translation_unit(doc, line, code):
    """(C source, extra pkg-config packages) for one snippet."""
    hoisted, body, pkgs = [], [], set()
    for ln in code.split("\n"):
        inc = re.match(r"\s*#\s*include\s*[<\"]([^>\"]+)", ln)
        if inc:
            hoisted.append(ln)
            pkgs |= {p for prefix, p in PKG.items() if inc.group(1).startswith(prefix)}
            body.append("")   # keeps the #line numbering
        else:
            body.append(ln)
    headers = sorted((REPO / "lib/include/vd").glob("*.h")) + sorted((REPO / "port/include/vd_port").glob("*.h"))
    src = ["#define VD_NO_DEPRECATED 1", "#include <stdio.h>", "#include <string.h>"]
    src += [f'#include "{h.parent.name}/{h.name}"' for h in headers]
    src += [f'#include "{h.name}"' for h in sorted((REPO / "models").glob("*_vdm.h"))]
    src += hoisted + [PRELUDE]
    text = "\n".join(body)
    if FUNCTION_DEF.search(text):
        src += [f'#line {line} "{doc}"', text]
    else:
        src += ["int snippet(int argc, char **argv)", "{", "    (void)argc; (void)argv;",
                f'#line {line} "{doc}"', text, "    return 0;", "}"]
    return "\n".join(src) + "\n", sorted(pkgs)


def compile_c(src, pkgs, tmp_path):
    """(returncode, messages) of compiling one translation unit; skips without a compiler or package."""
    cc = os.environ.get("CC", "cc")
    if not shutil.which(cc):
        pytest.skip(f"no C compiler {cc!r}")
    flags = []
    for pkg in pkgs:
        p = subprocess.run(["pkg-config", "--cflags", pkg], capture_output=True, text=True) \
            if shutil.which("pkg-config") else None
        if p is None or p.returncode != 0:
            pytest.skip(f"{pkg} not found by pkg-config (the snippet needs its headers)")
        flags += p.stdout.split()
    f = tmp_path / "snippet.c"
    f.write_text(src)
    cmd = [cc, "-std=c99", "-Wall", "-Wextra", "-Werror", "-Wno-unused-function", "-Wno-unused-parameter",
           "-fsyntax-only", "-I", str(REPO / "lib/include"), "-I", str(REPO / "port/include"),
           "-I", str(REPO / "models"), "-I", str(REPO / "tools/firmware"), *flags, str(f)]
    p = subprocess.run(cmd, capture_output=True, text=True, cwd=REPO)
    return p.returncode, p.stderr


SNIPPETS = snippets()


def test_snippets_are_found():
    docs = {d for d, _, _, _ in SNIPPETS}
    assert "README.md" in docs and "docs/porting.md" in docs, docs
    whole = [s for s in SNIPPETS if not s[3]]
    assert len(whole) >= 5 and len(whole) > 2 * (len(SNIPPETS) - len(whole)), \
        "```c fragment is for the exception, not the rule"


@pytest.mark.parametrize("doc,line,code,fragment", SNIPPETS, ids=[f"{d}:{n}" for d, n, _, _ in SNIPPETS])
def test_snippet_compiles(doc, line, code, fragment, tmp_path):
    if fragment:
        pytest.skip("```c fragment: deliberately not complete C")
    src, pkgs = translation_unit(doc, line, code)
    rc, err = compile_c(src, pkgs, tmp_path)
    assert rc == 0, f"the C snippet at {doc}:{line} does not compile:\n{err}"


def test_compile_catches_a_wrong_call(tmp_path):
    """The README's old example (workspace_size with 2 arguments, the 0.1 signature) must fail."""
    src, pkgs = translation_unit("README.md", 1, "size_t bytes;\nvd_detector_workspace_size(&cfg, &bytes);\n")
    rc, err = compile_c(src, pkgs, tmp_path)
    assert rc != 0 and 'README.md:2' in err, err
    src, pkgs = translation_unit("x.md", 1, "undeclared_function(&det);\n")
    assert compile_c(src, pkgs, tmp_path)[0] != 0
    src, pkgs = translation_unit("x.md", 1, "static int f(unsigned u)\n{\n    return u < -1;\n}\n")
    rc, err = compile_c(src, pkgs, tmp_path)   # file scope; -Wextra's sign-compare is an error under -Werror
    assert rc != 0 and "x.md:3" in err and "sign-compare" in err, err


def test_blocks_parser(tmp_path):
    md = tmp_path / "x.md"
    md.write_text("text\n```c\nint a;\n```\n\n   ```sh\n   echo '```c'\n   ```\n- item\n\n  ```c fragment\n  x = ...;\n  ```\n")
    got = list(blocks(md))
    assert got == [(3, ["c"], "int a;\n"), (7, ["sh"], "echo '```c'\n"), (12, ["c", "fragment"], "x = ...;\n")], got
