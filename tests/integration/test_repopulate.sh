#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# `sunprobe cutouts` and `sunprobe repopulate` end to end on synth street: the people of one seed's capture
# (segmented against its probe) become a collection with the sun of the probe's shadow model; a frame of
# another seed gets them, replacing its people (--private, with its probe: heights from the plane within
# 10 % of the truth's), and at given points from a person's box with the sun given (the shadow's direction
# within 5 degrees of the truth's), and a cut-out with a real height of 0.85 m at half a person's. Then the bad input: nothing to remove, no usable cut-out, a cut-out
# without alpha, a sidecar with NaN, an empty collection: a message, exit 2, OUT left as it was.
set -u
SP=$1
. "$(dirname "$0")/cli_lib.sh" repop
cam=386.2741699796952,160,120,15 # synth street's default camera

for s in 1 2; do
    "$SP" synth street --seed $s -o "$dir/s$s.spcap" >/dev/null 2>&1 || { echo "synth street failed"; exit 1; }
    "$SP" probe "$dir/s$s.spcap" -o "$dir/p$s" -q >/dev/null 2>&1 || { echo "probe failed"; exit 1; }
done
"$SP" export-video "$dir/s2.spcap" -o "$dir/f" --every 100 >/dev/null 2>&1 || { echo "export-video failed"; exit 1; }
frame=$dir/f/frame_000100.png

expect 0 "cutouts" "$SP" cutouts "$dir/s1.spcap" --probe "$dir/p1" -o "$dir/c" --camera $cam --max 20
python3 - "$dir/c" <<'PY' || fail "cutouts: collection"
import glob, json, struct, sys
side = sorted(glob.glob(sys.argv[1] + "/*.json"))
assert len(side) >= 10, len(side)
for p in side:
    m = json.load(open(p))
    assert m["sky"] == "sunny" and abs(m["sun_azimuth_deg"] + 30) < 10 and abs(m["sun_elevation_deg"] - 40) < 10, m
    png = open(sys.argv[1] + "/" + m["image"], "rb").read(26)
    w, h, depth, colour = struct.unpack(">IIBB", png[16:26])
    assert colour == 6 and h == m["height_px"] + 2 and m["foot"] == [(w - 1) / 2, h - 2], (p, w, h, colour, m)
PY
expect 1 "cutouts without --probe" "$SP" cutouts "$dir/s1.spcap" -o "$dir/c2"
contains "$dir/err.txt" "PROBE_DIR is required" "cutouts without --probe"

# --private with the probe: everyone the probe segments replaced at their foot, the plane's height
expect 0 "private" "$SP" repopulate "$frame" --collection "$dir/c" --probe "$dir/p2" --private -o "$dir/a.png" \
    --camera $cam
cmp -s "$frame" "$dir/a.png" && fail "private: nothing changed"
python3 - "$dir/a.json" "$dir/s2.truth.json" <<'PY' || fail "private: report"
import json, sys
r, t = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
assert r["private"] and r["filled_from"] == "the probe's clean plate" and r["scene"]["sky"] == "sunny", r
assert 1 <= len(r["placed"]) <= r["people_found"], r
rows = sorted({(s["y"], s["height"]) for s in t["samples"]})
def true_height(y): # linear between the truth's sample rows (a person's height depends on the row alone)
    for (y0, h0), (y1, h1) in zip(rows, rows[1:]):
        if y0 <= y <= y1:
            return h0 + (h1 - h0) * (y - y0) / (y1 - y0)
checked = 0
for p in r["placed"]:
    assert p["cutout"] and p["match"] > 0.95 and p["shadow"], p
    h = true_height(p["at"][1])
    if h:
        assert abs(p["height_px"] / h - 1) < 0.10, (p, h)
        checked += 1
assert checked >= 1, rows
PY

# no probe: the scale from a person's box (the truth's height there), the sun given; shadows along it
python3 - "$dir/s2.truth.json" >"$dir/pts" <<'PY'
import json, sys
t = json.load(open(sys.argv[1]))
s = sorted(t["samples"], key=lambda s: (-s["y"], s["x"]))
b, q = s[0], [s[len(s) // 3], s[len(s) // 2]]
print("%d,%d,10,%d" % (b["x"] - 5, b["y"] - round(b["height"]) + 1, round(b["height"])))
print(" ".join("--at %d,%d" % (round(p["x"]), round(p["y"])) for p in q))
PY
read -r box <"$dir/pts"
at=$(sed -n 2p "$dir/pts")
expect 0 "at points" "$SP" repopulate "$frame" --collection "$dir/c" --detector none --box "$box" $at --sun -30,40 \
    --camera $cam -o "$dir/b.png"
python3 - "$dir/b.json" "$dir/s2.truth.json" <<'PY' || fail "at points: report"
import json, math, sys
r, t = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
assert len(r["placed"]) == 2 and r["scene"]["sun_from"] == "--sun", r
for p in r["placed"]:
    s = min(t["samples"], key=lambda s: math.hypot(s["x"] - p["at"][0], s["y"] - p["at"][1]))
    d = p["shadow_offset_per_height"]
    err = abs(math.degrees(math.atan2(d[1], d[0]) - math.atan2(s["shadow_dy"], s["shadow_dx"])))
    assert min(err, 360 - err) < 5, (p, s, err)
    assert abs(p["height_px"] / s["height"] - 1) < 0.08, (p, s)
PY

# a cut-out with its real height (a child of 0.85 m): drawn at half a person's height there
mkdir -p "$dir/child"
side=$(ls "$dir/c" | grep json | head -1)
cp "$dir/c/${side%.json}.png" "$dir/child/"
sed 's/"height_px":/"height_m":0.85,"height_px":/' "$dir/c/$side" >"$dir/child/$side"
expect 0 "real height" "$SP" repopulate "$frame" --collection "$dir/child" --detector none --box "$box" $at \
    --sun -30,40 --camera $cam --min-match -1 -o "$dir/k.png"
python3 - "$dir/k.json" "$dir/b.json" <<'PY' || fail "real height: report"
import json, sys
k, b = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
for p, q in zip(k["placed"], b["placed"]):
    assert p["at"] == q["at"] and abs(p["height_px"] / q["height_px"] - 0.5) < 0.01, (p, q)
print("real height: %s" % [round(p["height_px"] / q["height_px"], 3) for p, q in zip(k["placed"], b["placed"])])
PY

# HOG where OpenCV is built: its boxes are its training window (an eighth above and below the person), and
# the people it finds give the scale: the inserted heights within 15 % of the truth's
"$SP" repopulate "$frame" --collection "$dir/c" --detector hog --private --camera $cam -o "$dir/h.png" -q \
    2>"$dir/e.txt"
got=$?
case $got in
    0) python3 - "$dir/h.json" "$dir/s2.truth.json" <<'PY' || fail "hog: heights" ;;
import json, sys
r, t = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
rows = sorted({(s["y"], s["height"]) for s in t["samples"]})
for p in r["placed"]:
    for (y0, h0), (y1, h1) in zip(rows, rows[1:]):
        if y0 <= p["at"][1] <= y1:
            h = h0 + (h1 - h0) * (p["at"][1] - y0) / (y1 - y0)
            assert abs(p["height_px"] / h - 1) < 0.15, (p, h, r["scene"])
# HOG's loose windows are cut to the people's silhouettes (GrabCut, with OpenCV) unless --whole-boxes
assert r["silhouettes"] >= 1, r
PY
    2) grep -q "nothing to remove" "$dir/e.txt" || fail "hog: exit 2 without the message" ;;
    4) grep -q -- "-Dopencv" "$dir/e.txt" || fail "hog: exit 4 without naming -Dopencv" ;;
    *) fail "hog: exit $got" ;;
esac
if [ $got = 0 ]; then
    expect 0 "hog, whole boxes" "$SP" repopulate "$frame" --collection "$dir/c" --detector hog --private --camera $cam \
        --whole-boxes -o "$dir/hw.png" -q
    python3 -c 'import json, sys; r = json.load(open(sys.argv[1])); assert r["silhouettes"] == 0, r' "$dir/hw.json" ||
        fail "hog, whole boxes: silhouettes"
fi

bad() { # name args...: exit 2, a message, OUT untouched, no report
    local name=$1
    shift
    echo keep >"$dir/out.png"
    "$SP" repopulate "$@" -o "$dir/out.png" >"$dir/o.txt" 2>"$dir/e.txt"
    local got=$?
    [ "$got" -eq 2 ] || { fail "$name: exit $got, expected 2"; sed 's/^/  | /' "$dir/e.txt"; }
    [ -s "$dir/e.txt" ] || fail "$name: no message"
    [ "$(cat "$dir/out.png")" = keep ] || fail "$name: OUT was overwritten"
    ls "$dir"/out.json "$dir"/out.png.tmp.* >/dev/null 2>&1 && fail "$name: partial outputs"
    rm -f "$dir/out.png"
}
bad "nothing to remove" "$dir/s2.background.png" --collection "$dir/c" --private --detector none
contains "$dir/e.txt" "nothing to remove" "nothing to remove: message"
mkdir "$dir/over" && for f in "$dir"/c/*; do cp "$f" "$dir/over/"; done
sed -i 's/"sky":"sunny"/"sky":"overcast"/' "$dir"/over/*.json
bad "no usable cut-out" "$frame" --collection "$dir/over" --probe "$dir/p2" --private
contains "$dir/e.txt" "no usable cut-out" "no usable cut-out: message"
mkdir "$dir/rgb" && cp "$dir/c/$(ls "$dir/c" | grep json | head -1)" "$dir/rgb/a.json"
cp "$frame" "$dir/rgb/$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["image"])' "$dir/rgb/a.json")"
bad "cut-out without alpha" "$frame" --collection "$dir/rgb" --probe "$dir/p2" --private
contains "$dir/e.txt" "no alpha" "cut-out without alpha: message"
mkdir "$dir/nan" && cp "$dir"/c/* "$dir/nan/"
sed -i 's/"height_px":[0-9.]*/"height_px":NaN/' "$dir/nan/$(ls "$dir/nan" | grep json | tail -1)"
bad "sidecar with NaN" "$frame" --collection "$dir/nan" --probe "$dir/p2" --private
contains "$dir/e.txt" "nan/.*json" "sidecar with NaN: message names the file"
mkdir "$dir/empty"
bad "empty collection" "$frame" --collection "$dir/empty" --probe "$dir/p2" --private
contains "$dir/e.txt" "no cut-out" "empty collection: message"
bad "no scale" "$frame" --collection "$dir/c" --detector none
contains "$dir/e.txt" "no scale" "no scale: message"

[ "$fails" -eq 0 ] && echo "repopulate: all passed"
exit $((fails > 0))
