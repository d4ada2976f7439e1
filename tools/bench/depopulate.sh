#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Removal from one image against the true empty street (bench_depopulate.c): synth street seeds 1-5,
# sunny and overcast, 7 frames each; the path-traced street (../shared/captures/street-sunny-dev1,
# its gt/ids as the objects) when present, 20 frames; then one 1280x720 frame timed on one core.
# The sun from each frame's shadows against the truth's: the synth seeds above (sun 30 deg left of the
# view, 40 up), seeds 6-16 under other suns (all round, 15-55 deg up; 6-8 and 9-11 the same suns), and the
# path-traced street with its camera from meta.json.
# Usage: tools/bench/depopulate.sh BUILD_DIR SCRATCH_DIR
set -euo pipefail
build=$1
dir=$2/depopulate
sp=$build/tools/sunprobe
bench=$build/tools/bench/bench_depopulate
mkdir -p "$dir"
synth_camera="--camera 386.2741699796952,160,120,15" # synth street's default: 320x240, 45 deg wide, 15 deg down
scenes() { # KIND SEED [SYNTH OPTIONS] -> the bench's LABEL FRAME BACKGROUND - - arguments
    local kind=$1 seed=$2 cap=$dir/$1$2
    shift 2
    if [ ! -f "$cap.spcap" ]; then
        "$sp" synth street --seed "$seed" $([ "$kind" = overcast ] && echo --overcast) "$@" -o "$cap.spcap" >/dev/null
        "$sp" export-video "$cap.spcap" -o "$cap.frames" >/dev/null
    fi
    for f in 50 100 150 200 250 300 350; do
        printf '%s-%s-%d %s %s - - ' "$kind" "$seed" $f "$(printf '%s.frames/frame_%06d.png' "$cap" $f)" "$cap.background.png"
    done
}
for kind in sunny overcast; do
    args=()
    for seed in 1 2 3 4 5; do read -ra more <<<"$(scenes $kind $seed)"; args+=("${more[@]}"); done
    echo "-- synth street, $kind"
    if [ $kind = sunny ]; then "$bench" $synth_camera --sun -30,40 "${args[@]}"; else "$bench" $synth_camera "${args[@]}"; fi
done
for sun in "6 60 25" "7 -120 55" "8 150 30" "9 60 25" "10 -120 55" "11 150 30" "12 0 45" "13 90 15" "14 -60 35" \
    "15 170 50" "16 -150 20"; do
    read -r seed az el <<<"$sun"
    read -ra args <<<"$(scenes sun$az.$el "$seed" --sun-azimuth "$az" --sun-elevation "$el")"
    echo "-- synth street, seed $seed, sun $az deg from the view, $el up"
    "$bench" $synth_camera --sun "$az,$el" "${args[@]}" | grep '^sun over\|^median.*ours'
done
shared=${SP_SHARED_DIR:-$(dirname "$0")/../../../shared}/captures/street-sunny-dev1
if [ -d "$shared" ]; then
    args=()
    for f in $(seq 5 15 295); do
        n=$(printf '%05d' "$f")
        args+=("street-sunny-$n" "$shared/frames/$n.jpg" "$shared/gt/clean_plate.png" "$shared/gt/ids/$n.png" "$shared/gt/shadows/$n.png")
    done
    echo "-- path-traced street (sunny; objects from gt/ids; sun -132.47 deg from the view, 33.21 up)"
    "$bench" --camera 622.2222222222222,320,180,20 --sun -132.4747,33.2143 "${args[@]}"
else
    echo "-- path-traced street: $shared absent, skipped"
fi
big=$dir/big
if [ ! -f "$big.spcap" ]; then
    "$sp" synth street --seed 2 --width 1280 --height 720 --seconds 12 -o "$big.spcap" >/dev/null
    "$sp" export-video "$big.spcap" -o "$big.frames" >/dev/null
fi
echo "-- 1280x720, one core (45 degrees wide, 15 down, as synth street's camera)"
"$bench" --time "$big.frames/frame_000100.png" "$big.background.png" --camera 1545.0966799187808,640,360,15
