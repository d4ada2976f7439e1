#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# sunprobe retexture from the command line on a probed synthetic street: the ground changes and the
# sky does not; bad input (texture not a PNG, a mask of the wrong size, a damaged probe.json, a missing
# option, an existing output) is refused with the documented exit code, a message naming the file or
# option, and no output.
set -u
SP=$1 MK=$2
. "$(dirname "$0")/cli_lib.sh" retexture
"$SP" synth street -o "$dir/st.spcap" --seconds 20 >/dev/null || { echo "FAIL: synth street"; exit 1; }
"$SP" probe "$dir/st.spcap" -o "$dir/probe" -q >/dev/null || { echo "FAIL: probe"; exit 1; }
"$MK" bricks 64 64 "$dir/tex.png" || { echo "FAIL: make_exemplar"; exit 1; }
O="$dir/out.png"

expect 0 "retexture" "$SP" retexture "$dir/probe" --texture "$dir/tex.png" -o "$O" --metres 2
contains "$dir/out.txt" "ground pixels retextured" "summary"
cmp -s "$O" "$dir/probe/clean_plate.png" && fail "the output is the plate"
expect 1 "existing output" "$SP" retexture "$dir/probe" --texture "$dir/tex.png" -o "$O"
contains "$dir/err.txt" "exists.*--force" "existing output"
expect 0 "--force, a mask" "$SP" retexture "$dir/probe" --texture "$dir/tex.png" -o "$O" -f -q \
    --mask "$dir/probe/clean_plate.png"
X="$dir/x.png"
expect 2 "texture not a PNG" "$SP" retexture "$dir/probe" --texture "$dir/st.spcap" -o "$X"
contains "$dir/err.txt" "st.spcap" "texture not a PNG"
expect 2 "mask of the wrong size" "$SP" retexture "$dir/probe" --texture "$dir/tex.png" -o "$X" --mask "$dir/tex.png"
contains "$dir/err.txt" "mask .*tex.png: 64x64, the probe's plate is 320x240" "mask of the wrong size"
cp -r "$dir/probe" "$dir/bad"
echo '{"plane": ' >"$dir/bad/probe.json"
expect 2 "damaged probe.json" "$SP" retexture "$dir/bad" --texture "$dir/tex.png" -o "$X"
contains "$dir/err.txt" "bad" "damaged probe.json"
expect 1 "no --texture" "$SP" retexture "$dir/probe" -o "$X"
expect 1 "bad --metres" "$SP" retexture "$dir/probe" --texture "$dir/tex.png" -o "$X" --metres 0
contains "$dir/err.txt" "metres .0.: expected a number" "bad --metres"
[ -e "$X" ] && fail "a refused run left x.png"
ls "$dir" | grep -q partial && fail "a partial file was left"
[ "$fails" -eq 0 ] && echo "retexture CLI: all passed"
exit $((fails > 0))
