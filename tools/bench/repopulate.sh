#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Insertion from a collection against the truth (repopulate_score.py): synth street seeds 1-5, sunny and
# overcast. Each scene's collection is the cut-outs of seed S+10 of both kinds together (so the choice of
# sky is tested too). Frames 100, 200, 300: (A) --probe --private, (B) one image alone, the probe's
# segmentation boxes given as --box, three people at random points, the sun from the image's shadows;
# (C) as (A) but from the other sky's cut-outs only, the lighting match switched off (--min-match -1).
# Then the path-traced street (../shared/captures/street-sunny-dev1), imported and probed, when present.
# Usage: tools/bench/repopulate.sh BUILD_DIR SCRATCH_DIR
set -euo pipefail
build=$1
dir=$2/repopulate
sp=$build/tools/sunprobe
score=$(dirname "$0")/repopulate_score.py
mkdir -p "$dir"
cam=386.2741699796952,160,120,15 # synth street's default camera
capture() { # NAME SEED [--overcast]: synth, probe, frames
    local c=$dir/$1
    if [ ! -d "$c.probe" ]; then
        "$sp" synth street --seed "$2" ${3:-} -o "$c.spcap" >/dev/null
        "$sp" probe "$c.spcap" -o "$c.probe" -q -f
        "$sp" export-video "$c.spcap" -o "$c.frames" --every 100 >/dev/null
    fi
}
collection() { # SEED: the cut-outs of seed SEED+10, sunny and overcast, names prefixed by the kind
    local col=$dir/coll$1 k
    [ -d "$col" ] && return
    mkdir -p "$col"
    for k in sunny overcast; do
        capture "src-$k$1" $(($1 + 10)) $([ $k = overcast ] && echo --overcast)
        "$sp" cutouts "$dir/src-$k$1.spcap" --probe "$dir/src-$k$1.probe" -o "$dir/cut-$k$1" --camera $cam -f -q
        for f in "$dir/cut-$k$1"/*.png; do cp "$f" "$col/$k-$(basename "$f")"; done
        for f in "$dir/cut-$k$1"/*.json; do
            sed "s/\"image\":\"/\"image\":\"$k-/" "$f" >"$col/$k-$(basename "$f")"
        done
    done
}
for kind in sunny overcast; do
    a=() b=() c=()
    for seed in 1 2 3 4 5; do
        capture "$kind$seed" "$seed" $([ $kind = overcast ] && echo --overcast)
        collection "$seed"
        for f in 100 200 300; do
            frame=$(printf '%s/%s%d.frames/frame_%06d.png' "$dir" $kind "$seed" $f)
            out=$dir/out-$kind$seed-$f
            truth=$dir/$kind$seed.truth.json,$frame,$dir/$kind$seed.background.png,$dir/coll$seed
            "$sp" repopulate "$frame" --collection "$dir/coll$seed" --probe "$dir/$kind$seed.probe" --private \
                --camera $cam --seed "$seed" -o "$out-a.png" -q || continue
            a+=("$truth,$out-a.json")
            other=$([ $kind = sunny ] && echo overcast || echo sunny)
            "$sp" repopulate "$frame" --collection "$dir/cut-$other$seed" --probe "$dir/$kind$seed.probe" --private \
                --camera $cam --seed "$seed" --min-match -1 -o "$out-c.png" -q &&
                c+=("$dir/$kind$seed.truth.json,$frame,$dir/$kind$seed.background.png,$dir/cut-$other$seed,$out-c.json")
            boxes=$(python3 -c 'import json,sys; print(" ".join("--box %d,%d,%d,%d" % tuple(b) for b in json.load(open(sys.argv[1]))["found"]))' "$out-a.json")
            # shellcheck disable=SC2086
            "$sp" repopulate "$frame" --collection "$dir/coll$seed" --detector none $boxes --count 3 --camera $cam \
                --seed "$seed" -o "$out-b.png" -q && b+=("$truth,$out-b.json")
        done
    done
    echo "-- synth street, $kind, (A) --probe --private"
    python3 "$score" "$kind A" synth "${a[@]}"
    echo "-- synth street, $kind, (B) one image, boxes given, sun from its shadows"
    python3 "$score" "$kind B" synth "${b[@]}"
    echo "-- synth street, $kind, (C) as (A) from the other sky's cut-outs only (--min-match -1): the baseline"
    python3 "$score" "$kind C" synth "${c[@]}"
done
shared=${SP_SHARED_DIR:-$(dirname "$0")/../../../shared}/captures/street-sunny-dev1
if [ ! -d "$shared" ]; then
    echo "-- path-traced street: $shared absent, skipped"
    exit 0
fi
st=$dir/street
stcam=622.2222222222222,320,180,20 # from its meta.json
if [ ! -d "$st.cut" ]; then
    "$sp" import "$shared/frames" -o "$st.spcap" --fps 10 --kind static -q -f
    "$sp" probe "$st.spcap" -o "$st.probe" -q -f
    "$sp" cutouts "$st.spcap" --probe "$st.probe" -o "$st.cut" --camera $stcam -f -q
fi
a=() b=()
for f in $(seq 20 30 290); do
    n=$(printf '%05d' "$f")
    frame=$st-$n.png
    [ -f "$frame" ] || ffmpeg -loglevel error -y -i "$shared/frames/$n.jpg" "$frame"
    truth=$shared/meta.json,$frame,$shared/gt/clean_plate.png,$st.cut
    "$sp" repopulate "$frame" --collection "$st.cut" --probe "$st.probe" --private --camera $stcam -o "$st-a-$n.png" \
        -q && a+=("$truth,$st-a-$n.json")
    boxes=$(awk -F, -v f="$f" '$1 == f && $16 > 200 && $26 == 0 && $30 == 0 { printf "--box %d,%d,%d,%d ", $18, $19, $20 - $18 + 1, $21 - $19 + 1 }' \
        "$shared/gt/people.csv")
    # the collection's cut-outs say overcast (the probe learned no shadow model here): --min-match -1 lets them in
    # shellcheck disable=SC2086
    "$sp" repopulate "$frame" --collection "$st.cut" --detector none $boxes --count 3 --camera $stcam --min-match -1 \
        -o "$st-b-$n.png" -q && b+=("$truth,$st-b-$n.json")
done
echo "-- path-traced street, (A) --probe --private (its own people as the collection)"
python3 "$score" "street A" street "${a[@]}"
echo "-- path-traced street, (B) one image, gt/people.csv boxes, sun from its shadows, --min-match -1"
python3 "$score" "street B" street "${b[@]}"
