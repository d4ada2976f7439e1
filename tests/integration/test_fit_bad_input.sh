#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# `sunprobe fit` on captures that cannot be fitted, made from a path-traced selfie in ../shared/captures:
# frames backlit to black, no face anywhere, a face in only four frames. Each must exit 2 with a
# message naming what is missing and leave no face directory. An IMU log that never overlaps the
# frames, and an IMU-to-camera rotation that is not a rotation, are refused by import already (exit 2,
# no capture), also checked here.
# usage: test_fit_bad_input.sh SUNPROBE CAPTURES_DIR
set -uo pipefail
sp=$1
cap=$2/selfie-sunny-dev1
here=$(cd "$(dirname "$0")" && pwd)
[ -f "$cap/meta.json" ] || { echo "SKIP: no path-traced capture at $cap (../shared/captures)"; exit 77; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

to_camera=$(python3 "$here/check_capture_truth.py" to-camera "$cap/meta.json") || exit 1
python3 - "$cap" "$tmp" "$to_camera" <<'PY' || exit 1
import json, os, struct, sys, zlib
cap, tmp, q = sys.argv[1], sys.argv[2], [float(v) for v in sys.argv[3].split(",")]
m = json.load(open(f"{cap}/meta.json"))
c = m["camera"]
meta = {"kind": "selfie", "camera": {k: c[k] for k in ("fx", "fy", "cx", "cy")},
        "imu": {"name": "phone imu", "rate_hz": m["imu"]["rate_hz"], "to_camera": q}}
json.dump(meta, open(f"{tmp}/meta.json", "w"))
meta["imu"]["to_camera"] = [0.5, 0.5, 0.5, 2.0]
json.dump(meta, open(f"{tmp}/not-a-rotation.json", "w"))
lines = open(f"{cap}/imu.csv").read().splitlines()  # the IMU clock 1000 s late
open(f"{tmp}/imu-late.csv", "w").write("\n".join([lines[0]] + [
    f"{int(l.split(',', 1)[0]) + 1000 * 10**9},{l.split(',', 1)[1]}" for l in lines[1:]]) + "\n")
def png(path, rgb):  # a flat 480x360 image
    raw = b"".join(b"\0" + bytes(rgb) * 480 for _ in range(360))
    chunk = lambda t, d: struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
    open(path, "wb").write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 480, 360, 8, 2, 0, 0, 0))
                           + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))
png(f"{tmp}/black.png", (0, 0, 0))
png(f"{tmp}/wall.png", (150, 140, 120))
# 30 frames are enough to say "none" (and keep the whole-frame face search short under sanitizers)
rows = open(f"{cap}/frames.csv").read().splitlines()
n = min(30, len(rows) - 1)
open(f"{tmp}/frames30.csv", "w").write("\n".join(rows[:n + 1]) + "\n")
for kind in ("black", "noface", "few"):
    os.mkdir(f"{tmp}/{kind}")
    for i in range(n):
        src = f"{tmp}/black.png" if kind == "black" else f"{tmp}/wall.png"
        if kind == "few" and 10 <= i < 14:  # after the orientation filter has settled
            src = f"{cap}/frames/{i:05d}.png"
        os.symlink(src, f"{tmp}/{kind}/{i:05d}.png")
PY

fail=0
imp() { # NAME FRAMES_PATTERN IMU META [FRAME_TIMES]
    "$sp" import "$2" -o "$tmp/$1.spcap" --frame-times "${5:-$cap/frames.csv}" --imu "$3" --meta "$4" \
        >"$tmp/$1.import.log" 2>&1
}
imp late "$cap/frames/%05d.png" "$tmp/imu-late.csv" "$tmp/meta.json"
rc=$?
[ $rc = 4 ] && { echo "SKIP: this build cannot import PNG frames"; exit 77; }
if [ $rc = 2 ] && grep -q "never overlap" "$tmp/late.import.log" && [ ! -e "$tmp/late.spcap" ]; then
    echo "ok: late IMU refused by import: $(cat "$tmp/late.import.log")"
else
    echo "FAILED: an IMU log 1000 s late: import exit $rc"; cat "$tmp/late.import.log"; exit 1
fi
for kind in black noface few; do
    imp $kind "$tmp/$kind/%05d.png" "$cap/imu.csv" "$tmp/meta.json" "$tmp/frames30.csv" ||
        { cat "$tmp/$kind.import.log"; exit 1; }
done

expect_fit() { # NAME WORDS: exit 2, the words in the message, no face directory
    "$sp" fit "$tmp/$1.spcap" -o "$tmp/face-$1" --no-progress >"$tmp/$1.log" 2>&1
    local rc=$?
    if [ $rc = 2 ] && grep -q "$2" "$tmp/$1.log" && [ ! -e "$tmp/face-$1" ]; then
        echo "ok: $1: $(grep -m1 error "$tmp/$1.log")"
    elif [ $rc != 0 ] && grep -q "no dlib" "$tmp/$1.log" && [ "$1" != black ]; then
        echo "skip: $1 needs dlib"
    else
        echo "FAILED: $1: exit $rc, face dir $( [ -e "$tmp/face-$1" ] && echo left || echo absent ), expected '$2'"
        cat "$tmp/$1.log"
        fail=1
    fi
}
expect_fit black "frames are too dark"
expect_fit noface "a face was found in 0 of"
expect_fit few "need at least 5"

imp rot "$cap/frames/%05d.png" "$cap/imu.csv" "$tmp/not-a-rotation.json"
rc=$?
if [ $rc = 2 ] && grep -q "to_camera" "$tmp/rot.import.log" && [ ! -e "$tmp/rot.spcap" ]; then
    echo "ok: not a rotation: $(grep -m1 to_camera "$tmp/rot.import.log")"
else
    echo "FAILED: an imu.to_camera that is not a rotation: import exit $rc"; cat "$tmp/rot.import.log"; fail=1
fi
exit $fail
