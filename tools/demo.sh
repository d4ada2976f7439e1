#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The main job on an embedded default input: installs what it needs, builds, generates a
# synthetic turning capture (fake camera + fake IMU), summarises and verifies it, replays it
# through the IMU orientation stage, exports frames, and prints where the outputs are.
set -euo pipefail
cd "$(dirname "$0")/.."

tools/install-deps.sh full
out=${1:-out/demo}
if [ ! -f build/build.ninja ]; then
    meson setup build -Dbuildtype=release >build-setup.log 2>&1 || { cat build-setup.log; exit 1; }
fi
ninja -C build >/dev/null
sp=build/tools/sunprobe
mkdir -p "$out"
rm -f "$out/turn.spcap"

echo "== synthesise a 12 s rotating capture (640x480 YUYV, 30 fps, 200 Hz IMU)"
$sp synth turn -o "$out/turn.spcap"
echo "== info"
$sp info "$out/turn.spcap" | tee "$out/info.txt"
echo "== verify"
$sp verify "$out/turn.spcap"
echo "== replay through the orientation stage"
$sp replay "$out/turn.spcap" --stage orientation -o "$out/orientation.csv"
echo "== export every 15th frame as PNG"
$sp export-video "$out/turn.spcap" -o "$out/frames" --every 15

echo
echo "outputs:"
echo "  capture:             $out/turn.spcap"
echo "  summary:             $out/info.txt"
echo "  per-frame orientation (IMU-fused, with ground-truth error): $out/orientation.csv"
echo "  frames:              $out/frames/"
