#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Ctrl-C in synth turn/street/selfie and export-video (PNG and .avi): SIGINT, sent once the run's
# temporary output exists (its handler is installed by then), ends it with exit 130; the previous
# outputs stay byte for byte and nothing of the run is left (no .partial, .new.PID, .tmp.PID, no
# half-written truth directory, no frames directory). Each run is far longer than the test waits.
set -u
SP=$(cd "$(dirname "$1")" && pwd)/$(basename "$1") # the runs below start in another directory
dir=$(mktemp -d "${TMPDIR:-/tmp}/sp-int-out.XXXXXX")
trap 'kill "$pid" 2>/dev/null; rm -rf "$dir"' EXIT
pid=
fails=0
fail() { echo "FAIL: $*"; fails=$((fails + 1)); }
snapshot() { (cd "$dir/w" && find . -mindepth 1 | sort && find . -type f -exec md5sum {} + | sort) }

# run NAME GLOB command...: in $dir/w, waits until a file matching GLOB appears, sends SIGINT, checks
# exit 130 and that $dir/w holds exactly what it held before
run() {
    local name=$1 glob=$2; shift 2
    local before
    before=$(snapshot)
    (cd "$dir/w" && exec "$@") >"$dir/out.txt" 2>"$dir/err.txt" &
    pid=$!
    local seen=0
    for _ in $(seq 1 3000); do
        compgen -G "$dir/w/$glob" >/dev/null && { seen=1; break; }
        kill -0 "$pid" 2>/dev/null || break
        sleep 0.01
    done
    [ $seen = 1 ] || fail "$name: no $glob appeared"
    kill -INT "$pid" 2>/dev/null
    for _ in $(seq 1 3000); do # a run that ignores the signal would go on for an hour
        kill -0 "$pid" 2>/dev/null || break
        sleep 0.01
    done
    kill -0 "$pid" 2>/dev/null && { kill -KILL "$pid"; fail "$name: still running 30 s after SIGINT"; }
    wait "$pid"
    local rc=$?
    pid=
    [ $rc = 130 ] || { fail "$name: exit $rc, expected 130"; sed 's/^/  | /' "$dir/err.txt"; }
    grep -q "interrupted" "$dir/err.txt" || fail "$name: no 'interrupted' message"
    [ "$(snapshot)" = "$before" ] || { fail "$name: changed or left files"; diff <(echo "$before") <(snapshot); }
}

mkdir "$dir/w"
cd "$dir/w" || exit 1
# previous outputs: short runs of each command
"$SP" synth turn -o t.spcap --width 16 --height 16 --turn-seconds 1 >/dev/null || exit 1
"$SP" synth street -o s.spcap --width 32 --height 32 --seconds 1 >/dev/null || exit 1
"$SP" synth turn -o long.spcap --width 64 --height 48 --turn-seconds 200 --fps 30 >/dev/null || exit 1

run "synth turn" 't.spcap.partial' "$SP" synth turn -o t.spcap --width 16 --height 16 --format gray8 \
    --turn-seconds 3600 --fps 240
run "synth street" 's.spcap?*' "$SP" synth street -o s.spcap --width 32 --height 32 --fps 240 --seconds 36000
run "export-video PNG" 'frames/frame_*' "$SP" export-video long.spcap -o frames -q

if "$SP" export-video t.spcap -o v.avi -q >/dev/null 2>&1; then
    run "export-video avi" 'v.partial.avi' "$SP" export-video long.spcap -o v.avi -f -q
else
    echo "note: SKIP export-video .avi: this build has no OpenCV"
fi

# synth selfie: a capture and its truth directory (needs a JPEG encoder for its default MJPEG frames)
if "$SP" synth selfie -o f.spcap --turn-seconds 0.5 --still 0 --width 32 --height 32 --relit 1 --novel 0 \
    >/dev/null 2>"$dir/err.txt"; then
    run "synth selfie" 'f.spcap.partial' "$SP" synth selfie -o f.spcap --turn-seconds 3600 --width 32 --height 32
else
    echo "note: SKIP synth selfie: $(head -1 "$dir/err.txt")"
fi

[ "$fails" -eq 0 ] || { echo "$fails check(s) failed"; exit 1; }
echo "all interrupt checks passed"
