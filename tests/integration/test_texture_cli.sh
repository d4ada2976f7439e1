#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# sunprobe texture from the command line: a PNG of the asked size, the same bytes for 1 and 2 threads,
# and bad input refused with the documented exit code and a message naming the option or file; a write
# limit and a full tmpfs (where mounting is permitted) end with exit 3, the old output kept byte for
# byte and no partial file left.
set -u
SP=$1 MK=$2
. "$(dirname "$0")/cli_lib.sh" texture
trap 'umount "$dir/mnt" 2>/dev/null; rm -rf "$dir"' EXIT # the full-tmpfs case mounts inside $dir
# case-insensitive, unlike cli_lib.sh's contains: messages are matched by their words
contains() { grep -qiE -- "$2" "$1" || { fail "$3: no /$2/ in output"; sed 's/^/  | /' "$1"; }; }
write_limit() { # OUT KiB SIZE expected-message: exit 3 under ulimit -f, OUT kept byte for byte, nothing partial
    cp "$1" "$dir/old"
    expect 3 "$1 under a write limit" bash -c 'ulimit -f "$3"; trap "" XFSZ; exec "$0" texture "$1" -o "$2" --size "$4" -f -q' \
        "$SP" "$dir/ex.png" "$1" "$2" "$3"
    contains "$dir/err.txt" "$4" "$1 write limit message"
    cmp -s "$1" "$dir/old" || fail "$1 under a write limit: the old texture was changed"
    no_partial "$1 under a write limit"
}
no_partial() { local left; left=$(find "$dir" -name '*.partial*'); [ -z "$left" ] || fail "$1: left behind: $left"; }

"$MK" stones 96 96 "$dir/ex.png" || exit 1
"$MK" stones 6 40 "$dir/thin.png" || exit 1
T=$dir/t.png
expect 0 "texture" "$SP" texture "$dir/ex.png" -o "$T" --size 300x200 --tile 128 --threads 1
head -c 24 "$T" | od -An -tx1 | tr -d ' \n' | grep -q '0000012c000000c8' || fail "texture: not a 300x200 PNG"
expect 0 "texture, 2 threads" "$SP" texture "$dir/ex.png" -o "$dir/t2.png" --size 300x200 --tile 128 --threads 2
cmp -s "$T" "$dir/t2.png" || fail "the thread count changed the texture"
expect 0 "texture, seed 2" "$SP" texture "$dir/ex.png" -o "$dir/t3.png" --size 300x200 --tile 128 --seed 2
cmp -s "$T" "$dir/t3.png" && fail "--seed 2 gave the seed-1 texture"
expect 0 "tileable" "$SP" texture "$dir/ex.png" -o "$dir/tt.png" --size 128x128 --tileable -q

# tiled TIFF and EXR through OpenImageIO: the PNG's pixels, or exit 4 naming the option without it
if "$SP" texture "$dir/ex.png" -o "$dir/t.tif" --size 300x200 --tile 128 -q 2>"$dir/err.txt"; then
    "$MK" same "$T" "$dir/t.tif" || fail "the tiled TIFF differs from the PNG"
    expect 0 "tiled EXR" "$SP" texture "$dir/ex.png" -o "$dir/t.exr" --size 300x200 --tile 128 -q
    "$MK" same "$T" "$dir/t.exr" || fail "the tiled EXR differs from the PNG"
    expect 0 "a TIFF exemplar" "$SP" texture "$dir/t.tif" -o "$dir/t4.png" --size 64x64 -q
    write_limit "$dir/t.tif" 32 1500x1500 "t.tif: writing the texture"
else
    contains "$dir/err.txt" "-Dopenimageio" "TIFF without OpenImageIO"
fi

expect 1 "existing output" "$SP" texture "$dir/ex.png" -o "$T" --size 64x64
contains "$dir/err.txt" "exists.*--force" "existing output"
expect 2 "exemplar smaller than the patch" "$SP" texture "$dir/thin.png" -o "$dir/x.png" --size 64x64
contains "$dir/err.txt" "thin.png: 6x40 is smaller than the 8x8 patch" "exemplar < patch"
expect 1 "size 0" "$SP" texture "$dir/ex.png" -o "$dir/x.png" --size 0x64
contains "$dir/err.txt" "--size 0x64: a side of 0" "size 0"
expect 1 "size over the limit" "$SP" texture "$dir/ex.png" -o "$dir/x.png" --size 2000000x64
contains "$dir/err.txt" "over the limit of 1000000" "size over the limit"
expect 1 "bad size" "$SP" texture "$dir/ex.png" -o "$dir/x.png" --size 64
contains "$dir/err.txt" "--size '64': expected WxH" "bad size"
expect 1 "tileable too small" "$SP" texture "$dir/ex.png" -o "$dir/x.png" --size 100x300 --tileable
contains "$dir/err.txt" "16 patches" "tileable too small"
expect 1 "patch too small" "$SP" texture "$dir/ex.png" -o "$dir/x.png" --size 64x64 --patch 3
contains "$dir/err.txt" "texture: --patch '3': expected" "patch too small" # one pair of dashes
expect 1 "not a PNG name" "$SP" texture "$dir/ex.png" -o "$dir/x.jpg" --size 64x64
expect 2 "exemplar not a PNG" "$SP" texture "$dir/out.txt" -o "$dir/x.png" --size 64x64
expect 3 "missing exemplar" "$SP" texture "$dir/none.png" -o "$dir/x.png" --size 64x64
contains "$dir/err.txt" "none.png" "missing exemplar"
TMPDIR="$dir/no-such-dir" expect 3 "no scratch directory" "$SP" texture "$dir/ex.png" -o "$dir/x.png" --size 64x64
contains "$dir/err.txt" "no-such-dir/sunprobe-texture-.*scratch file" "no scratch directory"
[ -e "$dir/x.png" ] && fail "a refused run left x.png"

# a write limit: the texture does not fit in 64 KiB; the old T stays, nothing partial is left
write_limit "$T" 64 1200x1200 "t.png: writing the texture: (file too large|no space)"

# Ctrl-C mid-way: exit 130, the old texture kept, nothing partial left
cp "$T" "$dir/old"
"$SP" texture "$dir/ex.png" -o "$T" --size 4000x4000 -f -q 2>"$dir/err.txt" &
pid=$!
sleep 1
kill -INT $pid
wait $pid
rc=$?
if [ $rc = 0 ]; then
    echo "note: the texture was finished before the signal came; the interrupt case did not run"
    cp "$dir/old" "$T"
else
    [ $rc = 130 ] || fail "SIGINT: exit $rc, expected 130"
    cmp -s "$T" "$dir/old" || fail "SIGINT: the old texture was changed"
fi
no_partial "SIGINT"

# a really full file system, where mounting a tmpfs is permitted
mkdir "$dir/mnt"
if unshare -m true 2>/dev/null; then
    kb=$(($(stat -c %s "$T") / 1024 + 64)) # room for the kept file (stored, not deflated, without zlib) and a little
    expect 3 "full tmpfs" unshare -m bash -c 'mount -t tmpfs -o size="$4"k tmpfs "$2" || exit 99
        cp "$3" "$2/keep.png"; "$0" texture "$1" -o "$2/big.png" --size 1500x1500; rc=$?
        cmp -s "$3" "$2/keep.png" || { echo "keep.png changed" >&2; exit 98; }
        ls "$2" | grep -q partial && { echo "partial left" >&2; exit 97; }
        exit $rc' "$SP" "$dir/ex.png" "$dir/mnt" "$T" "$kb"
    contains "$dir/err.txt" "big.png: writing the texture: no space left on device" "full tmpfs message"
else
    echo "note: SKIP the full-tmpfs case: mounting a tmpfs is not permitted here (needs CAP_SYS_ADMIN)"
fi
no_partial "all"
[ "$fails" -eq 0 ] && echo "texture CLI: all passed"
exit $((fails > 0))
