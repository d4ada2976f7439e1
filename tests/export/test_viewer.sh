#!/bin/sh
# SPDX-License-Identifier: MIT
# The face viewer (tools/viewer, three.js) against the project's renderer: exports the fixture face
# (Draco), renders its silhouette in headless Chromium (viewer_shot.cjs, playwright-core; the page's
# mask mode, flat white on black) and with sp_render (render_mask, coverage >= 0.5) from the same
# cameras, and requires IoU >= 0.95 for each: keyframe 0's camera, and an orbited camera on a
# non-square image with the principal point off centre; the lit page changes when the sun slider
# turns the sun by 180 degrees; and the page's linear mode (sun, image-based light from the .hdr,
# shadows, exposure 1 / lux_per_fit_unit) gives a mean face luminance within a factor of 1.5 of the
# project's renderer (render_mask lum) from keyframe 0; and an expression (jawOpen at 1) changes the lit
# picture, and looks the same from a --draco-expressions file as from the plain one (morph targets
# indexing Draco's decoded vertices). Exit 77 without node/npm/Chromium/Draco or
# when npm cannot install the viewer's packages (tools/viewer/package-lock.json).
# usage: test_viewer.sh SUNPROBE TEST_EXPORT RENDER_MASK VIEWER_DIR NODE_DIR
set -u
SUNPROBE=$1 FIXTURE=$2 MASK=$3 VIEWER=$4 NODE_DIR=$5
HERE=$(cd "$(dirname "$0")" && pwd)
CHROMIUM=${CHROMIUM:-/usr/bin/chromium}
MIN_IOU=0.95 MAX_RATIO=1.5
skip() { echo "SKIP: $*"; exit 77; }
command -v node >/dev/null 2>&1 || skip "node not installed (Debian: apt-get install nodejs npm)"
command -v npm >/dev/null 2>&1 || skip "npm not installed (Debian: apt-get install npm)"
[ -x "$CHROMIUM" ] || skip "no Chromium at $CHROMIUM (Debian: apt-get install chromium; or set CHROMIUM)"
TMP=$(mktemp -d) || exit 99
trap 'rm -rf "$TMP"' EXIT
# keyframe 0 as the fit writes it: camera at the origin looking along world +y (z up) at the face
"$FIXTURE" "$SUNPROBE" fixture "$TMP/face" facing || exit 99
"$SUNPROBE" export "$TMP/face" -o "$TMP/face.drc" --format drc >/dev/null 2>&1
[ $? -eq 4 ] && skip "this build has no Draco (-Ddraco); the viewer test loads a Draco-compressed export"
"$SUNPROBE" export "$TMP/face" -o "$TMP/face.glb" || exit 1
"$SUNPROBE" export "$TMP/face" -o "$TMP/plain.glb" --no-draco --no-env || exit 1
"$SUNPROBE" export "$TMP/face" -o "$TMP/morph.glb" --draco-expressions --no-env || exit 1
grep -q KHR_draco_mesh_compression "$TMP/face.glb" || { echo "FAIL: the export is not Draco-compressed"; exit 1; }
mkdir -p "$NODE_DIR" || exit 99
if [ ! -f "$NODE_DIR/node_modules/three/package.json" ] ||
   [ ! -f "$NODE_DIR/node_modules/playwright-core/package.json" ] ||
   ! cmp -s "$VIEWER/package-lock.json" "$NODE_DIR/package-lock.json"; then
    cp "$VIEWER/package.json" "$VIEWER/package-lock.json" "$NODE_DIR/" || exit 99
    (cd "$NODE_DIR" && timeout 600 npm ci --no-audit --no-fund --loglevel=error >npm.log 2>&1) ||
        skip "npm ci failed (registry unreachable?); see $NODE_DIR/npm.log"
fi
mkdir "$TMP/www" || exit 99
ln -s "$VIEWER/index.html" "$VIEWER/viewer.js" "$NODE_DIR/node_modules" "$TMP/face.glb" "$TMP/face.env.hdr" \
    "$TMP/plain.glb" "$TMP/morph.glb" "$TMP/www/" || exit 99
# name, then render_mask's camera options (none: keyframe 0's camera)
set -- key0 "" orbit "160 120 9 -6 25"
jobs="" lit=""
while [ $# -ge 2 ]; do
    # shellcheck disable=SC2086 # the options are words
    q=$("$MASK" "$TMP/face" "$TMP/$1-ref.png" $2) || exit 1
    w=${q#w=}; w=${w%%&*}; h=${q#*&h=}; h=${h%%&*}
    jobs="$jobs $w $h $TMP/$1-viewer.png glb=face.glb&mode=mask&$q"
    [ "$1" = key0 ] && lit="$w $h $TMP/lit0.png glb=face.glb&env=face.env.hdr&ui=0&$q $w $h $TMP/lit180.png glb=face.glb&env=face.env.hdr&ui=0&az=180&$q $w $h $TMP/linear.png glb=face.glb&env=face.env.hdr&mode=linear&$q"
    [ "$1" = key0 ] && lit="$lit $w $h $TMP/jaw-plain.png glb=plain.glb&ui=0&expr=jawOpen:1&$q"
    [ "$1" = key0 ] && lit="$lit $w $h $TMP/jaw-draco.png glb=morph.glb&ui=0&expr=jawOpen:1&$q"
    [ "$1" = key0 ] && lit="$lit $w $h $TMP/rest-plain.png glb=plain.glb&ui=0&$q"
    echo "$1: $q"
    shift 2
done
# shellcheck disable=SC2086 # no spaces inside the jobs' words
NODE_PATH="$NODE_DIR/node_modules" timeout 400 node "$HERE/viewer_shot.cjs" "$CHROMIUM" "$TMP/www" $jobs $lit || exit 1
fail=0
for name in key0 orbit; do
    printf '%s: ' "$name"
    "$MASK" iou "$TMP/$name-ref.png" "$TMP/$name-viewer.png" "$MIN_IOU" || fail=1
done
# the lit page: turning the sun half way round must change the picture
printf 'lit, sun azimuth 0 vs 180: '
"$MASK" differ "$TMP/lit0.png" "$TMP/lit180.png" 2 || fail=1
# expressions: jawOpen moves the face; the Draco file's morph targets move the same vertices
printf 'jawOpen 1 vs 0: '
"$MASK" differ "$TMP/jaw-plain.png" "$TMP/rest-plain.png" 0.5 || fail=1
printf 'jawOpen 1, Draco vs plain: '
"$MASK" near "$TMP/jaw-draco.png" "$TMP/jaw-plain.png" 0.2 || fail=1
# physical light and exposure: the same view's mean face luminance as the project's renderer
ref=$("$MASK" lum "$TMP/face" | sed -n 's/^sunprobe: mean_luminance //p')
got=$("$MASK" lum-shot "$TMP/linear.png" "$TMP/key0-viewer.png" | sed -n 's/^shot: mean_luminance //p')
awk -v r="$ref" -v g="$got" -v m="$MAX_RATIO" 'BEGIN {
    if (r <= 0 || g <= 0) { print "FAIL: no luminance"; exit 1 }
    q = g / r; printf "mean face luminance: three.js / sunprobe = %.3f (%.4g / %.4g; allowed %.3f..%.3f)\n", q, g, r, 1 / m, m
    exit (q <= m && q >= 1 / m) ? 0 : 1 }' || fail=1
[ -n "${KEEP_VIEWER_SHOTS:-}" ] && cp "$TMP"/*.png "$KEEP_VIEWER_SHOTS"/
exit $fail
