#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Ctrl-C during `sunprobe probe`: SIGINT (then SIGTERM) sent while the frames stream ends the run
# with exit code 128 + the signal, removes DIR.partial.PID and leaves an existing DIR untouched.
set -u
SP=$1
dir=$(mktemp -d "${TMPDIR:-/tmp}/sp-probe-int.XXXXXX")
trap 'rm -rf "$dir"' EXIT
fails=0
fail() { echo "FAIL: $*"; fails=$((fails + 1)); }

# a longer capture than the plate's warm-up, small frames: streaming takes a second or more
"$SP" synth street -o "$dir/long.spcap" --width 160 --height 120 --fps 25 --seconds 80 >/dev/null 2>&1 ||
    { echo "synth street failed"; exit 1; }
mkdir "$dir/out"
echo keep >"$dir/out/old.txt"

interrupt() { # signal-name expected-exit-code
    "$SP" probe "$dir/long.spcap" -o "$dir/out" --force -q >"$dir/o.txt" 2>"$dir/e.txt" &
    local pid=$! seen=0
    for _ in $(seq 1 3000); do # wait for the partial directory: the frame loop is about to start
        if [ -d "$dir/out.partial.$pid" ]; then seen=1; break; fi
        kill -0 "$pid" 2>/dev/null || break
        sleep 0.01
    done
    [ "$seen" = 1 ] || fail "$1: $dir/out.partial.$pid never appeared"
    kill "-$1" "$pid" 2>/dev/null
    wait "$pid"
    local got=$?
    [ "$got" -eq "$2" ] || { fail "$1: exit $got, expected $2"; sed 's/^/  | /' "$dir/o.txt" "$dir/e.txt"; }
    grep -q interrupted "$dir/e.txt" || fail "$1: no message"
    ls -d "$dir"/out.partial.* >/dev/null 2>&1 && fail "$1: partial directory left behind"
    [ "$(cat "$dir/out/old.txt" 2>/dev/null)" = keep ] || fail "$1: the existing directory was touched"
    [ -e "$dir/out/probe.json" ] && fail "$1: a result was written"
}
interrupt INT 130
interrupt TERM 143
# the same capture without a signal completes (the run above was long enough to be interrupted)
"$SP" probe "$dir/long.spcap" -o "$dir/out" --force -q --max-frames 200 >/dev/null 2>&1 || fail "uninterrupted run"
[ -e "$dir/out/probe.json" ] || fail "uninterrupted run wrote no probe.json"
[ "$fails" -eq 0 ] && echo "probe interrupt: all passed"
[ "$fails" -eq 0 ]
