#!/bin/sh
# SPDX-License-Identifier: MIT
# meson install into a DESTDIR, then a user's program (use_libsunprobe.c) built with nothing but the
# installed headers, libsunprobe and its pkg-config file reads a capture and renders a fitted face; the
# man page and bash completion are installed too, and the installed command runs against the installed library.
# Usage: test_install.sh BUILD_ROOT SUNPROBE SOURCE_DIR
set -u
build=$1; sp=$2; src=$3
tmp=$(mktemp -d "${TMPDIR:-/tmp}/sp-install.XXXXXX") || exit 1
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
command -v pkg-config >/dev/null || { echo "SKIP: no pkg-config"; exit 77; }
meson install -C "$build" --destdir "$tmp/root" --no-rebuild --quiet >"$tmp/install.log" 2>&1 ||
    { cat "$tmp/install.log"; fail "meson install"; }
pc=$(find "$tmp/root" -name sunprobe.pc | head -1)
[ -n "$pc" ] || fail "no sunprobe.pc installed"
prefix=$(PKG_CONFIG_PATH=$(dirname "$pc") pkg-config --variable=prefix sunprobe)
flags=$(PKG_CONFIG_PATH=$(dirname "$pc") pkg-config --define-variable=prefix="$tmp/root$prefix" --cflags --libs sunprobe) ||
    fail "pkg-config sunprobe"
libdir=$(PKG_CONFIG_PATH=$(dirname "$pc") pkg-config --define-variable=prefix="$tmp/root$prefix" --variable=libdir sunprobe)
ls "$libdir"/libsunprobe.so.0 >/dev/null 2>&1 || fail "no libsunprobe.so.0 (soname) in $libdir"
[ -f "$tmp/root$prefix/include/sunprobe/sp_sunstage.h" ] || fail "headers not installed"
find "$tmp/root" -path '*man1/sunprobe.1' | grep -q . || echo "note: no man page (help2man not found at configure time)"
find "$tmp/root" -path '*bash-completion/completions/sunprobe' | grep -q . || fail "no bash completion installed"
# shellcheck disable=SC2086 # flags are words
cc -std=c11 -Wall -Werror -o "$tmp/use" "$src/tests/install/use_libsunprobe.c" $flags || fail "building against the install"
"$sp" synth selfie -o "$tmp/s.spcap" --face generic --width 96 --height 96 --turn-seconds 3 --still 0.5 --fps 10 \
    --supersample 1 --relit 0 --novel 0 --no-truth >/dev/null 2>&1 || fail "synth selfie"
"$sp" fit "$tmp/s.spcap" -o "$tmp/face" --face generic --keyframes 6 --heldout 1 --no-progress >/dev/null 2>&1 ||
    fail "fit"
LD_LIBRARY_PATH=$libdir "$tmp/use" "$tmp/s.spcap" "$tmp/face" || fail "the program against the installed library"
# it ran the installed library, not the build tree's
LD_LIBRARY_PATH=$libdir ldd "$tmp/use" | grep -q "$tmp/root" || fail "not linked to the installed libsunprobe"
# the installed command runs from the DESTDIR with no LD_LIBRARY_PATH (meson test sets one to the build
# tree): it finds the installed libsunprobe beside itself (an $ORIGIN run path), unless linked statically
cmd="$tmp/root$prefix/bin/sunprobe"
env -u LD_LIBRARY_PATH "$cmd" --version >"$tmp/version.txt" 2>&1 || { cat "$tmp/version.txt"; fail "the installed sunprobe --version"; }
grep -q "^sunprobe " "$tmp/version.txt" || fail "the installed sunprobe --version says: $(head -1 "$tmp/version.txt")"
loaded=$(env -u LD_LIBRARY_PATH ldd "$cmd" | grep libsunprobe)
[ -z "$loaded" ] || echo "$loaded" | grep -q "$tmp/root" || fail "the installed sunprobe loads $loaded"
