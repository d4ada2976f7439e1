#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Every writing command (tools/sunprobe.c) against a full file system and a read-only one (a small tmpfs in
# a private mount namespace; skipped with 77 where mounting is not permitted): exit code 3, a message naming
# the cause and the output's path, the previous output byte for byte, and nothing of the run left behind.
set -u
SP=$1
if [ -z "${SP_FULL_FS_NS:-}" ]; then
    if ! unshare -m true 2>/dev/null; then
        echo "SKIP: mounting a tmpfs is not permitted here (needs CAP_SYS_ADMIN; CI runs as root)"
        exit 77
    fi
    SP_FULL_FS_NS=1 exec unshare -m bash "$0" "$@"
fi
dir=$(mktemp -d "${TMPDIR:-/tmp}/sp-full-fs.XXXXXX")
M=$dir/mnt
trap 'umount "$M" 2>/dev/null; rm -rf "$dir"' EXIT
fails=0
fail() { echo "FAIL: $*"; fails=$((fails + 1)); }
snapshot() { (cd "$M" && find . -mindepth 1 ! -name fill | sort && find . -type f ! -name fill -exec md5sum {} + | sort) }

# the inputs, and each command's previous output made in $dir/prev (copied into the tmpfs below)
mkdir "$dir/prev" "$M"
P=$dir/prev
"$SP" synth turn -o "$dir/cap.spcap" --width 32 --height 24 --turn-seconds 1 --fps 10 >/dev/null || exit 1
"$SP" synth street -o "$dir/street.spcap" --width 64 --height 48 --seconds 4 --figures 2 >/dev/null || exit 1
"$SP" export-video "$dir/cap.spcap" -o "$dir/imgs" --max-frames 3 -q || exit 1
"$SP" export-video "$dir/street.spcap" -o "$dir/sf" --max-frames 1 -q || exit 1
cp "$dir/cap.spcap" "$dir/damaged.spcap"
printf '\xff' | dd of="$dir/damaged.spcap" bs=1 seek=$(($(stat -c %s "$dir/cap.spcap") / 2)) conv=notrunc status=none
# a fitted face, its render as a cut-out, a street frame and a probe (what fit ... depopulate read); a build
# that cannot make them (no JPEG encoder for the selfie) leaves their cases out below
FIT="--keyframes 4 --heldout 1 --texture 16 --refine 0 --face generic --no-dlib --no-progress --threads 1"
"$SP" synth selfie -o "$dir/sel.spcap" --turn-seconds 4 --width 64 --height 64 --relit 1 --novel 0 >/dev/null 2>&1 &&
    "$SP" fit "$dir/sel.spcap" -o "$dir/face" $FIT >/dev/null 2>&1 &&
    "$SP" relight "$dir/face" -o "$dir/cut.png" --supersample 1 >/dev/null 2>&1
"$SP" export-video "$dir/street.spcap" -o "$dir/simgs" --max-frames 1 -q
"$SP" probe "$dir/street.spcap" -o "$dir/probe" -q
# a street long enough for a ground plane (what retexture replaces)
"$SP" synth street -o "$dir/ground.spcap" --seconds 20 >/dev/null && "$SP" probe "$dir/ground.spcap" -o "$dir/gprobe" -q

# name: output(s) kept from before | command with @ for the tmpfs (run once into $P first, for the old output)
cases=(
    "synth turn|@/t.spcap|$SP synth turn -o @/t.spcap --width 32 --height 24 --turn-seconds 2"
    "synth street|@/s.spcap|$SP synth street -o @/s.spcap --width 64 --height 48 --seconds 3 --figures 1"
    "replay stats|@/st.csv|$SP replay $dir/cap.spcap --stage stats -o @/st.csv"
    "recover|@/r.spcap|$SP recover $dir/damaged.spcap -o @/r.spcap"
    "export-video PNG|@/frames|$SP export-video $dir/cap.spcap -o @/frames -q"
    "export-video avi|@/v.avi|$SP export-video $dir/cap.spcap -o @/v.avi -f -q"
    "import|@/i.spcap|$SP import $dir/imgs -o @/i.spcap -f --fps 10 -q"
    "probe|@/p|$SP probe $dir/street.spcap -o @/p --force -q"
    "cutouts|@/c|$SP cutouts $dir/street.spcap --probe $P/p -o @/c -f --min-height 4 --every 5 -q"
    "repopulate|@/rp.png|$SP repopulate $dir/sf/frame_000000.png --collection $P/c --probe $P/p --at 40,39 -o @/rp.png -q"
    "synth selfie|@/f.spcap|$SP synth selfie -o @/f.spcap --turn-seconds 0.5 --still 0 --width 32 --height 32 --relit 1 --novel 0"
    "fit|@/face|$SP fit $dir/sel.spcap -o @/face $FIT"
    "relight|@/r.png|$SP relight $dir/face -o @/r.png --supersample 1"
    "export|@/f.glb|$SP export $dir/face -o @/f.glb"
    "composite|@/c.png|$SP composite $dir/probe --object $dir/cut.png --at 30,40 --height-px 20 -o @/c.png -q"
    "depopulate|@/d.png|$SP depopulate $dir/simgs/frame_000000.png -o @/d.png --detector none --box 10,10,8,16 -q"
    "texture|@/t.png|$SP texture $dir/imgs/frame_000000.png -o @/t.png --size 40x40 -f -q"
    "retexture|@/rt.png|$SP retexture $dir/gprobe --texture $dir/imgs/frame_000000.png -o @/rt.png -f -q"
    "check|@/c.json|$SP check $dir/sel.spcap --no-face --json @/c.json"
    "record|@/rec.spcap|$SP record --camera fake --imu fake --duration 0.5 --size 160x120 --fps 20 -o @/rec.spcap"
)
runnable=()
for c in "${cases[@]}"; do
    IFS='|' read -r name _ cmd <<<"$c"
    # the old output; a case this build cannot run (no OpenCV, no JPEG encoder, no PNG decoder) is left out
    rm -rf "$P.new" && mkdir "$P.new"
    if bash -c "${cmd//@/$P.new}" >/dev/null 2>"$dir/err.txt"; then
        cp -a "$P.new/." "$P/"
        runnable+=("$c")
    else
        echo "note: SKIP $name: $(head -1 "$dir/err.txt")"
    fi
done
# export-video PNG makes its directory, recover -o its copy, fit its face directory and record its capture:
# none replaces an old one
rm -rf "$P/frames" "$P/r.spcap" "$P/face" "$P/rec.spcap"

check() { # how expected-message
    local how=$1 want=$2
    for c in "${runnable[@]}"; do
        IFS='|' read -r name _ cmd <<<"$c"
        local before
        before=$(snapshot)
        bash -c "${cmd//@/$M}" >"$dir/out.txt" 2>"$dir/err.txt"
        local rc=$?
        [ $rc = 3 ] || { fail "$name on a $how file system: exit $rc, expected 3"; sed 's/^/  | /' "$dir/err.txt"; }
        grep -qi "$want" "$dir/err.txt" || { fail "$name on a $how file system: no '$want'"; sed 's/^/  | /' "$dir/err.txt"; }
        grep -q "$M/" "$dir/err.txt" || { fail "$name on a $how file system: the message names no output"; sed 's/^/  | /' "$dir/err.txt"; }
        [ "$(snapshot)" = "$before" ] || { fail "$name on a $how file system: outputs changed or left";
                                           diff <(echo "$before") <(snapshot) | head; }
    done
}

mount -t tmpfs -o size=64m tmpfs "$M" || { echo "SKIP: mount -t tmpfs failed"; exit 77; }
cp "$dir/damaged.spcap" "$P/dmg.spcap" # what recover in place repairs
cp -a "$P/." "$M/" || { echo "the previous outputs do not fit a 64 MB tmpfs"; exit 1; }
mount -o remount,ro "$M" || exit 1
check "read-only" "read-only file system"
# recover in place: refused on a read-only file system (the capture as it was); on a full one it only cuts
in_place() { # how expected-exit-code expected-message
    "$SP" recover "$M/dmg.spcap" >"$dir/out.txt" 2>"$dir/err.txt"
    local rc=$?
    [ $rc = "$2" ] || { fail "recover in place on a $1 file system: exit $rc, expected $2"; sed 's/^/  | /' "$dir/err.txt"; }
    grep -qi "$3" "$dir/err.txt" "$dir/out.txt" || { fail "recover in place on a $1 file system: no '$3'"; sed 's/^/  | /' "$dir/err.txt"; }
    [ -z "$(cd "$M" && find . -name '*.tmp*' -o -name '*.partial*' -o -name '*.new.*')" ] ||
        fail "recover in place on a $1 file system: left temporaries"
}
in_place "read-only" 3 "read-only file system"
cmp -s "$M/dmg.spcap" "$dir/damaged.spcap" || fail "recover in place on a read-only file system changed the capture"
mount -o remount,rw "$M" || exit 1
dd if=/dev/zero of="$M/fill" bs=4k status=none 2>/dev/null # until it is full
check "full" "no space left on device"
in_place "full" 0 "kept"
"$SP" verify "$M/dmg.spcap" >/dev/null 2>&1 || fail "recover in place on a full file system: the capture does not verify"

echo "${#runnable[@]} of ${#cases[@]} commands checked"
[ "$fails" -eq 0 ] || { echo "$fails check(s) failed"; exit 1; }
echo "all full and read-only file-system checks passed"
