#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# `sunprobe depopulate`: a synth street frame emptied from user boxes (exemplar inpainting) and from a
# probe of the same street (its clean plate), each with its report and debug image; then the bad
# input: nothing to remove, everything kept, a damaged image, a box outside the image, a probe of
# another size, the HOG detector without OpenCV: a message, the documented exit code, and no output
# (an existing OUT is left as it was).
set -u
SP=$1
dir=$(mktemp -d "${TMPDIR:-/tmp}/sp-depop.XXXXXX")
trap 'rm -rf "$dir"' EXIT
fails=0
fail() { echo "FAIL: $*"; fails=$((fails + 1)); }

"$SP" synth street --seed 1 --seconds 14 -o "$dir/s.spcap" >/dev/null 2>&1 || { echo "synth street failed"; exit 1; }
"$SP" export-video "$dir/s.spcap" -o "$dir/f" >/dev/null 2>&1 || { echo "export-video failed"; exit 1; }
"$SP" probe "$dir/s.spcap" -o "$dir/p" -q >/dev/null 2>&1 || { echo "probe failed"; exit 1; }
frame=$dir/f/frame_000120.png

# user boxes, no detector: exemplar inpainting; report and masks beside OUT
"$SP" depopulate "$frame" -o "$dir/a.png" --detector none --box 100,60,30,80 --box 10,10,20,40 -q ||
    fail "boxes: exit $?"
for f in a.png a.json a.debug.png; do [ -s "$dir/$f" ] || fail "boxes: no $f"; done
python3 - "$dir/a.json" <<'EOF' || fail "boxes: report"
import json, sys
r = json.load(open(sys.argv[1]))
assert r["filled_from"] == "exemplar inpainting", r["filled_from"]
assert len(r["objects"]) == 2 and r["objects"][0]["box"] == [100, 60, 30, 80], r["objects"]
assert r["object_pixels"] >= 30 * 80 + 20 * 40 and r["inpainted_patches"] > 0, r
EOF
cmp -s "$frame" "$dir/a.png" && fail "boxes: nothing changed"

# the image, its report and its masks are one set: a report that cannot be written leaves the old three as
# they were (the masks were replaced and then deleted)
cp "$dir/a.png" "$dir/a0.png"; cp "$dir/a.json" "$dir/a0.json"; cp "$dir/a.debug.png" "$dir/a0.debug.png"
"$SP" depopulate "$frame" -o "$dir/a.png" --detector none --box 50,60,30,80 --report "$dir/no/such/r.json" -q \
    2>"$dir/err.txt" && fail "report into a missing directory: exit 0"
grep -q "no/such/r.json" "$dir/err.txt" || fail "report into a missing directory: the path not named"
for f in a.png a.json a.debug.png; do cmp -s "$dir/$f" "$dir/${f/a/a0}" || fail "a failed report changed $f"; done
ls "$dir" | grep -E "\.new\.|\.tmp" && fail "a failed report left temporaries"

# --keep drops the box that holds the point; named report and debug paths
"$SP" depopulate "$frame" -o "$dir/k.png" --detector none --box 100,60,30,80 --box 10,10,20,40 --keep 15,20 \
    --report "$dir/k-report.json" --debug "$dir/k-masks.png" -q || fail "keep: exit $?"
python3 -c "import json,sys; r=json.load(open(sys.argv[1])); assert r['kept']==1 and len(r['objects'])==1, r" \
    "$dir/k-report.json" || fail "keep: report"
[ -s "$dir/k-masks.png" ] || fail "keep: no debug image"

# the sun from the clock beside the shadows; the clock's options go together and need a zone
"$SP" depopulate "$frame" -o "$dir/c.png" --detector none --box 100,60,30,80 --camera 386.27,160,120,15 \
    --utc 2026-06-21T12:00:00Z --location 48.1,11.6 --heading 180 -q || fail "clock: exit $?"
python3 - "$dir/c.json" <<'EOF' || fail "clock: report"
import json, sys
s = json.load(open(sys.argv[1]))["sun"]
assert s["camera"] == "given" and abs(s["from_clock"]["elevation_deg"] - 63.8) < 1.0, s
EOF

# a probe of the same street: its segmentation, its clean plate
"$SP" depopulate "$frame" -o "$dir/b.png" --probe "$dir/p" -q || fail "probe: exit $?"
python3 - "$dir/b.json" <<'EOF' || fail "probe: report"
import json, sys
r = json.load(open(sys.argv[1]))
assert r["filled_from"] == "the probe's clean plate", r["filled_from"]
assert "probe" in r["objects_from"] and len(r["objects"]) >= 1, r
EOF

bad() { # name expected-exit-code args...: the exit code, a message, OUT untouched, no stray outputs
    local name=$1 want=$2
    shift 2
    echo keep >"$dir/out.png"
    "$SP" depopulate "$@" -o "$dir/out.png" >"$dir/o.txt" 2>"$dir/e.txt"
    local got=$?
    [ "$got" -eq "$want" ] || { fail "$name: exit $got, expected $want"; sed 's/^/  | /' "$dir/e.txt"; }
    [ -s "$dir/e.txt" ] || fail "$name: no message"
    [ "$(cat "$dir/out.png")" = keep ] || fail "$name: OUT was overwritten"
    ls "$dir"/out.json "$dir"/out.debug.png "$dir"/out.png.tmp.* >/dev/null 2>&1 && fail "$name: partial outputs"
    rm -f "$dir/out.png"
}
bad "nothing to remove" 2 "$frame" --detector none
grep -q "nothing to remove" "$dir/e.txt" || fail "nothing to remove: message"
bad "all kept" 2 "$frame" --detector none --box 100,60,30,80 --keep 110,100
head -c 300 "$frame" >"$dir/cut.png"
bad "damaged image" 2 "$dir/cut.png" --detector none --box 1,1,5,5
bad "box outside" 1 "$frame" --detector none --box 300,200,40,80
grep -q -- "--box" "$dir/e.txt" || fail "box outside: message does not name --box"
bad "bad box" 1 "$frame" --box 1,2,3
bad "utc without a zone" 1 "$frame" --box 1,1,5,5 --utc 2026-06-21T12:00:00 --location 1,2 --heading 0
bad "utc alone" 1 "$frame" --box 1,1,5,5 --utc 2026-06-21T12:00:00Z
bad "latitude past 90" 1 "$frame" --box 1,1,5,5 --utc 2026-06-21T12:00:00Z --location 90.5,2 --heading 0
grep -q -- "--location '90.5,2': expected LAT,LON in degrees, latitude -90..90" "$dir/e.txt" || fail "latitude past 90: message"
bad "empty heading" 1 "$frame" --box 1,1,5,5 --utc 2026-06-21T12:00:00Z --location 1,2 --heading ""
grep -q -- "--heading '': expected a number from -360 to 360" "$dir/e.txt" || fail "empty heading: message"
bad "bad camera" 1 "$frame" --box 1,1,5,5 --camera 0,1,1,10
"$SP" synth street --width 160 --height 120 --seconds 1 -o "$dir/small.spcap" >/dev/null 2>&1 &&
    "$SP" export-video "$dir/small.spcap" -o "$dir/sf" >/dev/null 2>&1 || fail "small synth"
bad "probe of another size" 2 "$dir/sf/frame_000000.png" --probe "$dir/p"
grep -q "160x120" "$dir/e.txt" || fail "probe of another size: message"

# the HOG detector: runs where OpenCV is built (finding someone or nobody), else says which option
"$SP" depopulate "$frame" -o "$dir/h.png" --detector hog -q 2>"$dir/e.txt"
got=$?
case $got in
    0) [ -s "$dir/h.json" ] || fail "hog: no report" ;;
    2) grep -q "nothing to remove" "$dir/e.txt" || fail "hog: exit 2 without the message" ;;
    4) grep -q -- "-Dopencv" "$dir/e.txt" || fail "hog: exit 4 without naming -Dopencv" ;;
    *) fail "hog: exit $got" ;;
esac

[ "$fails" -eq 0 ] && echo "depopulate: all passed"
exit $((fails > 0))
