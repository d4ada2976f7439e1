#!/bin/sh
# SPDX-License-Identifier: MIT
# Blender round trip of the exported face: exports the fixture face (--no-draco: Debian's Blender cannot
# decode Draco), loads it with tools/blender/sunprobe_face.py in headless Blender, checks the import
# against the glTF (blender_check.py: counts, materials, textures, shape keys, sun, camera), renders one
# frame from the glTF camera with Cycles and one with Eevee and requires, against the project's renderer
# (render_mask) from keyframe 0's camera: silhouette IoU >= 0.9 (Cycles) and a mean face luminance within
# a factor of 1.5 (each engine).
# Exit 77 without Blender.
# usage: test_blender.sh SUNPROBE TEST_EXPORT RENDER_MASK BLENDER_TOOLS_DIR
set -u
SUNPROBE=$1 FIXTURE=$2 MASK=$3 TOOLS=$4
HERE=$(cd "$(dirname "$0")" && pwd)
BLENDER=${BLENDER:-blender}
MIN_IOU=0.9 MAX_RATIO=1.5
skip() { echo "SKIP: $*"; exit 77; }
command -v "$BLENDER" >/dev/null 2>&1 || skip "no blender (Debian: apt-get install blender; or set BLENDER)"
TMP=$(mktemp -d) || exit 99
trap 'rm -rf "$TMP"' EXIT
# keyframe 0 as the fit writes it: camera at the origin looking along world +y (z up) at the face
"$FIXTURE" "$SUNPROBE" fixture "$TMP/face" facing || exit 99
# one face: export, Blender, then silhouette and luminance against the project's renderer
check_face() { # NAME FACE_DIR
    name=$1 face=$2 out=$TMP/$1
    mkdir "$out" || exit 99
    echo "== $name"
    "$SUNPROBE" export "$face" -o "$out/face.glb" --no-draco || exit 1
    SUNPROBE_BLENDER_TOOLS=$TOOLS timeout 300 "$BLENDER" -b --factory-startup --python-exit-code 99 \
        --python "$HERE/blender_check.py" -- "$out/face.glb" "$out" 16 >"$out/blender.log" 2>&1
    rc=$?
    grep -E '^(ok|FAIL|blender):' "$out/blender.log"
    if [ $rc -ne 0 ]; then
        [ $rc -eq 99 ] && tail -20 "$out/blender.log"
        echo "FAIL: $name: blender_check.py exited $rc"
        fail=1
        return
    fi
    "$MASK" "$face" "$out/ref.png" >/dev/null || exit 1
    printf 'silhouette: '
    "$MASK" iou "$out/ref.png" "$out/mask.png" "$MIN_IOU" || fail=1
    "$MASK" lum "$face" >"$out/lum.txt" || exit 1
    cat "$out/lum.txt"
    ref=$(sed -n 's/^sunprobe: mean_luminance //p' "$out/lum.txt")
    for engine in Cycles Eevee; do
        key=mean_luminance
        [ $engine = Eevee ] && key=eevee_mean_luminance
        got=$(sed -n "s/^blender: $key //p" "$out/blender.log")
        awk -v r="$ref" -v g="$got" -v m="$MAX_RATIO" -v e=$engine 'BEGIN {
            if (r <= 0 || g <= 0) { print "FAIL: no luminance from " e; exit 1 }
            q = g / r; printf "mean face luminance: %s / sunprobe = %.3f (allowed %.3f..%.3f)\n", e, q, 1 / m, m
            exit (q <= m && q >= 1 / m) ? 0 : 1 }' || fail=1
    done
}
fail=0
check_face fixture "$TMP/face"
# a real fit of the synthetic selfie (its specular clusters and a sun from the side)
"$SUNPROBE" synth selfie -o "$TMP/selfie.spcap" --no-truth >/dev/null || exit 99
"$SUNPROBE" fit "$TMP/selfie.spcap" -o "$TMP/fitted" >/dev/null || exit 1
check_face fit "$TMP/fitted"
exit $fail
