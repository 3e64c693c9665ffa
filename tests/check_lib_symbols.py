#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""The names vd's libraries define (issue 37 item 5; the rule is in docs/architecture.md, "Names").

- libvd.a: every global symbol it defines (`nm -g --defined-only`) is a function declared in a public
  header (lib/include/vd/*.h). The build prelinks the archive and makes its hidden symbols local (the
  functions that files of lib/src share, named `vd__*`, and CMSIS-NN's, compiled under that prefix), so
  none of them shows. With --allow-internal (an archive built with VD_PRELINK=OFF) `vd__*` names are
  allowed too; nothing else is.
- libvd.so (when given): the symbols it exports (`nm -D --defined-only`) are exactly the functions the
  public headers declare: none missing (a declaration without VD_API would be hidden), none more (no
  `vd__` name, no helper that forgot `static`).

The public functions are read from the headers: every `vd_name(` outside comments, except function
pointer typedefs and `static inline` definitions. Before reading the real headers and libraries the
check runs on a fake header and fake symbol lists with one violation of each kind, and fails unless it
reports exactly those: a pattern that stopped matching cannot pass silently.

usage: check_lib_symbols.py [--allow-internal] HEADER_DIR NM LIBVD_A [LIBVD_SO]
"""
import re
import subprocess
import sys
from pathlib import Path

INTERNAL = "vd__"
# Symbols the linker itself defines in a shared object on some toolchains (not vd's code).
LINKER = {"_init", "_fini", "_edata", "_end", "__bss_start", "_etext", "__end__"}


def declared(text):
    """Names of the functions a header text declares (comments, typedefs and static inlines dropped)."""
    text = re.sub(r"#\s*ifdef\s+__cplusplus.*?#\s*endif", " ", text, flags=re.S)   # extern "C" { / }
    text = re.sub(r"/\*.*?\*/", " ", text, flags=re.S)
    text = re.sub(r"//[^\n]*", " ", text)
    text = re.sub(r"^\s*#[^\n]*(\\\n[^\n]*)*", " ", text, flags=re.M)   # preprocessor lines
    names = set()
    # Top-level statements: split at ';' and at the braces of inline bodies / struct bodies.
    depth, stmt = 0, []
    for ch in text:
        if ch == "{":
            if depth == 0:
                names |= _decl_names("".join(stmt), body=True)
                stmt = []
            depth += 1
        elif ch == "}":
            depth -= 1
        elif depth == 0:
            if ch == ";":
                names |= _decl_names("".join(stmt), body=False)
                stmt = []
            else:
                stmt.append(ch)
    return names


def _decl_names(stmt, body):
    stmt = " ".join(stmt.split())
    if body or not stmt or re.match(r"(typedef|static|extern\s+\"C\")\b", stmt):
        return set()   # a definition (static inline), a typedef, or extern "C" {
    m = re.search(r"\b(vd_\w+)\s*\(", stmt)
    if m is None:
        m = re.match(r"(?:VD_API\s+)?(?:extern\s+)?[\w\s\*]*?\b(vd_\w+)\s*(\[[^\]]*\])?\s*$", stmt)
        if m is None or not stmt.startswith(("VD_API", "extern")):
            return set()   # a struct/enum tail such as "} vd_x_t" is not a symbol
    return {m.group(1)}


def nm_defined(nm, lib, dynamic=False):
    """Global symbols a library defines: name -> nm type letter."""
    args = [nm, "-D" if dynamic else "-g", "--defined-only", str(lib)]
    out = subprocess.run(args, check=True, capture_output=True, text=True).stdout
    syms = {}
    for line in out.splitlines():
        parts = line.split()
        if len(parts) >= 3 and len(parts[-2]) == 1:
            syms[parts[-1]] = parts[-2]
    return syms


def static_problems(syms, public, allow_internal=False):
    why = f"neither declared in lib/include/vd nor {INTERNAL}-prefixed" if allow_internal else \
        "not declared in lib/include/vd"
    return sorted(f"{s} ({t}): {why}" for s, t in syms.items()
                  if s not in public and not (allow_internal and s.startswith(INTERNAL)))


def shared_problems(syms, public):
    bad = [f"{s} ({t}): exported but not declared in lib/include/vd" for s, t in syms.items()
           if s not in public and s not in LINKER]
    bad += [f"{s}: declared in lib/include/vd but not exported (VD_API missing?)" for s in public
            if s not in syms]
    return sorted(bad)


def self_test():
    fake = """
#ifdef __cplusplus
extern "C" {
#endif
// vd_comment_only(void) in a comment
/* vd_block_comment(int) */
#define VD_X(a) vd_macro_call(a)
typedef vd_status_t (*vd_fn_t)(void *user);
typedef struct vd_s { int a; } vd_s_t;
static inline int vd_inline_helper(int a) { return a; }
VD_API vd_status_t vd_one(const vd_s_t *s,
                          int b);
VD_API const char *vd_two(void);
#ifdef __cplusplus
}
#endif
"""
    got = declared(fake)
    if got != {"vd_one", "vd_two"}:
        return f"header parser: expected vd_one, vd_two, got {sorted(got)}"
    fake_a = {"vd_one": "T", "vd__helper": "T", "vd_helper": "T", "arm_nn_x": "T"}
    st = static_problems(fake_a, got, allow_internal=True)
    if len(st) != 2 or not st[0].startswith("arm_nn_x") or not st[1].startswith("vd_helper"):
        return f"libvd.a check (--allow-internal): expected arm_nn_x and vd_helper, got {st}"
    st = static_problems(fake_a, got)
    if [x.split()[0] for x in st] != ["arm_nn_x", "vd__helper", "vd_helper"]:
        return f"libvd.a check: expected arm_nn_x, vd__helper and vd_helper, got {st}"
    sh = shared_problems({"vd_one": "T", "vd__helper": "T", "_init": "T"}, got)
    if len(sh) != 2 or not sh[0].startswith("vd__helper") or not sh[1].startswith("vd_two"):
        return f"libvd.so check: expected vd__helper (exported) and vd_two (missing), got {sh}"
    return None


def main(argv):
    allow_internal = "--allow-internal" in argv[1:]
    argv = [a for a in argv if a != "--allow-internal"]
    if len(argv) not in (4, 5):
        print(__doc__.strip().splitlines()[-1])
        return 2
    err = self_test()
    if err:
        print(f"check_lib_symbols.py does not catch its own fake violations: {err}")
        return 2
    headers, nm, lib_a = Path(argv[1]), argv[2] or "nm", argv[3]
    public = set()
    for h in sorted(headers.glob("*.h")):
        public |= declared(h.read_text())
    if not public:
        print(f"no public functions found in {headers}/*.h")
        return 2
    rc = 0
    syms = nm_defined(nm, lib_a)
    bad = static_problems(syms, public, allow_internal)
    if bad:
        print(f"{lib_a} defines names outside the rule:\n  " + "\n  ".join(bad))
        rc = 1
    internal = sum(1 for s in syms if s.startswith(INTERNAL))
    summary = [f"{Path(lib_a).name}: {len(syms) - internal} public + {internal} {INTERNAL} symbols"]
    if len(argv) == 5:
        so = nm_defined(nm, argv[4], dynamic=True)
        bad = shared_problems(so, public)
        if bad:
            print(f"{argv[4]} exports the wrong names:\n  " + "\n  ".join(bad))
            rc = 1
        summary.append(f"{Path(argv[4]).name}: {len(so)} exported")
    if rc == 0:
        print(f"lib symbols: {len(public)} public functions; " + ", ".join(summary) + ": OK")
    return rc


if __name__ == "__main__":
    sys.exit(main(sys.argv))
