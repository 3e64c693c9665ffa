#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Fresh-machine check: runs the README's two commands in a minimal Debian chroot, so that
# nothing this machine already has installed (compilers, cross C libraries, Python
# packages, a pyenv Python) can make them pass. Issue 11 item 1: the armhf C library was
# only "recommended", this machine happened to have it, and CI passed while a fresh
# machine failed.
#
# What it does, as root (it needs mount and chroot):
#   1. debootstrap --variant=minbase of THIS machine's Debian release (/etc/os-release),
#      from the mirror THIS machine's apt uses (sources.list / sources.list.d), so it
#      works wherever our machines can install packages at all;
#   2. mounts /proc, /sys, /dev (recursive bind) and ../shared (read-only bind) into it,
#      removed again by an EXIT trap;
#   3. puts a clean clone of the repository's HEAD at src/vd inside the chroot (committed state only:
#      uncommitted edits of this tree are NOT tested, unless --worktree) and ../shared
#      at src/shared beside it, the layout the README assumes;
#   4. runs the README's two commands (read from its first ```sh block) one after the
#      other, as root, in src/vd, timing each, and prints one PASS/FAIL line.
#
# Usage: sudo tools/fresh_check.sh [options]
#   --dir DIR          chroot directory (default: tools/.cache/fresh, ignored by git)
#   --keep             keep the chroot afterwards (default: remove it)
#   --worktree         copy the working tree (tracked + untracked, not ignored files)
#                      instead of cloning HEAD
#   --overlay PATH     after cloning, copy PATH (relative to the repository) from the
#                      working tree over the clone; repeatable (to test an uncommitted
#                      fix of e.g. tools/setup.sh without the rest of the working tree)
#   --copy-shared      copy ../shared into the chroot instead of a read-only bind mount
#   --mirror URL       Debian mirror (default: the one this machine's apt uses)
#   --nice N           run the README commands with nice -n N (default 0)
#   --not-before HH:MM wait until this UTC time before the README commands (e.g. to
#                      leave a busy shared machine alone); debootstrap runs at once
#   --log-dir DIR      where logs go (default: tools/.cache/fresh-logs)
set -euo pipefail

repo=$(cd "$(dirname "$0")/.." && pwd)
shared=$(cd "$repo/.." && pwd)/shared
dir="$repo/tools/.cache/fresh"
logdir="$repo/tools/.cache/fresh-logs"
keep=0 worktree=0 copy_shared=0 mirror="" niceness=0 not_before="" overlays=()
while [ $# -gt 0 ]; do
  case $1 in
    --dir) dir=$2; shift ;;
    --keep) keep=1 ;;
    --worktree) worktree=1 ;;
    --overlay) overlays+=("$2"); shift ;;
    --copy-shared) copy_shared=1 ;;
    --mirror) mirror=$2; shift ;;
    --nice) niceness=$2; shift ;;
    --not-before) not_before=$2; shift ;;
    --log-dir) logdir=$2; shift ;;
    -h|--help) sed -n '3,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    *) echo "fresh_check.sh: unknown option $1 (see --help)" >&2; exit 2 ;;
  esac
  shift
done
[ "$(id -u)" = 0 ] || { echo "fresh_check.sh: needs root (mount, chroot): sudo $0 $*" >&2; exit 2; }
[ -d "$shared" ] || { echo "fresh_check.sh: $shared not found (the README expects ../shared beside the clone)" >&2; exit 2; }
mkdir -p "$logdir"
dir=$(mkdir -p "$dir" && cd "$dir" && pwd)
if [ -n "$(ls -A "$dir")" ]; then
  echo "fresh_check.sh: $dir is not empty (a kept chroot?); remove it first: rm -rf --one-file-system $dir" >&2
  exit 2
fi
log="$logdir/fresh_check-$(date -u +%Y%m%dT%H%M%SZ).log"
say() { echo "fresh_check: $*" | tee -a "$log"; }

# The README's two commands, exactly: the non-comment lines of its first ```sh block.
# Reading them (instead of a copy here) keeps this check in sync with what users are told.
mapfile -t cmds < <(awk '/^```sh$/ && !done {inb=1; next} inb && /^```/ {inb=0; done=1} inb' "$repo/README.md" \
  | grep -v '^[[:space:]]*#' | grep -v '^[[:space:]]*$')
if [ "${#cmds[@]}" != 2 ]; then
  echo "fresh_check.sh: expected two commands in README.md's first \`\`\`sh block, found ${#cmds[@]}" >&2
  exit 2
fi

# This machine's release and its apt mirror (deb822 .sources or one-line .list files; only
# the names apt itself reads, so *.disabled files are skipped).
. /etc/os-release
suite=${VERSION_CODENAME:?no VERSION_CODENAME in /etc/os-release}
if [ -z "$mirror" ]; then
  mirror=$(
    { cat /etc/apt/sources.list 2>/dev/null || true
      for f in /etc/apt/sources.list.d/*.list; do if [ -f "$f" ]; then cat "$f"; fi; done
    } | awk -v s="$suite" '$1 == "deb" { for (i = 2; i <= NF; i++) if ($i !~ /^\[/ && $i !~ /=/) { if ($(i+1) == s) { print $i; exit } break } }'
  )
fi
if [ -z "$mirror" ]; then
  mirror=$(for f in /etc/apt/sources.list.d/*.sources; do if [ -f "$f" ]; then cat "$f"; echo; fi; done \
    | awk -v s="$suite" 'BEGIN{RS=""} { u=""; ok=0; deb=0
        n = split($0, L, "\n"); for (i = 1; i <= n; i++) {
          if (L[i] ~ /^Types:.*deb([[:space:]]|$)/) deb=1
          if (L[i] ~ /^URIs:/) { split(L[i], w, /[[:space:]]+/); u=w[2] }
          if (L[i] ~ /^Suites:/) { m = split(L[i], w, /[[:space:]]+/); for (j = 2; j <= m; j++) if (w[j] == s) ok=1 }
        }
        if (deb && ok && u != "") { print u; exit } }')
fi
[ -n "$mirror" ] || { echo "fresh_check.sh: no apt source for $suite found; pass --mirror URL" >&2; exit 2; }

# Cleanup: unmount everything under the chroot (deepest first), then remove it unless --keep.
# rm runs only when nothing is mounted below $dir any more, and with --one-file-system, so a
# failed unmount can never delete the host's /dev or ../shared.
mounted_below() { awk -v d="$dir/" 'index($2 "/", d) == 1 {print $2}' /proc/self/mounts | sort -r; }
cleanup() {
  local m
  for m in $(mounted_below); do umount -R "$m" 2>/dev/null || umount -l "$m" 2>/dev/null || true; done
  if [ -n "$(mounted_below)" ]; then
    echo "fresh_check: still mounted under $dir, NOT removing it:" >&2; mounted_below >&2
  elif [ "$keep" = 0 ]; then
    rm -rf --one-file-system "$dir"
  else
    echo "fresh_check: kept $dir (remove with: rm -rf --one-file-system $dir)" >&2
  fi
}
trap cleanup EXIT

now() { date +%s; }
say "Debian $suite from $mirror into $dir; log $log"
t0=$(now)
command -v debootstrap >/dev/null || { apt-get update -qq && apt-get install -y -qq debootstrap >/dev/null; }
# minbase: essential packages + apt only -- less than any real install, so whatever
# setup.sh forgets to name shows up here.
debootstrap --variant=minbase "$suite" "$dir" "$mirror" >>"$log" 2>&1 \
  || { say "FAIL: debootstrap (see $log)"; exit 1; }
t_boot=$(( $(now) - t0 ))
say "debootstrap: ${t_boot} s"

# The chroot's apt uses the same mirror; debootstrap writes only the release itself, a
# normal install also has its -updates suite (security updates are left out: the point
# here is which packages setup.sh names, not their patch level).
printf 'deb %s %s main\ndeb %s %s-updates main\n' "$mirror" "$suite" "$mirror" "$suite" >"$dir/etc/apt/sources.list"
# Network settings of this machine, not software: name resolution, and the local CA
# certificates (e.g. an HTTPS egress proxy's) so that pip can reach PyPI. They take effect
# when setup.sh installs ca-certificates (a dependency of python3-pip), whose postinst
# runs update-ca-certificates over /usr/local/share/ca-certificates.
cp /etc/resolv.conf "$dir/etc/resolv.conf"
if [ -d /usr/local/share/ca-certificates ]; then
  mkdir -p "$dir/usr/local/share/ca-certificates"
  cp -a /usr/local/share/ca-certificates/. "$dir/usr/local/share/ca-certificates/"
fi
mount -t proc proc "$dir/proc"
mount --rbind /sys "$dir/sys"; mount --make-rslave "$dir/sys"
mount --rbind /dev "$dir/dev"; mount --make-rslave "$dir/dev"   # includes /dev/pts, /dev/shm

# The repository: a clean clone of HEAD (committed state), or the working tree.
mkdir -p "$dir/src"
if [ "$worktree" = 1 ]; then
  mkdir -p "$dir/src/vd"
  # no build trees or caches (ignored files); tracked files deleted in the tree are skipped
  (cd "$repo" && git ls-files -z --cached --others --exclude-standard \
    | tar --null -T - --ignore-failed-read -cf - 2>/dev/null) | tar -xf - -C "$dir/src/vd"
  say "copied the working tree of $repo (tracked + untracked, not ignored)"
else
  git clone -q --no-hardlinks "$repo" "$dir/src/vd"
  say "cloned HEAD $(git -C "$repo" rev-parse --short HEAD) of $repo (committed state only)"
fi
for p in ${overlays[@]+"${overlays[@]}"}; do
  (cd "$repo" && cp -a --parents "$p" "$dir/src/vd/")
  say "overlaid $p from the working tree"
done
# ../shared: read-only bind mount by default -- instant (it is ~170 MB and grows), and it
# proves that the commands never write into the shared data; --copy-shared copies it.
mkdir -p "$dir/src/shared"
if [ "$copy_shared" = 1 ]; then
  cp -a "$shared/." "$dir/src/shared/"
else
  mount --bind "$shared" "$dir/src/shared"
  mount -o remount,bind,ro "$dir/src/shared"
fi

if [ -n "$not_before" ]; then
  target=$(date -u -d "$not_before" +%s)
  if [ "$(now)" -lt "$target" ]; then
    say "waiting until $not_before UTC before the README commands"
    sleep $(( target - $(now) ))
  fi
fi

# Each command runs in a clean environment (nothing of this shell's PATH, pyenv or
# virtualenv leaks in), as root, in the chroot's src/vd, like a user pasting it into a shell.
results=() status=0
for i in 0 1; do
  say "command $((i + 1)): ${cmds[$i]}"
  t0=$(now)
  if chroot "$dir" /usr/bin/env -i HOME=/root LANG=C.UTF-8 TERM=dumb \
      PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
      nice -n "$niceness" /bin/bash -c "cd /src/vd && ${cmds[$i]}" >>"$log" 2>&1; then
    r=PASS
  else
    r=FAIL; status=1
  fi
  d=$(( $(now) - t0 ))
  results+=("command $((i + 1)) $r ${d} s")
  say "command $((i + 1)): $r in ${d} s"
  [ "$r" = PASS ] || tail -n 30 "$log" >&2
done

summary="$([ $status = 0 ] && echo PASS || echo FAIL): Debian $suite minbase chroot; debootstrap ${t_boot} s; ${results[0]}; ${results[1]}; log $log"
say "$summary"
exit $status
