#!/bin/sh
# SPDX-License-Identifier: MIT
# Size bars of lib/src (issue 37): no file longer than MAX_FILE lines, no function longer than MAX_FN
# lines (signature to closing brace), so a module stays a set of rooms a reader can hold in mind.
# A function is found the way lib/ writes one: its signature starts in column 0, its body opens with
# "{" alone in column 0 and closes with "}" in column 0 (a brace at the end of a signature line would
# hide a function from the check; lib/ has none). Before reading lib/src the check runs on a small fake
# tree with one violation of each bar and a function of exactly MAX_FN lines, and fails unless it
# reports exactly the two violations: a pattern that stopped matching cannot pass silently.
# usage: check_lib_size.sh LIB_SRC_DIR [MAX_FILE [MAX_FN]]   (defaults 800 and 120)
set -u
dir=$1; max_file=${2:-800}; max_fn=${3:-120}

# One line per violation below $1: "file: N lines" or "file:line: function() N lines".
violations() {
    find "$1" -type f \( -name '*.c' -o -name '*.h' \) | LC_ALL=C sort | while read -r f; do
        n=$(wc -l < "$f")
        if [ "$n" -gt "$max_file" ]; then echo "$f: $n lines (> $max_file)"; fi
    done
    find "$1" -type f \( -name '*.c' -o -name '*.h' \) -exec awk -v max="$max_fn" '
        FNR == 1 { sig = 0; body = 0 }
        !body && /^[A-Za-z_]/ && !/^(typedef|struct|union|enum)([^A-Za-z0-9_]|$)/ && !/;[ \t]*$/ { sig = FNR; text = $0 }
        !body && /^\{[ \t]*$/ && sig > 0 { body = 1; next }
        body && /^\}/ {
            n = FNR - sig + 1
            name = text; sub(/\(.*/, "", name); k = split(name, w, /[ *]+/)
            if (n > max) printf "%s:%d: %s() %d lines (> %d)\n", FILENAME, sig, w[k], n, max
            body = 0; sig = 0
        }' {} +
}

# The fake tree: a file of max_file + 1 lines, a function of max_fn + 1 lines, one of max_fn lines.
tmp=$(mktemp -d) || exit 1
trap 'rm -rf "$tmp"' EXIT
awk -v n="$max_file" 'BEGIN { for (i = 0; i <= n; i++) print "// line" }' > "$tmp/too_long.c"
awk -v n="$max_fn" 'BEGIN {
    print "static int too_long_fn(int a,"; print "                       int b)"; print "{"
    for (i = 0; i < n - 3; i++) print "    a += b;"
    print "}"
    print "int fits(void)"; print "{"
    for (i = 0; i < n - 3; i++) print "    ;"
    print "}"
}' > "$tmp/fns.c"
self=$(violations "$tmp")
if [ "$(printf '%s\n' "$self" | grep -c .)" -ne 2 ] || ! printf '%s\n' "$self" | grep -q 'too_long\.c:' ||
   ! printf '%s\n' "$self" | grep -q 'too_long_fn()'; then
    echo "check_lib_size.sh does not catch its own fake violations (expected too_long.c and too_long_fn(), got):"
    printf '%s\n' "$self"
    exit 2
fi

found=$(violations "$dir")
if [ -n "$found" ]; then
    echo "lib/src size bars broken (files <= $max_file lines, functions <= $max_fn lines):"
    printf '%s\n' "$found"
    exit 1
fi
echo "lib size: files <= $max_file lines, functions <= $max_fn lines: OK (self-test caught its 2 fake violations)"
exit 0
