#!/bin/sh
# SPDX-License-Identifier: MIT
# sunprobe export checked by independent tools from npm (tests/export/package.json): the Khronos glTF
# validator (0 errors, 0 warnings) on Draco and plain .glb files, and draco3dgltf decoding the Draco
# geometry back (check_gltf.cjs). Installs the npm packages into NODE_DIR once; exit 77 when node, npm
# or the registry is unavailable. A build without Draco validates the plain files only.
# usage: test_export_node.sh SUNPROBE TEST_EXPORT NODE_DIR
set -u
SUNPROBE=$1 FIXTURE=$2 NODE_DIR=$3
HERE=$(cd "$(dirname "$0")" && pwd)
skip() { echo "SKIP: $*"; exit 77; }
command -v node >/dev/null 2>&1 || skip "node not installed (Debian: apt-get install nodejs npm)"
command -v npm >/dev/null 2>&1 || skip "npm not installed (Debian: apt-get install npm)"
mkdir -p "$NODE_DIR" || exit 99
if [ ! -f "$NODE_DIR/node_modules/gltf-validator/package.json" ] ||
   [ ! -f "$NODE_DIR/node_modules/draco3dgltf/package.json" ] ||
   ! cmp -s "$HERE/package-lock.json" "$NODE_DIR/package-lock.json"; then
    cp "$HERE/package.json" "$HERE/package-lock.json" "$NODE_DIR/" || exit 99
    (cd "$NODE_DIR" && timeout 600 npm ci --no-audit --no-fund --loglevel=error >npm.log 2>&1) ||
        skip "npm ci failed (registry unreachable?); see $NODE_DIR/npm.log"
fi
TMP=$(mktemp -d) || exit 99
trap 'rm -rf "$TMP"' EXIT
"$FIXTURE" "$SUNPROBE" fixture "$TMP/face" || exit 99
"$FIXTURE" "$SUNPROBE" fixture "$TMP/flat" flat || exit 99
"$FIXTURE" "$SUNPROBE" fixture "$TMP/ict" ict || exit 99 # ICT's eyes and mouth as primitives of their own (generic head without its data)
draco=1
"$SUNPROBE" export "$TMP/face" -o "$TMP/x.drc" --format drc >/dev/null 2>&1
[ $? -eq 4 ] && { draco=0; echo "this build has no Draco (-Ddraco): validating --no-draco files only"; }
fail=0
check() { # NAME FACE_DIR [export options]
    name=$1 dir=$2 dglb=-
    shift 2
    if [ $draco = 1 ]; then
        dglb="$TMP/$name-draco.glb"
        "$SUNPROBE" export "$dir" -o "$dglb" --stats "$@" >"$TMP/$name.stats" || { fail=1; return; }
        echo "== $name ($*): $(tr '\n' ' ' <"$TMP/$name.stats")"
    fi
    "$SUNPROBE" export "$dir" -o "$TMP/$name-plain.glb" --no-draco "$@" || { fail=1; return; }
    NODE_PATH="$NODE_DIR/node_modules" node "$HERE/check_gltf.cjs" "$dglb" "$TMP/$name-plain.glb" \
        "${PBITS:-14}" "${UBITS:-12}" || fail=1
}
check face "$TMP/face"
check flat "$TMP/flat"
check ict "$TMP/ict"
check ict-expressions "$TMP/ict" --draco-expressions # every primitive's decoded vertices in their order
PBITS=11 UBITS=10 check coarse "$TMP/face" --position-bits 11 --uv-bits 10 --texture-size 32
check expressions "$TMP/face" --draco-expressions
if "$SUNPROBE" export "$TMP/face" -o "$TMP/j.glb" --jpeg --no-draco >/dev/null 2>&1; then
    check jpeg "$TMP/face" --jpeg=80
fi
exit $fail
