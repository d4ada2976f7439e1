#!/bin/sh
# SPDX-License-Identifier: MIT
# Every C line changed since .clang-format came in is laid out as clang-format lays it out (git clang-format on
# the difference between the commit before that file and the working tree). Code older than the file keeps its
# layout: reformatting 82,000 lines at once would bury their history. Usage: test_clang_format.sh SOURCE_ROOT
cd "$1" || exit 1
command -v git-clang-format >/dev/null 2>&1 || { echo "SKIP: git-clang-format not found (Debian package clang-format)"; exit 77; }
git rev-parse --git-dir >/dev/null 2>&1 || { echo "SKIP: not a git checkout"; exit 77; }
first=$(git log --diff-filter=A --format=%H -- .clang-format | tail -1)
[ -n "$first" ] || { echo "SKIP: .clang-format is not committed yet"; exit 77; }
git rev-parse -q --verify "$first^" >/dev/null || { echo "SKIP: the history before $first is not here (a shallow clone)"; exit 77; }
out=$(git clang-format --diff --extensions c,h,cpp,hpp "$first^" -- . ':!tests/fuzz/corpus' 2>&1)
case $out in
"diff --git"*)
    printf '%s\n' "$out" | head -80
    echo "FAIL: the lines above differ from clang-format's layout (git clang-format $first^ applies it)"
    exit 1 ;;
esac
echo "ok: lines changed since ${first%"${first#???????????}"} follow .clang-format"
