#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# SIGINT and SIGTERM at two points of every long-running writing command (fit, probe, import,
# export, export-video, synth, texture, depopulate): exit 130 / 143, the previous outputs byte for
# byte and nothing of the run left (no *.partial*, *.new.*, *.tmp*). Each run is made long enough
# (a big texture, a long capture) that every signal lands while it works.
set -u
SP=$(cd "$(dirname "$1")" && pwd)/$(basename "$1") # the runs below start in another directory
dir=$(mktemp -d "${TMPDIR:-/tmp}/sp-sigmatrix.XXXXXX")
pid=
trap '[ -n "$pid" ] && kill -KILL "$pid" 2>/dev/null; rm -rf "$dir"' EXIT
fails=0
fail() { echo "FAIL: $*"; fails=$((fails + 1)); }
snapshot() { (cd "$dir/w" && find . -mindepth 1 | sort && find . -type f -exec md5sum {} + | sort) }
I=$dir/in
mkdir -p "$I" "$dir/w"
q() { "$@" >/dev/null 2>"$dir/setup-err.txt"; }

# inputs: a long turn and its frames, VGA frames, a long street, a big street frame, a selfie and its face
q "$SP" synth turn -o "$I/long.spcap" --width 64 --height 48 --turn-seconds 120 --fps 30 || exit 1
q "$SP" export-video "$I/long.spcap" -o "$I/frames" --max-frames 1500 -q || exit 1
# import's frames: VGA, so decoding them takes seconds even on an idle machine (1,500 small ones took 0.4 s)
q "$SP" synth turn -o "$I/vga.spcap" --width 640 --height 480 --turn-seconds 40 --fps 30 || exit 1
q "$SP" export-video "$I/vga.spcap" -o "$I/vga" --max-frames 1200 -q || exit 1
q "$SP" synth street -o "$I/street.spcap" --width 160 --height 120 --fps 25 --seconds 300 || exit 1
q "$SP" synth street -o "$I/big.spcap" --width 1280 --height 720 --seconds 0.2 --figures 1 || exit 1
q "$SP" export-video "$I/big.spcap" -o "$I/big" --max-frames 1 -q || exit 1
FIT="--face generic --no-dlib --no-progress"
selfie=1
q "$SP" synth selfie -o "$I/sel.spcap" --turn-seconds 10 --width 96 --height 96 --relit 0 --novel 0 &&
    q "$SP" fit "$I/sel.spcap" -o "$I/face" $FIT --keyframes 4 --heldout 1 --texture 16 --refine 0 ||
    { selfie=0; echo "note: SKIP fit and export: $(head -1 "$dir/setup-err.txt")"; }

# name | the previous output, made in w by a short run (empty: none) | the long run (in w)
cases=(
    "synth turn|$SP synth turn -o t.spcap --width 16 --height 16 --turn-seconds 1|$SP synth turn -o t.spcap --width 64 --height 64 --turn-seconds 3600 --fps 240"
    "export-video|$SP export-video $I/long.spcap -o old-frames --max-frames 2 -q|$SP export-video $I/long.spcap -o frames -q"
    "import|$SP import $I/vga -o i.spcap --fps 30 --max-frames 3 -q|$SP import $I/vga -o i.spcap -f --fps 30 -q"
    "probe|$SP probe $I/street.spcap -o p -q --max-frames 1500|$SP probe $I/street.spcap -o p --force -q"
    "texture|$SP texture $I/frames/frame_000000.png -o t.png --size 32x32|$SP texture $I/frames/frame_000000.png -o t.png --size 6000x6000 -f -q"
    "depopulate|$SP depopulate $I/frames/frame_000000.png -o d.png --detector none --box 4,4,8,8 -q|$SP depopulate $I/big/frame_000000.png -o d.png --detector none --box 300,100,300,300 -q"
)
if [ $selfie = 1 ]; then
    cases+=("fit||$SP fit $I/sel.spcap -o face $FIT --threads 1"
            "export|$SP export $I/face -o f.glb|$SP export $I/face -o f.glb --texture-size 4096")
fi

# one signal at one point: exit 128+N, w as it was
run() { # name signal delay command
    local name=$1 sig=$2 delay=$3 cmd=$4 before want
    before=$(snapshot)
    want=$((128 + $(kill -l "$sig")))
    (cd "$dir/w" && exec $cmd) >"$dir/out.txt" 2>"$dir/err.txt" &
    pid=$!
    sleep "$delay"
    kill -0 "$pid" 2>/dev/null || { wait "$pid"; fail "$name: over before SIG$sig at ${delay}s (exit $?)"; pid=; return; }
    kill "-$sig" "$pid"
    for _ in $(seq 1 6000); do kill -0 "$pid" 2>/dev/null || break; sleep 0.01; done
    kill -0 "$pid" 2>/dev/null && { kill -KILL "$pid"; fail "$name: still running 60 s after SIG$sig"; }
    wait "$pid"
    local rc=$?
    pid=
    [ $rc = "$want" ] || { fail "$name, SIG$sig at ${delay}s: exit $rc, expected $want"; sed 's/^/  | /' "$dir/err.txt"; }
    [ "$(snapshot)" = "$before" ] || { fail "$name, SIG$sig at ${delay}s: changed or left files";
                                       diff <(echo "$before") <(snapshot) | head; }
}

n=0
for c in "${cases[@]}"; do
    IFS='|' read -r name old cmd <<<"$c"
    if [ -n "$old" ]; then
        (cd "$dir/w" && $old) >/dev/null 2>"$dir/err.txt"
        rc=$?
        [ $rc = 4 ] && { echo "note: SKIP $name: $(head -1 "$dir/err.txt")"; continue; } # feature not built
        [ $rc = 0 ] || { fail "$name: the short run failed"; cat "$dir/err.txt"; continue; }
    fi
    t0=$SECONDS
    for sig in INT TERM; do
        for delay in 0.05 0.6; do
            run "$name" "$sig" "$delay" "$cmd"
            n=$((n + 1))
        done
    done
    echo "$name: $((SECONDS - t0)) s"
done
echo "$n signals sent to ${#cases[@]} commands"
[ "$fails" -eq 0 ] || { echo "$fails check(s) failed"; exit 1; }
echo "all signal-matrix checks passed"
