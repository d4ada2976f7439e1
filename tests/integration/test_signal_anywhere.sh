#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# SIGINT and SIGTERM at random points of every command that writes output (tools/sunprobe.c: recover,
# replay, import, check, export-video, synth turn/street/selfie, texture, fit, relight, evaluate, export,
# probe, composite, retexture, depopulate, repopulate, cutouts, record; not evaluate, which needs a
# capture laid out as ../shared/captures and a face fitted to it). Each run is short (a second or two) so
# the points fall anywhere from the start to the final rename. A run the signal ends exits 128 + N and
# leaves its directory byte for byte as before - or, when the signal came after the last rename (the
# process ends either way), exactly the outputs an uninterrupted run makes and no "nothing written"; a
# run that finished first exits 0 with those outputs. record stops on a signal by design: exit 0 and a
# capture that verifies, or, for a signal before the capture file exists, 128+N and nothing written. The points come from a seed, printed: SP_SIGNAL_SEED=N re-runs the same points.
# Usage: test_signal_anywhere.sh SUNPROBE [POINTS_PER_COMMAND (default 4)]
set -u
SP=$(cd "$(dirname "$1")" && pwd)/$(basename "$1") # the runs below start in another directory
points=${2:-4}
seed=${SP_SIGNAL_SEED:-$(($(date +%s%N) % 1000000))}
echo "seed $seed (re-run these points: SP_SIGNAL_SEED=$seed $0 $*)"
RANDOM=$seed
. "$(dirname "$0")/cli_lib.sh" sig-any
pid=
trap '[ -n "$pid" ] && kill -KILL "$pid" 2>/dev/null; rm -rf "$dir"' EXIT # a run still going is ended too
snapshot() { (cd "$1" && find . -mindepth 1 | sort && find . -type f -exec md5sum {} + | sort) }
names() { (cd "$1" && find . -mindepth 1 | sort) }
I=$dir/in
mkdir -p "$I"
q() { "$@" >/dev/null 2>"$dir/setup-err.txt" || { echo "setup failed: $*"; cat "$dir/setup-err.txt"; exit 1; }; }

# ---- inputs (what the commands read), small so each run takes a second or two
q "$SP" synth turn -o "$I/cap.spcap" --width 64 --height 48 --turn-seconds 20 --fps 30
q "$SP" export-video "$I/cap.spcap" -o "$I/imgs" --max-frames 1 -q
cp "$I/cap.spcap" "$I/damaged.spcap"
printf '\xff' | dd of="$I/damaged.spcap" bs=1 seek=$(($(stat -c %s "$I/cap.spcap") / 2)) conv=notrunc status=none
q "$SP" synth turn -o "$I/vga.spcap" --width 640 --height 480 --turn-seconds 2 --fps 30
q "$SP" export-video "$I/vga.spcap" -o "$I/vga" -q
# a street long enough for a ground plane (retexture), its first frame, its probe and its people
q "$SP" synth street -o "$I/street.spcap" --seconds 20
q "$SP" export-video "$I/street.spcap" -o "$I/sf" --max-frames 1 -q
q "$SP" probe "$I/street.spcap" -o "$I/probe" -q
q "$SP" cutouts "$I/street.spcap" --probe "$I/probe" -o "$I/coll" --min-height 4 -q
FIT="--keyframes 4 --heldout 1 --texture 16 --refine 0 --face generic --no-dlib --no-progress --threads 1"
selfie=1
if "$SP" synth selfie -o "$I/sel.spcap" --turn-seconds 4 --width 64 --height 64 --relit 1 --novel 0 \
    >/dev/null 2>"$dir/setup-err.txt"; then
    q "$SP" fit "$I/sel.spcap" -o "$I/face" $FIT
    q "$SP" relight "$I/face" -o "$I/cut.png" --supersample 1
else
    selfie=0
    echo "note: SKIP synth selfie, fit, relight, evaluate, export, composite: $(head -1 "$dir/setup-err.txt")"
fi

# name | the previous output, made in w by a run before (empty: none; then w holds an unrelated file) | the
# run (in w; its output replaces the previous one where both are named alike)
cases=(
    "recover|$SP recover $I/damaged.spcap -o old.spcap|$SP recover $I/damaged.spcap -o r.spcap"
    "replay|$SP replay $I/cap.spcap --stage orientation -o o.csv|$SP replay $I/cap.spcap --stage orientation -o o.csv"
    "import|$SP import $I/imgs -o i.spcap --fps 30 -q|$SP import $I/vga -o i.spcap -f --fps 30 -q"
    "export-video PNG||$SP export-video $I/cap.spcap -o frames -q"
    "export-video avi|$SP export-video $I/cap.spcap -o v.avi --max-frames 2 -q|$SP export-video $I/vga.spcap -o v.avi -f -q"
    "synth turn|$SP synth turn -o t.spcap --width 16 --height 16 --turn-seconds 1|$SP synth turn -o t.spcap --width 320 --height 240 --turn-seconds 4"
    "synth street|$SP synth street -o s.spcap --width 32 --height 32 --seconds 1|$SP synth street -o s.spcap --width 160 --height 120 --seconds 4"
    "texture|$SP texture $I/imgs/frame_000000.png -o t.png --size 32x32|$SP texture $I/imgs/frame_000000.png -o t.png --size 768x768 -f -q"
    "probe|$SP probe $I/street.spcap -o p -q|$SP probe $I/street.spcap -o p --force -q"
    "cutouts|$SP cutouts $I/street.spcap --probe $I/probe -o c --min-height 4 --every 20 -q|$SP cutouts $I/street.spcap --probe $I/probe -o c -f --min-height 4 -q"
    "retexture|$SP retexture $I/probe --texture $I/imgs/frame_000000.png -o rt.png|$SP retexture $I/probe --texture $I/vga/frame_000000.png -o rt.png -f -q"
    "depopulate|$SP depopulate $I/sf/frame_000000.png -o d.png --detector none --box 4,4,8,8 -q|$SP depopulate $I/vga/frame_000000.png -o d.png --detector none --box 200,100,200,200 -q"
    "repopulate|$SP repopulate $I/sf/frame_000000.png --collection $I/coll --probe $I/probe --at 160,200 -o rp.png -q|$SP repopulate $I/sf/frame_000000.png --collection $I/coll --probe $I/probe --count 12 -o rp.png -q"
    "record||$SP record --camera fake:panorama --imu fake --mode static --duration 1.5 --format nv12 --size 160x120 --fps 20 -o rec.spcap"
)
if [ $selfie = 1 ]; then
    cases+=(
        "synth selfie|$SP synth selfie -o f.spcap --turn-seconds 0.5 --still 0 --width 32 --height 32 --relit 1 --novel 0|$SP synth selfie -o f.spcap --turn-seconds 2 --width 64 --height 64 --relit 1 --novel 0"
        "check|$SP check $I/cap.spcap --no-face --json c.json|$SP check $I/sel.spcap --no-face --json c.json"
        "fit||$SP fit $I/sel.spcap -o face $FIT --report fit.json"
        "relight|$SP relight $I/face -o r.png --supersample 1|$SP relight $I/face -o r.png --size 512x512"
        "export|$SP export $I/face -o f.glb|$SP export $I/face -o f.glb --texture-size 1024"
        "composite|$SP composite $I/probe --object $I/cut.png --at 30,40 --height-px 20 -o cp.png -q|$SP composite $I/probe --object $I/cut.png --at 30,40 --height-px 40 --object $I/cut.png --at 60,50 --height-px 30 -o cp.png -q"
    )
fi

# the run uninterrupted in a copy of w, twice: its duration and the outputs it makes (the files both runs
# made alike are compared byte for byte after a run that finished before its signal; the others by name)
reference() { # cmd; sets ref_ms, ref_names, ref_sums
    local i t0
    for i in 1 2; do
        rm -rf "$dir/ref$i" && cp -a "$dir/w" "$dir/ref$i"
        t0=$(date +%s%N)
        (cd "$dir/ref$i" && exec $1) >/dev/null 2>"$dir/err.txt" || { cat "$dir/err.txt"; return 1; }
        [ $i = 1 ] && ref_ms=$((($(date +%s%N) - t0) / 1000000))
    done
    ref_names=$(names "$dir/ref1")
    [ "$ref_names" = "$(names "$dir/ref2")" ] || { echo "two runs made different files"; return 1; }
    ref_sums=$(comm -12 <(cd "$dir/ref1" && find . -type f -exec md5sum {} + | sort) \
                        <(cd "$dir/ref2" && find . -type f -exec md5sum {} + | sort))
}

# one signal at a random point of the run: returns with `outcome` set to "stopped" or "finished"
run() { # name signal cmd
    local name=$1 sig=$2 cmd=$3 before want delay_ms rc
    before=$(snapshot "$dir/w")
    want=$((128 + $(kill -l "$sig")))
    delay_ms=$(((RANDOM * 32768 + RANDOM) % (ref_ms + 1)))
    set -m # the run gets SIGINT's default action, as from a terminal (a script's background jobs ignore it)
    (cd "$dir/w" && exec $cmd) >"$dir/out.txt" 2>"$dir/err.txt" &
    pid=$!
    set +m # no job-control notices in the log
    sleep "$(printf '%d.%03d' $((delay_ms / 1000)) $((delay_ms % 1000)))"
    kill "-$sig" "$pid" 2>/dev/null
    for _ in $(seq 1 6000); do kill -0 "$pid" 2>/dev/null || break; sleep 0.01; done
    kill -0 "$pid" 2>/dev/null && { kill -KILL "$pid"; fail "$name: still running 60 s after SIG$sig"; }
    wait "$pid"
    rc=$?
    pid=
    local at="$name, SIG$sig at ${delay_ms} ms of ${ref_ms}"
    if [ "$name" = record ] && [ $rc = "$want" ] && [ "$(snapshot "$dir/w")" = "$before" ]; then
        outcome=stopped # the signal came before the capture file existed (while the devices were opened)
    elif [ "$name" = record ]; then # a signal ends the recording: exit 0, a capture that verifies
        outcome=stopped
        [ $rc = 0 ] || { fail "$at: exit $rc, expected 0"; sed 's/^/  | /' "$dir/err.txt"; }
        [ "$(names "$dir/w")" = "$ref_names" ] || { fail "$at: files"; diff <(echo "$ref_names") <(names "$dir/w"); }
        "$SP" verify "$dir/w/rec.spcap" >/dev/null 2>&1 || fail "$at: the capture does not verify"
        rm -f "$dir/w/rec.spcap"
    elif [ $rc = "$want" ] && [ "$(snapshot "$dir/w")" = "$before" ]; then
        outcome=stopped
    elif [ $rc = "$want" ] || [ $rc = 0 ]; then # finished first, or stopped after its last rename
        outcome=finished
        [ $rc = 0 ] || ! grep -q "nothing written" "$dir/err.txt" ||
            fail "$at: says 'nothing written' but replaced the outputs"
        [ "$(names "$dir/w")" = "$ref_names" ] || { fail "$at: exit $rc with other files than a whole run makes";
                                                   diff <(echo "$ref_names") <(names "$dir/w") | head; }
        local missing
        missing=$(comm -23 <(echo "$ref_sums") <(cd "$dir/w" && find . -type f -exec md5sum {} + | sort))
        [ -z "$missing" ] || { fail "$at: exit $rc with outputs unlike a whole run's"; echo "$missing" | head -3; }
        rm -rf "$dir/w" && cp -a "$dir/prev" "$dir/w" # the previous outputs again for the next point
    else
        outcome=wrong
        fail "$at: exit $rc, expected $want (or 0 had it finished first)"; sed 's/^/  | /' "$dir/err.txt"
    fi
}

total=0 stopped=0
for c in "${cases[@]}"; do
    IFS='|' read -r name old cmd <<<"$c"
    rm -rf "$dir/w" && mkdir "$dir/w"
    echo keep >"$dir/w/unrelated.txt"
    if [ -n "$old" ]; then
        (cd "$dir/w" && exec $old) >/dev/null 2>"$dir/err.txt"
        rc=$?
        [ $rc = 4 ] && { echo "note: SKIP $name: $(head -1 "$dir/err.txt")"; continue; } # feature not built
        [ $rc = 0 ] || { fail "$name: the run before failed (exit $rc)"; cat "$dir/err.txt"; continue; }
    fi
    rm -rf "$dir/prev" && cp -a "$dir/w" "$dir/prev"
    if ! reference "$cmd" >"$dir/ref-err.txt"; then
        if grep -q "not built\|left out\|-D[a-z_]*=enabled" "$dir/ref-err.txt"; then
            echo "note: SKIP $name: $(head -1 "$dir/ref-err.txt")"
        else
            fail "$name: the uninterrupted run failed"; sed 's/^/  | /' "$dir/ref-err.txt"
        fi
        continue
    fi
    n_stop=0 n_fin=0
    for k in $(seq 1 "$points"); do
        sig=INT
        [ $((k % 2)) = 0 ] && sig=TERM
        run "$name" "$sig" "$cmd"
        case $outcome in stopped) n_stop=$((n_stop + 1)) ;; finished) n_fin=$((n_fin + 1)) ;; esac
        total=$((total + 1))
    done
    stopped=$((stopped + n_stop))
    echo "$name: ${ref_ms} ms a run; $n_stop stopped, $n_fin finished (or stopped after the last rename)"
done
echo "$total signals, $stopped of them stopped a run; seed $seed"
[ "$fails" -eq 0 ] || { echo "$fails check(s) failed (seed $seed)"; exit 1; }
echo "all signal-anywhere checks passed"
