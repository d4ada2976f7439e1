#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# `sunprobe fit` on captures without an IMU: the camera orientation comes from the video (issue 19).
# A synthetic turn in front of a distant city (synth --backdrop city) must be tracked to a fraction of
# a degree and fitted about as well as from its IMU, and the same turn without an IMU (--no-imu) fitted
# from the video without being asked; a turn in front of a plain sky, and a path-traced
# selfie from ../shared/captures imported without its IMU log (sky over a uniform ground), must be
# refused with exit 2, a message saying why, and no face directory.
# A short turn held tilted takes world up from its accelerometer when the video gives the orientation.
# usage: test_fit_no_imu.sh SUNPROBE CAPTURES_DIR
set -uo pipefail
sp=$1
shared=$2/selfie-sunny-dev1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail=0
short=(--turn-seconds 6 --still 0.5 --seed 3)

# the same turn with its IMU: orientation from the video against the truth, and the fit from either
"$sp" synth selfie -o "$tmp/city.spcap" --backdrop city "${short[@]}" >/dev/null || exit 1
"$sp" replay "$tmp/city.spcap" --stage video-orientation -o "$tmp/vo.csv" >"$tmp/vo.log" 2>&1
rc=$?
cat "$tmp/vo.log"
if [ $rc != 0 ] && grep -q "module\|OpenCV" "$tmp/vo.log"; then
    echo "SKIP: this build cannot track corners (no OpenCV)"
    exit 77
fi
[ $rc = 0 ] || { echo "FAIL: video-orientation on the city capture exited $rc"; fail=1; }
python3 - "$tmp/vo.log" "$tmp/vo.csv" <<'PY' || fail=1
import csv, re, sys
log = open(sys.argv[1]).read()
m = re.search(r"median ([0-9.]+) deg, max ([0-9.]+) deg over ([0-9]+) frames; tilt error max ([0-9.]+)", log)
assert m, "no error against the truth in the summary"
med, mx, n, tilt = float(m[1]), float(m[2]), int(m[3]), float(m[4])
rows = list(csv.DictReader(open(sys.argv[2])))
assert len(rows) == n and all(r["tracked"] == "1" for r in rows), "every frame tracked and written"
assert "loop closed" in log and "turn's axis" in log, "loop closure and world up from the turn"
# measured: median 0.06 deg, max 0.12, tilt 0.23 (issue 19's target: a median of 2 deg)
assert med < 0.5 and mx < 1.5 and tilt < 1.5, f"orientation error median {med} max {mx} tilt {tilt}"
print(f"video orientation: median {med} deg, max {mx} deg, tilt {tilt} deg over {n} frames")
PY

# a 45-degree turn with the phone held 15 degrees up: too short to give its axis, so world up comes from
# the accelerometer (measured: tilt error 0.24 deg; the first frame's up, without it, is 15.4 deg off)
"$sp" synth selfie -o "$tmp/short.spcap" --backdrop city --turn-deg 45 --pitch 15 --turn-seconds 3 --still 0.5 \
    --seed 3 >/dev/null || exit 1
"$sp" replay "$tmp/short.spcap" --stage video-orientation -o "$tmp/short.csv" >"$tmp/short.log" 2>&1 ||
    { cat "$tmp/short.log"; echo "FAIL: video-orientation on the short turn"; fail=1; }
python3 - "$tmp/short.log" <<'PY' || fail=1
import re, sys
log = open(sys.argv[1]).read()
assert "world up is the accelerometer's" in log, "world up not from the accelerometer"
tilt = float(re.search(r"tilt error max ([0-9.]+)", log)[1])
print(f"short turn held up: tilt error {tilt} deg")
assert tilt < 1.0, f"tilt error {tilt} deg"
PY

fit_figures() { # NAME [fit args]: "held-out-dB sun-error-deg", or nothing when the fit failed
    local name=$1
    shift
    "$sp" fit "$@" -o "$tmp/$name" --no-progress >"$tmp/$name.log" 2>&1 || { cat "$tmp/$name.log"; return 1; }
    grep "^fit: " "$tmp/$name.log"
    echo "$(sed -n 's/.*held-out \([0-9.]*\) dB.*/\1/p' "$tmp/$name.log") $(sed -n \
        's/.*sun direction error \([0-9.]*\) deg.*/\1/p' "$tmp/$name.log")" >"$tmp/$name.figures"
}
if fit_figures imu "$tmp/city.spcap" --orientation imu; then
    fit_figures video "$tmp/city.spcap" --orientation video || fail=1
    # measured on this capture: held-out 28.10 dB with the IMU, 29.83 from the video; sun 3.05 / 6.51 deg.
    # The IMU fit loses the first 60 frames to the filter's start-up (thinned), the video fit keeps them,
    # and the fit's sun moves by degrees with its keyframes: the sun bound is the fit's own, not a match.
    python3 - "$(cat "$tmp/imu.figures")" "$(cat "$tmp/video.figures" 2>/dev/null)" <<'PY' || fail=1
import sys
pi, si = map(float, sys.argv[1].split())
pv, sv = map(float, sys.argv[2].split())
print(f"held-out {pi} dB with the IMU, {pv} dB from the video; sun error {si} / {sv} deg")
assert pv > pi - 1.0 and sv < 10.0, "the fit from the video is worse than the IMU's"
PY
elif grep -q "no dlib\|face model" "$tmp/imu.log"; then
    echo "SKIP (fit): this build cannot fit"
else
    fail=1
fi

# a capture with no IMU at all: fit finds that and orients from the video by itself
"$sp" synth selfie -o "$tmp/noimu.spcap" --backdrop city --no-imu "${short[@]}" --no-truth >/dev/null || exit 1
if [ -f "$tmp/imu.figures" ]; then
    fit_figures auto "$tmp/noimu.spcap" || fail=1
    grep -q "no gyroscope in the capture (no IMU, or an accelerometer alone): the camera orientation" "$tmp/auto.log" ||
        { echo "FAIL: fit did not say where the orientation came from"; fail=1; }
fi

refused() { # NAME CAPTURE: fit must exit 2 naming the video, and leave nothing
    "$sp" fit "$2" -o "$tmp/$1.face" --no-progress >"$tmp/$1.log" 2>&1
    local rc=$?
    if [ $rc != 2 ] || ! grep -q "cannot be found from the video" "$tmp/$1.log" || ls -d "$tmp/$1.face"* >/dev/null 2>&1; then
        cat "$tmp/$1.log"
        echo "FAIL ($1): exit $rc; want 2, the reason, and no face directory"
        fail=1
    else
        echo "ok ($1): refused: $(grep -o 'video-orientation: [0-9]* frames, [0-9]* coasted' "$tmp/$1.log")"
    fi
}
"$sp" synth selfie -o "$tmp/sky.spcap" --no-imu "${short[@]}" --no-truth >/dev/null || exit 1
refused sky "$tmp/sky.spcap"

# `check` looks at the video the same way when a capture has no gyroscope
checked() { # CAPTURE PATTERN WANT-EXIT
    "$sp" check "$1" --no-face >"$tmp/check.txt" 2>&1
    local rc=$?
    if [ $rc != "$3" ] || ! grep -q "$2" "$tmp/check.txt"; then
        cat "$tmp/check.txt"
        echo "FAIL (check $1): exit $rc, want $3 and '$2'"
        fail=1
    fi
}
checked "$tmp/noimu.spcap" "^ok   imu  *none: the camera orientation comes from the video" 0
checked "$tmp/sky.spcap" "^FAIL imu  *no gyroscope samples, and the background cannot be tracked" 2

if [ -f "$shared/meta.json" ]; then
    python3 - "$shared/meta.json" >"$tmp/meta.json" <<'PY' || exit 1
import json, sys
m = json.load(open(sys.argv[1]))
print(json.dumps({"kind": "selfie", "camera": {k: m["camera"][k] for k in ("fx", "fy", "cx", "cy")}}))
PY
    "$sp" import "$shared/frames/%05d.png" -o "$tmp/shared.spcap" --frame-times "$shared/frames.csv" \
        --meta "$tmp/meta.json" >"$tmp/import.log" 2>&1
    rc=$?
    if [ $rc = 4 ]; then
        echo "SKIP (shared): this build cannot import PNG frames"
    elif [ $rc != 0 ]; then
        cat "$tmp/import.log"; fail=1
    else
        refused shared "$tmp/shared.spcap"
    fi
else
    echo "SKIP (shared): no path-traced capture at $shared"
fi
exit $fail
