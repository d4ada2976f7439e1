#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# `sunprobe check` on synthetic selfies made to pass and to fail: a full sunny turn is good to fit;
# a 90-degree turn fails (exit 2); overcast warns that the lighting is flat; a long shutter warns of
# motion blur; a capture without IMU fails; a missing file is an I/O error (exit 3).
set -u
SP=$1
. "$(dirname "$0")/cli_lib.sh" check

small=(--face generic --width 64 --height 64 --fps 10 --still 0.5 --turn-seconds 6 --albedo-size 128
       --supersample 1 --shadow-size 128 --no-truth --seed 3)
synth() { # name extra-options...
    local name=$1; shift
    "$SP" synth selfie -o "$dir/$name.spcap" "${small[@]}" "$@" >/dev/null 2>"$dir/err.txt" \
        || { fail "synth $name"; cat "$dir/err.txt"; }
}
synth good
synth short --turn-deg 90
synth overcast --overcast
synth blur --shutter 0.1 --motion-blur 4

expect 0 "good capture" "$SP" check "$dir/good.spcap" --json "$dir/good.json"
contains "$dir/out.txt" "good to fit" "verdict"
contains "$dir/out.txt" "^ok +turn +3[5-6][0-9] deg" "a full turn measured"
contains "$dir/out.txt" "^ok +lighting .*face's brightness.*observable" "sunny lighting observable, on the face"
contains "$dir/out.txt" "^ok +face +found on 100 %" "faces from the landmark side data"
contains "$dir/good.json" '"fails": 0' "JSON"
python3 -c "import json,sys; json.load(open(sys.argv[1]))" "$dir/good.json" || fail "JSON does not parse"

expect 2 "a quarter turn" "$SP" check "$dir/short.spcap"
contains "$dir/out.txt" "^FAIL turn +9[0-9] deg" "the short turn"
contains "$dir/out.txt" "re-shoot turning a full circle" "advice"

expect 0 "overcast" "$SP" check "$dir/overcast.spcap"
contains "$dir/out.txt" "^warn lighting .*flat" "flat lighting"

expect 0 "long shutter" "$SP" check "$dir/blur.spcap"
contains "$dir/out.txt" "^warn blur .*turn more slowly" "motion blur"

# the same frames without their IMU
"$SP" export-video "$dir/good.spcap" -o "$dir/frames" >/dev/null 2>&1
rc=$?
[ "$rc" -eq 4 ] && echo "note: no OpenCV/libjpeg in this build: the capture without IMU is not made"
[ "$rc" -ne 0 ] && [ "$rc" -ne 4 ] && fail "export-video: exit $rc"
if [ "$rc" -eq 0 ]; then
    "$SP" import "$dir/frames" -o "$dir/noimu.spcap" --fps 10 -q >"$dir/out.txt" 2>&1
    rc=$?
    [ "$rc" -eq 4 ] && echo "note: this build cannot import PNG frames: the capture without IMU is not made"
    [ "$rc" -ne 0 ] && [ "$rc" -ne 4 ] && fail "import without IMU: exit $rc"
fi
if [ "$rc" -eq 0 ]; then
    expect 2 "no IMU" "$SP" check "$dir/noimu.spcap"
    contains "$dir/out.txt" "^FAIL imu +no gyroscope" "no IMU named"
fi
# a rotating test pattern: no face anywhere (the tracker finds none; without dlib it is not looked for)
"$SP" synth turn -o "$dir/turn.spcap" --width 96 --height 72 --fps 10 --turn-seconds 4 >/dev/null 2>&1 || fail "synth turn"
"$SP" check "$dir/turn.spcap" >"$dir/out.txt" 2>&1
rc=$?
if grep -q "not looked for" "$dir/out.txt"; then
    [ "$rc" -eq 0 ] || fail "no face, not looked for: exit $rc"
else
    [ "$rc" -eq 2 ] || fail "no face: exit $rc, expected 2"
    contains "$dir/out.txt" "^FAIL face +found on 0 %" "no face found"
fi
expect 0 "--no-face" "$SP" check "$dir/turn.spcap" --no-face
contains "$dir/out.txt" "^warn face +not looked for" "--no-face"
expect 3 "missing file" "$SP" check "$dir/nothing.spcap"
expect 1 "no argument" "$SP" check

[ "$fails" -eq 0 ] && echo "check: all passed" || echo "check: $fails failed"
[ "$fails" -eq 0 ]
