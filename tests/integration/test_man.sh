#!/bin/sh
# SPDX-License-Identifier: MIT
# The man page made at build time holds a section per command that `sunprobe --help` lists, each with
# that command's usage line, and renders without warnings.
# Usage: test_man.sh SUNPROBE [MANPAGE]   (no MANPAGE: help2man was not found at configure time)
sp=$1; page=${2:-}
[ -n "$page" ] || { echo "SKIP: no man page in this build (help2man not found)"; exit 77; }
fails=0
for cmd in $("$sp" --help | sed -n '/^commands:/,/^$/p' | awk 'NR > 1 && NF { print $1 }'); do
    grep -qx ".SS $cmd" "$page" || { echo "FAIL: no section for $cmd"; fails=$((fails + 1)); }
done
grep -q "usage: sunprobe fit CAPTURE" "$page" || { echo "FAIL: fit's usage line missing"; fails=$((fails + 1)); }
if command -v groff >/dev/null 2>&1; then
    warn=$(groff -man -Tutf8 -ww -z "$page" 2>&1)
    [ -z "$warn" ] || { echo "FAIL: groff warns: $warn"; fails=$((fails + 1)); }
fi
[ "$fails" -eq 0 ]
