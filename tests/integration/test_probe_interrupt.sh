#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Ctrl-C during `sunprobe probe`: SIGINT (then SIGTERM) sent while the frames stream ends the run
# with exit code 128 + the signal, removes DIR.partial.PID and leaves an existing DIR untouched.
# SIGKILL cannot be caught: the partial directory stays until the next run into DIR removes it.
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

start_probe() { # signal-name; sets pid once DIR.partial.PID exists (the frame loop is about to start)
    "$SP" probe "$dir/long.spcap" -o "$dir/out" --force -q >"$dir/o.txt" 2>"$dir/e.txt" &
    pid=$!
    local seen=0
    for _ in $(seq 1 3000); do
        if [ -d "$dir/out.partial.$pid" ]; then seen=1; break; fi
        kill -0 "$pid" 2>/dev/null || break
        sleep 0.01
    done
    [ "$seen" = 1 ] || fail "$1: $dir/out.partial.$pid never appeared"
}

interrupt() { # signal-name expected-exit-code
    start_probe "$1"
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
start_probe KILL
kill -KILL "$pid" 2>/dev/null
wait "$pid" 2>/dev/null
killed=$pid
[ -d "$dir/out.partial.$killed" ] || fail "KILL: expected the partial directory to stay behind"
# the same capture without a signal completes (the run above was long enough to be interrupted)
"$SP" probe "$dir/long.spcap" -o "$dir/out" --force -q --max-frames 200 >/dev/null 2>&1 || fail "uninterrupted run"
[ -e "$dir/out/probe.json" ] || fail "uninterrupted run wrote no probe.json"
[ -d "$dir/out.partial.$killed" ] && fail "the next run did not remove the killed run's partial directory"
# Ctrl-C during `sunprobe import` is the same contract: 128 + the signal, no partial file, the old output kept
"$SP" export-video "$dir/long.spcap" -o "$dir/pngs" -q >/dev/null 2>&1 || fail "export-video for the import case"
echo old >"$dir/imp.spcap"
"$SP" import "$dir/pngs/frame_%06d.png" -o "$dir/imp.spcap" -f --fps 25 -q >"$dir/o.txt" 2>"$dir/e.txt" &
pid=$!
seen=0
for _ in $(seq 1 3000); do
    if [ -e "$dir/imp.spcap.partial" ]; then seen=1; break; fi
    kill -0 "$pid" 2>/dev/null || break
    sleep 0.01
done
if [ "$seen" = 1 ]; then
    kill -INT "$pid" 2>/dev/null
    wait "$pid"
    got=$?
    # a build that cannot decode PNG fails on the first frame, maybe before the signal lands (a race the
    # minimal CI build lost once): that is exit 4, not an interrupted import
    if [ "$got" -eq 4 ] && grep -q "needs OpenCV" "$dir/e.txt"; then
        echo "note: the import case's signal not tested: this build cannot decode PNG"
    elif [ "$got" -ne 130 ]; then
        fail "import INT: exit $got, expected 130"
        sed 's/^/  | /' "$dir/e.txt"
    fi
    [ -e "$dir/imp.spcap.partial" ] && fail "import INT: partial file left behind"
    [ "$(cat "$dir/imp.spcap")" = old ] || fail "import INT: the existing output was replaced"
else
    wait "$pid"
    got=$?
    if [ "$got" -eq 4 ]; then
        echo "note: SKIP the import case: this build cannot import PNG frames"
    else
        fail "import: $dir/imp.spcap.partial never appeared (exit $got)"; sed 's/^/  | /' "$dir/e.txt"
    fi
fi

[ "$fails" -eq 0 ] && echo "probe interrupt: all passed"
[ "$fails" -eq 0 ]
