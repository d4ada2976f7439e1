#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# `sunprobe devices` and `sunprobe record` end to end with the fake camera and IMU: a timed recording,
# SIGINT and SIGTERM mid-recording (valid files, exit 0), a slowed writer (drops counted), the live
# capture check of selfie mode, bad arguments and missing devices (documented exit codes).
set -u
SP=$1
dir=$(mktemp -d "${TMPDIR:-/tmp}/sp-record.XXXXXX")
trap 'rm -rf "$dir"' EXIT
fails=0

expect() { # expected-exit-code description command...
    local want=$1 what=$2; shift 2
    "$@" >"$dir/out.txt" 2>"$dir/err.txt"
    local got=$?
    if [ "$got" -ne "$want" ]; then
        echo "FAIL: $what: exit $got, expected $want"; sed 's/^/  | /' "$dir/out.txt" "$dir/err.txt"
        fails=$((fails + 1))
    fi
}
contains() { # file pattern description
    grep -qE "$2" "$1" || { echo "FAIL: $3: no /$2/ in output"; sed 's/^/  | /' "$1"; fails=$((fails + 1)); }
}

expect 0 "devices" "$SP" devices
contains "$dir/out.txt" "\[fake\] fake: sunprobe test pattern" "devices lists the fake camera"
contains "$dir/out.txt" "yuyv +320x240@1000" "devices lists formats and sizes"
contains "$dir/out.txt" "channels: anglvel_x" "devices lists IMU channels"

cap=$dir/a.spcap
expect 0 "record fake" "$SP" record --camera fake:panorama --imu fake --mode static --duration 1.5 \
    --format nv12 --size 160x120 --fps 20 --lock-exposure -o "$cap"
contains "$dir/out.txt" "ended: duration reached" "record says how it ended"
expect 0 "verify" "$SP" verify "$cap"
expect 0 "info" "$SP" info "$cap"
contains "$dir/out.txt" "frames\[0\]: +[0-9]+ nv12 160x120" "frames as negotiated"
contains "$dir/out.txt" "kind: +static" "META kind"
contains "$dir/out.txt" "imu gyro +[0-9]+ samples" "IMU samples recorded"
contains "$dir/out.txt" "closed cleanly" "END chunk"
expect 1 "refuses to overwrite (EEXIST)" "$SP" record --camera fake --duration 0.2 -o "$cap"
[ -s "$cap" ] || { echo "FAIL: an existing capture was clobbered"; fails=$((fails + 1)); }

for sig in INT TERM; do
    out=$dir/sig-$sig.spcap
    "$SP" record --camera fake --size 160x120 -o "$out" >"$dir/out.txt" 2>&1 &
    pid=$!
    for _ in $(seq 50); do [ -s "$out" ] && break; sleep 0.1; done
    sleep 0.5
    kill -$sig $pid
    wait $pid
    rc=$?
    [ $rc -eq 0 ] || { echo "FAIL: record after SIG$sig exited $rc"; cat "$dir/out.txt"; fails=$((fails + 1)); }
    contains "$dir/out.txt" "ended: stopped" "SIG$sig stops the recording"
    expect 0 "verify after SIG$sig" "$SP" verify "$out"
done

expect 0 "slow writer" "$SP" record --camera fake --size 160x120 --fps 100 --duration 1 --queue 2 \
    --writer-delay-us 40000 -o "$dir/slow.spcap"
contains "$dir/out.txt" " [1-9][0-9]* dropped by the writer queue" "a slow writer drops and counts"
expect 0 "verify slow" "$SP" verify "$dir/slow.spcap"

# selfie mode checks the capture as it is recorded: a live line while recording (off a terminal, every
# 2 s), then the verdict `sunprobe check` gives on the finished file, item for item. Without the
# landmark tracker (--no-face), whose model takes seconds to load on a busy machine.
live=$dir/live.spcap
expect 0 "record selfie with its live check" "$SP" record --camera fake:panorama --imu fake --duration 5 \
    --size 160x120 --fps 20 --no-face -o "$live"
contains "$dir/err.txt" "^live check: turn [0-9]+ deg of 300 \| face .* \| clipped [0-9]+ % \| gyro [0-9]+ Hz" \
    "a live check line while recording"
contains "$dir/out.txt" "^capture check" "the live check's verdict after the summary"
cp "$dir/err.txt" "$dir/live-err.txt"
sed -n '/^capture check/,$p' "$dir/out.txt" | grep -v "^capture check" >"$dir/live-verdict.txt"
expect 2 "check the selfie (5 s of a 12 s turn cannot work)" "$SP" check --no-face "$live"
sed "s|^$live: ||" "$dir/out.txt" >"$dir/check-verdict.txt"
if ! diff "$dir/live-verdict.txt" "$dir/check-verdict.txt" >"$dir/diff.txt"; then
    echo "FAIL: the live check's verdict differs from sunprobe check's"; sed 's/^/  | /' "$dir/diff.txt"
    fails=$((fails + 1))
fi
contains "$dir/live-verdict.txt" "^FAIL turn .*re-shoot turning a full circle" "the live verdict says what to re-shoot"
last_turn=$(sed -nE 's/^live check: turn ([0-9]+) deg.*/\1/p' "$dir/live-err.txt" | tail -1)
final_turn=$(sed -nE 's/^FAIL turn +([0-9]+) deg turned.*/\1/p' "$dir/live-verdict.txt")
[ -n "$last_turn" ] && [ -n "$final_turn" ] && [ "$last_turn" -le "$final_turn" ] && [ "$final_turn" -gt 0 ] ||
    { echo "FAIL: live turn '$last_turn' deg then '$final_turn' deg at the end"; fails=$((fails + 1)); }
# a check behind the camera skips the tracker on frames older than --live-max-lag (0: every one), says so
expect 0 "record selfie, live check always behind" "$SP" record --camera fake --imu fake --duration 1 \
    --size 160x120 --live-max-lag 0 -o "$dir/lag.spcap"
if grep -q "no dlib tracker" "$dir/out.txt"; then
    echo "note: no landmark tracker in this build; the skipping is not exercised"
else
    contains "$dir/out.txt" "^warn face +not looked for \([1-9][0-9]* sampled frames skipped: the check was behind" \
        "frames skipped by a live check that is behind are counted and said"
fi
expect 0 "record selfie without the live check" "$SP" record --camera fake --imu fake --duration 0.5 \
    --size 160x120 --no-live-check -o "$dir/quiet.spcap"
if grep -qE "^live check|^capture check" "$dir/out.txt" "$dir/err.txt"; then
    echo "FAIL: --no-live-check still checked"; fails=$((fails + 1))
fi

expect 1 "no output" "$SP" record --camera fake
expect 1 "bad size" "$SP" record --camera fake --size 0x10 -o "$dir/x.spcap"
expect 1 "bad mode" "$SP" record --camera fake --mode movie -o "$dir/x.spcap"
expect 1 "bad fake option" "$SP" record --camera fake:nonsense --duration 0.1 -o "$dir/x.spcap"
expect 3 "no such camera" "$SP" record --camera no-such-camera --duration 0.1 -o "$dir/x.spcap"
expect 3 "no such imu" "$SP" record --camera fake --imu no-such-imu --duration 0.1 -o "$dir/y.spcap"
if "$SP" record --help | grep -q . && "$SP" devices --help | grep -q "v4l2"; then
    expect 3 "missing V4L2 node" "$SP" record --camera /dev/video-sunprobe-missing -o "$dir/z.spcap"
else
    expect 4 "V4L2 not built" "$SP" record --camera /dev/video-sunprobe-missing -o "$dir/z.spcap"
fi

echo "record-cli: $fails failure(s)"
[ $fails -eq 0 ]
