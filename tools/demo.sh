#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The main job on an embedded default input: installs what it needs and builds, then
#  1. synthesises a rotating-selfie capture (rendered head under a sun and sky, IMU with
#     noise and bias, ground truth beside it),
#  2. fits face geometry, reflectance, sun, sky and cameras to it (SunStage, fast solver),
#  3. relights the fitted face under a new sun, and exports it as a Draco-compressed glTF
#     when the export command is built,
#  4. replays a synthetic turn through the IMU orientation stage,
# and prints where every output is. Usage: tools/demo.sh [OUT_DIR]   (default out/demo)
set -euo pipefail
cd "$(dirname "$0")/.."

tools/install-deps.sh full
out=${1:-out/demo}
mkdir -p "$out"
if [ ! -f build/build.ninja ]; then
    meson setup build -Dbuildtype=release >"$out/build-setup.log" 2>&1 || { cat "$out/build-setup.log"; exit 1; }
fi
ninja -C build >/dev/null
sp=build/tools/sunprobe
mkdir -p "$out"
rm -rf "$out/selfie.spcap" "$out/selfie.truth" "$out/face" "$out/turn.spcap"

echo "== 1. synthesise a rotating selfie (12 s, 30 fps, IMU 200 Hz, ground truth)"
$sp synth selfie -o "$out/selfie.spcap" --truth "$out/selfie.truth" --contact-sheet "$out/contact-sheet.png"
$sp info "$out/selfie.spcap" | tee "$out/selfie-info.txt"
echo "== 2. fit (SunStage, fast solver; error against run time in fit-report.csv/.svg)"
$sp fit "$out/selfie.spcap" -o "$out/face" --report "$out/fit-report"
echo "== 3. relight under a new sun"
$sp relight "$out/face" --sun 120,25 -o "$out/relit.png"
have_export=0
if $sp export --help >/dev/null 2>&1; then
    $sp export "$out/face" -o "$out/face.glb"
    have_export=1
fi
echo "== 4. IMU orientation on a synthetic turn"
$sp synth turn -o "$out/turn.spcap" --width 320 --height 240
$sp replay "$out/turn.spcap" --stage orientation -o "$out/orientation.csv"

echo
echo "outputs:"
echo "  capture + ground truth:   $out/selfie.spcap, $out/selfie.truth/"
echo "  contact sheet:            $out/contact-sheet.png"
echo "  fitted face directory:    $out/face/ (manifest.json, mesh, UV maps, lighting, cameras)"
echo "  error against run time:   $out/fit-report.csv, $out/fit-report.svg"
echo "  relit render:             $out/relit.png"
[ $have_export = 1 ] && echo "  glTF asset (Draco):       $out/face.glb"
echo "  orientation per frame:    $out/orientation.csv (with error against ground truth)"
