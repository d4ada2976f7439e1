#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# `sunprobe synth selfie` end to end: a short small capture passes info and verify with the
# expected frame and IMU counts, the truth directory and contact sheet exist, the same seed gives
# the same bytes, --overcast gives a zero sun, --backdrop sky is the default and city changes only the
# background, --backdrop-distance moves it in from infinity, --no-imu writes no IMU samples, bad options get exit code 1.
set -u
SP=$1
. "$(dirname "$0")/cli_lib.sh" selfie

small=(--face generic --width 96 --height 96 --fps 15 --still 0.5 --turn-seconds 1 --albedo-size 128
       --supersample 1 --shadow-size 256 --seed 7)
mkdir -p "$dir/a" "$dir/b"
expect 0 "synth selfie" "$SP" synth selfie -o "$dir/a/s.spcap" "${small[@]}" --contact-sheet "$dir/a/sheet.png"
[ -f "$dir/a/s.spcap.partial" ] && fail "partial file left behind"
contains "$dir/out.txt" "31 frames 96x96" "frame count in the summary"
contains "$dir/out.txt" "12 held-out frames" "held-out count in the summary"

expect 0 "info" "$SP" info "$dir/a/s.spcap"
contains "$dir/out.txt" "frames\[0\]: +31 (mjpeg|rgb24) 96x96" "info frame count (2 s at 15 fps + 1)"
contains "$dir/out.txt" "imu gyro +401 samples" "info gyro count (2 s at 200 Hz + 1)"
contains "$dir/out.txt" "imu accel +401 samples" "info accel count"
contains "$dir/out.txt" "kind: +selfie" "info metadata kind"
contains "$dir/out.txt" "62 side" "two side chunks per frame"
contains "$dir/out.txt" "closed cleanly" "info END chunk"
expect 0 "verify" "$SP" verify "$dir/a/s.spcap"
expect 0 "replay" "$SP" replay "$dir/a/s.spcap"

t=$dir/a/s.truth
for f in truth.json frames.json albedo.png albedo.pfm clusters.png env.pfm env.png; do
    [ -s "$t/$f" ] || fail "truth file $f missing"
done
n_png=$(ls "$t"/heldout/relit_*.png "$t"/heldout/view_*.png 2>/dev/null | wc -l)
n_json=$(ls "$t"/heldout/*_[0-9][0-9].json 2>/dev/null | wc -l)
[ "$n_png" -eq 12 ] || fail "expected 12 held-out PNGs, found $n_png"
[ "$n_json" -eq 12 ] || fail "expected 12 held-out JSON files, found $n_json"
contains "$t/truth.json" '"capture":"s.spcap"' "manifest names the capture"
[ "$(head -c 4 "$dir/a/sheet.png" | od -An -tx1 | tr -d ' ')" = "89504e47" ] || fail "contact sheet is not a PNG"

# same seed, another directory: identical bytes after the 64-byte file header (which holds the wall clock)
expect 0 "synth selfie again" "$SP" synth selfie -o "$dir/b/s.spcap" "${small[@]}"
cmp -s -i 64 "$dir/a/s.spcap" "$dir/b/s.spcap" || fail "same seed gave different capture bytes"
cmp -s "$t/truth.json" "$dir/b/s.truth/truth.json" || fail "same seed gave a different truth.json"
cmp -s "$t/heldout/view_03.png" "$dir/b/s.truth/heldout/view_03.png" || fail "same seed gave a different held-out frame"
expect 0 "synth selfie other seed" "$SP" synth selfie -o "$dir/b/o.spcap" "${small[@]}" --seed 8 --no-truth
cmp -s -i 64 "$dir/a/s.spcap" "$dir/b/o.spcap" && fail "another seed gave the same capture"
[ -e "$dir/b/o.truth" ] && fail "--no-truth wrote a truth directory"

expect 0 "synth selfie overcast" "$SP" synth selfie -o "$dir/b/c.spcap" "${small[@]}" --overcast --truth "$dir/ct"
contains "$dir/ct/truth.json" '"sun":\{[^}]*"intensity":0,' "overcast sun intensity 0"
contains "$dir/ct/truth.json" '"model":"overcast"' "overcast sky model"

# --backdrop: sky is the default to the byte; city changes the background only (the face's metering, hence
# every frame's exposure, and the landmarks stay), and the truth says so
mkdir -p "$dir/sky" "$dir/city"
expect 0 "synth selfie --backdrop sky" "$SP" synth selfie -o "$dir/sky/s.spcap" "${small[@]}" --backdrop sky
cmp -s -i 64 "$dir/a/s.spcap" "$dir/sky/s.spcap" || fail "--backdrop sky differs from the default capture"
cmp -s "$t/truth.json" "$dir/sky/s.truth/truth.json" || fail "--backdrop sky differs from the default truth"
expect 0 "synth selfie --backdrop city" "$SP" synth selfie -o "$dir/city/s.spcap" "${small[@]}" --backdrop city
cmp -s -i 64 "$dir/a/s.spcap" "$dir/city/s.spcap" && fail "--backdrop city gave the default capture"
cmp -s "$t/frames.json" "$dir/city/s.truth/frames.json" || fail "--backdrop city changed the exposures or landmarks"
cmp -s "$t/heldout/relit_00.png" "$dir/city/s.truth/heldout/relit_00.png" && fail "--backdrop city: held-out frame unchanged"
contains "$dir/city/s.truth/truth.json" '"backdrop":\{"kind":"city"' "city backdrop in the manifest"
grep -q '"backdrop"' "$t/truth.json" && fail "the default manifest names a backdrop"
expect 0 "info city" "$SP" info "$dir/city/s.spcap"
contains "$dir/out.txt" "frames\[0\]: +31 " "city frame count"
expect 1 "synth selfie bad backdrop" "$SP" synth selfie -o "$dir/x.spcap" --backdrop foo
contains "$dir/err.txt" "selfie: --backdrop 'foo'" "bad --backdrop names the option"
# --backdrop-distance: the city 20 m away shows parallax, so the frames differ from the city at infinity
# (and the manifest records the distance); under 2 m the camera could leave the sphere: refused
mkdir -p "$dir/near"
expect 0 "synth selfie --backdrop-distance 20" "$SP" synth selfie -o "$dir/near/s.spcap" "${small[@]}" --backdrop city \
    --backdrop-distance 20
cmp -s -i 64 "$dir/city/s.spcap" "$dir/near/s.spcap" && fail "--backdrop-distance 20 gave the city at infinity"
contains "$dir/near/s.truth/truth.json" '"backdrop":\{"kind":"city","distance_m":20,' "backdrop distance in the manifest"
expect 1 "synth selfie --backdrop-distance 1" "$SP" synth selfie -o "$dir/x.spcap" --backdrop city --backdrop-distance 1
contains "$dir/err.txt" "selfie: --backdrop-distance '1'" "--backdrop-distance 1 names the option"

# --no-imu: frames and side data, no IMU samples, and META names no IMU
expect 0 "synth selfie --no-imu" "$SP" synth selfie -o "$dir/b/n.spcap" "${small[@]}" --no-imu --no-truth
contains "$dir/out.txt" " 0 IMU samples" "--no-imu summary"
expect 0 "info --no-imu" "$SP" info "$dir/b/n.spcap"
contains "$dir/out.txt" "imu: +none" "--no-imu: info finds no IMU samples"
contains "$dir/out.txt" " 0 imu, 62 side" "--no-imu: no IMU chunks, both side data"
grep -q "fake imu" "$dir/out.txt" && fail "--no-imu: META still names an IMU"
contains "$dir/out.txt" "frames\[0\]: +31 " "--no-imu frame count"

expect 0 "synth selfie --help" "$SP" synth selfie --help
expect 1 "synth selfie without output" "$SP" synth selfie
expect 1 "synth selfie bad width" "$SP" synth selfie -o "$dir/x.spcap" --width 5
expect 1 "synth selfie bad face" "$SP" synth selfie -o "$dir/x.spcap" --face martian
expect 1 "synth selfie bad bias" "$SP" synth selfie -o "$dir/x.spcap" --gyro-bias 1,2
[ -e "$dir/x.spcap" ] && fail "a rejected command wrote a capture"

[ "$fails" -eq 0 ] && echo "all synth selfie checks passed"
exit $((fails > 0))
