#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# A path-traced rotating selfie from ../shared/captures (another renderer; a phone-style IMU log that
# starts 1 s before the video; the front camera's imu.to_camera is 180 deg about z), imported as a user
# would, then: the orientation stage's cameras and the fit's keyframe cameras against the true
# cam_to_world of every frame, and the fitted sun against the true sun.
# usage: test_shared_selfie.sh SUNPROBE CAPTURES_DIR [NAME]   (default selfie-sunny-dev1)
set -uo pipefail
sp=$1
cap=$2/${3:-selfie-sunny-dev1}
here=$(cd "$(dirname "$0")" && pwd)
check=(python3 "$here/check_capture_truth.py")
[ -f "$cap/meta.json" ] || { echo "SKIP: no path-traced capture at $cap (../shared/captures)"; exit 77; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

to_camera=$("${check[@]}" to-camera "$cap/meta.json") || exit 1
python3 - "$cap/meta.json" "$to_camera" >"$tmp/meta.json" <<'PY' || exit 1
import json, sys
m = json.load(open(sys.argv[1]))
c = m["camera"]
print(json.dumps({"kind": "selfie", "camera": {k: c[k] for k in ("fx", "fy", "cx", "cy")},
                  "imu": {"name": "phone imu", "rate_hz": m["imu"]["rate_hz"],
                          "to_camera": [float(v) for v in sys.argv[2].split(",")]}}))
PY
"$sp" import "$cap/frames/%05d.png" -o "$tmp/c.spcap" --frame-times "$cap/frames.csv" --imu "$cap/imu.csv" \
    --meta "$tmp/meta.json" >"$tmp/import.log" 2>&1
rc=$?
[ $rc = 4 ] && { echo "SKIP: this build cannot import PNG frames"; cat "$tmp/import.log"; exit 77; }
[ $rc = 0 ] || { cat "$tmp/import.log"; exit 1; }

fail=0
"$sp" replay "$tmp/c.spcap" --stage orientation -o "$tmp/orientation.csv" || fail=1
"${check[@]}" orientation "$tmp/orientation.csv" "$cap/meta.json" --max-camera-deg 3 --max-up-deg 3 || fail=1

# landmarks on every frame, against the true 68 points (issue-tracked target: 95% of frames, 3% of the
# inter-ocular distance; the limits here guard what is reached: 99-100%, 3.2-4.5%)
"$sp" replay "$tmp/c.spcap" --stage landmarks -o "$tmp/landmarks.csv" >"$tmp/landmarks.log" 2>&1
rc=$?
cat "$tmp/landmarks.log"
if [ $rc != 0 ] && grep -q "no dlib" "$tmp/landmarks.log"; then
    echo "SKIP (landmarks): this build has no dlib"
else
    [ $rc = 0 ] || fail=1
    "${check[@]}" landmarks "$tmp/landmarks.csv" "$cap/gt/landmarks.csv" --min-coverage 0.95 \
        --max-landmark-error 0.06 || fail=1
fi

"$sp" fit "$tmp/c.spcap" -o "$tmp/face" --no-progress >"$tmp/fit.log" 2>&1
rc=$?
cat "$tmp/fit.log"
if [ $rc != 0 ] && grep -q "no dlib" "$tmp/fit.log"; then
    echo "SKIP (fit part): this build has no dlib to find the face"
    exit $((fail ? 1 : 77))
fi
[ $rc = 0 ] || exit 1
# the tracker sees every frame, also those the fit skips as blurred or saturated: landmarks.csv has a row for each
# (but those the tagger thinned while its IMU filter initialised: none on these captures, whose IMU log starts early)
thinned=$(python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["fit"]["thinned_early"])' \
    "$tmp/face/manifest.json") || fail=1
rows=$(($(wc -l <"$tmp/face/landmarks.csv") - 1)) frames=$(($(wc -l <"$cap/frames.csv") - 1 - ${thinned:-0}))
[ "$rows" = "$frames" ] || { echo "landmarks.csv: $rows rows for $frames frames"; fail=1; }
# the sun limit is loose: this test is about the cameras; how well the sun is found is issue-tracked fidelity
"${check[@]}" fit "$tmp/face" "$cap/meta.json" --max-camera-deg 3 --max-up-deg 3 --max-sun-deg 20 || fail=1

# the measuring instrument on the same fit: its registration must agree with the cameras above, and every
# held-out image must be scored with finite figures (the fidelity targets themselves are tracked, not asserted)
"$sp" evaluate "$tmp/face" "$cap" --json "$tmp/eval.json" --renders "$tmp/renders" --passes || fail=1
# --passes: one float file per held-out view, readable by the residual tool (SUNSTAGE.md, "The residual by normal")
python3 "$here/../../tools/bench/residual_by_normal.py" "$tmp/renders" nvs >"$tmp/residual.txt" &&
    grep -q "^| all | [1-9]" "$tmp/residual.txt" || { echo "evaluate --passes: FAILED"; cat "$tmp/residual.txt"; fail=1; }
python3 - "$tmp/eval.json" <<'PY' || fail=1
import json, math, sys
e = json.load(open(sys.argv[1]))
ok = e["camera_error_deg"]["max"] < 3 and e["nvs"]["images"] >= 1 and math.isfinite(e["nvs"]["psnr"])
ok &= 0 <= e["nvs"]["ssim"] <= 1 and 0 < e["nvs"]["mask_overlap"] <= 1
if "landmarks" in e:  # the fit's own landmark record, scored like the landmarks stage above
    lm = e["landmarks"]
    ok &= lm["found"] >= 0.9 * lm["frames_with_face"] and lm["error_iod"] < 0.06
    # the model fitted to every tracked frame (SUNSTAGE.md, "Fitted landmarks"): issue-tracked target 3%, the
    # limit guards what is reached (2.3-3.4%) and that the fitted points improve on the tracker's
    fl = e.get("landmarks_fitted")
    ok &= fl is not None and fl["found"] >= 0.9 * fl["frames_with_face"] and fl["error_iod"] < 0.04
    ok &= fl is not None and fl["error_iod"] < lm["error_iod"]
if e["relight"]["images"]:
    ok &= math.isfinite(e["relight"]["psnr"]) and 0 <= e["relight"]["ssim"] <= 1
    # a sunny capture scores the fitted sun; an overcast one is relit with the true sun's strength, no sun error
    ok &= (math.isfinite(e["sun_error_deg"]) if e["sun_error_deg"] is not None
           else "overcast" in e.get("sun_note", ""))
print("evaluate:", "ok" if ok else "FAILED",
      json.dumps({k: e.get(k) for k in ("camera_error_deg", "sun_error_deg", "relight", "nvs", "landmarks",
                                        "landmarks_fitted")}))
sys.exit(0 if ok else 1)
PY
# a damaged face directory is refused before any image is rendered, naming the file (exit 2; tools/evaluate_landmarks.c)
cp -r "$tmp/face" "$tmp/damaged"
rm "$tmp/damaged/landmarks_fitted.csv"
"$sp" evaluate "$tmp/damaged" "$cap" >/dev/null 2>"$tmp/damaged.err"
rc=$?
[ $rc = 2 ] && grep -q "landmarks_fitted.csv is missing" "$tmp/damaged.err" ||
    { echo "evaluate with the fitted landmarks missing: exit $rc, $(cat "$tmp/damaged.err"); FAILED"; fail=1; }
awk -F, 'NR == 1 || $1 != 7' "$tmp/face/landmarks.csv" >"$tmp/damaged/landmarks_fitted.csv" # a frame left out: fine
sed -n 2p "$tmp/face/landmarks.csv" >>"$tmp/damaged/landmarks_fitted.csv" # its first frame given twice
"$sp" evaluate "$tmp/damaged" "$cap" >/dev/null 2>"$tmp/damaged.err"
rc=$?
[ $rc = 2 ] && grep -q "landmarks_fitted.csv:.*appears twice" "$tmp/damaged.err" ||
    { echo "evaluate with a frame given twice: exit $rc, $(cat "$tmp/damaged.err"); FAILED"; fail=1; }
exit $fail
