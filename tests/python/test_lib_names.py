# SPDX-License-Identifier: MIT
"""The header predicts the name (docs/architecture.md, "Names"; issue 37 item 5).

Every name a public header `lib/include/vd/x.h` defines (functions, typedefs, struct and enum tags, enum
constants, macros) starts with `vd_x` / `VD_X`, or with the singular of a plural stem
(`components.h` -> `vd_component_t`, `windows.h` -> `vd_window_band_t`), or matches the header's entry
in EXCEPTIONS below, which docs/architecture.md lists with the same reasons. `deprecated.h` holds the
0.1 names by design: each of its macros must alias a name that some other header defines.

An exception that no longer matches any name fails the test (the table cannot go stale), and the
checks run first on a fake header with one violation of each kind.
"""
import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
HEADERS = REPO / "lib" / "include" / "vd"

# header -> (pattern of the other names it may define, why)
EXCEPTIONS = {
    "config.h": (r"VD_(API|ASSERT|MAX_DIM|WORKSPACE_ALIGN)$", "library-wide settings"),
    "vd.h": (r"VD_VERSION_(MAJOR|MINOR|PATCH)$", "the library's version"),
    "status.h": (r"VD_(OK|ERR_\w+)$", "the codes of vd_status_t"),
    "image.h": (r"(vd_frame(_\w+)?|vd_view_u(8|16)(_\w+)?|vd_pixfmt(_t)?|VD_PIX_U(8|16))$",
                "named after the type they take: frames and views"),
    "rect.h": (r"vd_point(_t)?$", "the other geometry primitive, beside vd_rect_t"),
    "temporal.h": (r"(vd_track(_\w+)?|VD_TRACK_\w+)$", "a track, the object temporal analysis keeps"),
}


def strip(text):
    text = re.sub(r"/\*.*?\*/", " ", text, flags=re.S)
    return re.sub(r"//[^\n]*", " ", text)


def defined_names(text):
    """Names a header text defines (not the ones it only uses)."""
    t = strip(text)
    names = set(re.findall(r"^\s*#\s*define\s+(\w+)", t, re.M))
    body = re.sub(r"^\s*#[^\n]*(\\\n[^\n]*)*", " ", t, flags=re.M)           # preprocessor lines out
    names |= set(re.findall(r"\b(?:struct|enum)\s+(vd_\w+)\s*\{", body))      # tags
    names |= set(re.findall(r"\}\s*(vd_\w+)\s*;", body))                      # typedef struct {...} x;
    names |= set(re.findall(r"\btypedef\s+[^;{}()]*?\b(vd_\w+)\s*;", body))   # typedef int x;
    names |= set(re.findall(r"\btypedef\s+[^;{}]*?\(\s*\*\s*(vd_\w+)\s*\)", body))   # function pointers
    for enum in re.findall(r"\benum\b[^{;]*\{([^}]*)\}", body):
        names |= set(re.findall(r"\b(VD_\w+)\s*(?:=[^,]*)?(?:,|$)", enum))
    # function declarations / inline definitions: a name followed by '(' at top level that is not a call
    # inside a body and not a function pointer typedef
    depth, top = 0, []
    for ch in body:
        if ch == "{":
            depth += 1
            top.append(" ")
        elif ch == "}":
            depth -= 1
        elif depth == 0:
            top.append(ch)
    for stmt in "".join(top).split(";"):
        if re.match(r"\s*typedef\b", stmt):
            continue
        m = re.search(r"\b(vd_\w+)\s*\(", stmt)
        if m:
            names.add(m.group(1))
    return names


def violations(header, names, exceptions):
    stem = header[:-2]
    prefixes = {stem} | ({stem[:-1]} if stem.endswith("s") else set())
    extra = exceptions.get(header, (None, ""))[0]
    bad = []
    for n in sorted(names):
        if any(n.lower() == "vd_" + p or n.lower().startswith("vd_" + p + "_") for p in prefixes):
            continue
        if extra and re.match(extra, n):
            continue
        bad.append(n)
    return bad


def unused_exceptions(all_names, exceptions):
    return sorted(h for h, (pat, _why) in exceptions.items()
                  if not any(re.match(pat, n) for n in all_names.get(h, ())))


def deprecated_problems(text, current):
    """deprecated.h: each macro (outside its include guard / switches) aliases a current name."""
    bad = []
    for name, target in re.findall(r"^\s*#\s*define\s+(\w+)[ \t]+(\w+)\s*$", strip(text), re.M):
        if target not in current:
            bad.append(f"{name} -> {target}: not a name of the current headers")
    return bad


def test_checks_catch_fake_violations():
    fake = """
    #ifndef VD_WIDGET_H
    #define VD_WIDGET_H
    // vd_comment_only(void) is not a name
    #define VD_WIDGET_MAX 4
    #define VD_GADGET_MAX 5
    typedef struct vd_widget { int a; } vd_widget_t;
    typedef struct { int b; } vd_gadget_t;
    typedef enum { VD_WIDGET_A = 0, VD_GIZMO_B } vd_widget_kind_t;
    typedef int (*vd_widget_fn)(void *user);
    typedef int (*vd_gizmo_fn)(void *user);
    VD_API int vd_widget_run(const vd_widget_t *w);
    VD_API int vd_gizmo_run(const vd_widget_t *w);
    static inline int vd_widgets_helper(int a) { return vd_gizmo_call(a); }
    #endif
    """
    names = defined_names(fake)
    assert "vd_comment_only" not in names and "vd_gizmo_call" not in names
    assert violations("widget.h", names, {}) == ["VD_GADGET_MAX", "VD_GIZMO_B", "vd_gadget_t", "vd_gizmo_fn",
                                                 "vd_gizmo_run", "vd_widgets_helper"]
    assert violations("widgets.h", names, {}) == ["VD_GADGET_MAX", "VD_GIZMO_B", "vd_gadget_t", "vd_gizmo_fn",
                                                  "vd_gizmo_run"]   # the singular of a plural stem is allowed
    assert violations("widget.h", names, {"widget.h": (r"(vd|VD)_(gadget|GADGET)_?\w*$", "")}) == \
        ["VD_GIZMO_B", "vd_gizmo_fn", "vd_gizmo_run", "vd_widgets_helper"]
    assert unused_exceptions({"widget.h": names}, {"widget.h": (r"vd_nothing$", ""),
                                                   "other.h": (r"VD_GADGET_MAX$", "")}) == ["other.h", "widget.h"]
    assert deprecated_problems("#define vd_old_run vd_widget_run\n#define VD_OLD VD_GONE\n", names) == \
        ["VD_OLD -> VD_GONE: not a name of the current headers"]


def public_names():
    return {h.name: defined_names(h.read_text()) for h in sorted(HEADERS.glob("*.h"))}


def test_public_names_follow_their_header():
    per_header = public_names()
    assert len(per_header) > 10
    bad = {h: v for h, names in per_header.items() if h != "deprecated.h"
           for v in [violations(h, names, EXCEPTIONS)] if v}
    assert not bad, f"names whose prefix does not name their header (rename, or add an exception with a reason): {bad}"
    assert not unused_exceptions(per_header, EXCEPTIONS)


def test_deprecated_names_alias_current_ones():
    per_header = public_names()
    current = set().union(*(n for h, n in per_header.items() if h != "deprecated.h"))
    # field names (a struct member renamed) are aliased too: read every identifier of the headers
    current |= set(re.findall(r"\b\w+\b", "".join(strip(h.read_text()) for h in HEADERS.glob("*.h")
                                                  if h.name != "deprecated.h")))
    text = (HEADERS / "deprecated.h").read_text()
    assert re.search(r"#\s*define\s+\w+\s+\w+", text)
    assert not deprecated_problems(text, current)


def test_exceptions_are_documented():
    arch = (REPO / "docs" / "architecture.md").read_text()
    for h in EXCEPTIONS:
        assert f"`{h}`" in arch, f"docs/architecture.md does not name the exception of {h}"
