#!/bin/sh
# SPDX-License-Identifier: MIT
# Downloads the ICT Face Model (the FaceXModel folder of ICT-FaceKit, MIT License,
# https://github.com/ICT-VGL/ICT-FaceKit) into DIR, for sunprobe's face fitting.
# sunprobe never ships these files; it reads them at run time from
# $SP_ICT_FACEKIT_DIR (default: ../shared/face-models/ict-facekit beside the source tree).
#
#   tools/fetch-ict-facekit.sh [--minimal] DIR
#
# Default: downloads the repository archive (a few hundred MB) and keeps FaceXModel/
# plus the LICENSE. --minimal: fetches only what the importer reads by default
# (neutral mesh, 100 identity modes, 10 expressions, LICENSE), one file at a time.
# ICT_FACEKIT_REF selects a branch, tag or commit (default: master).
set -eu

REPO="ICT-VGL/ICT-FaceKit"
REF="${ICT_FACEKIT_REF:-master}"
EXPRESSIONS="jawOpen mouthSmile_L mouthSmile_R eyeBlink_L eyeBlink_R browInnerUp_L browInnerUp_R mouthClose mouthFunnel mouthPucker"

usage() {
    echo "usage: $0 [--minimal] DIR" >&2
    echo "  downloads the ICT Face Model (MIT License) into DIR; then: export SP_ICT_FACEKIT_DIR=DIR" >&2
    exit 2
}

die() {
    echo "fetch-ict-facekit: error: $*" >&2
    exit 1
}

MINIMAL=0
case "${1:-}" in
--minimal) MINIMAL=1; shift ;;
-h|--help|"") usage ;;
esac
[ $# -eq 1 ] || usage
DIR="$1"

# download URL FILE: curl or wget, failing on HTTP errors, with retries
if command -v curl >/dev/null 2>&1; then
    download() { curl -fL --retry 3 --connect-timeout 30 -o "$2" "$1"; }
elif command -v wget >/dev/null 2>&1; then
    download() { wget -q --tries=3 --timeout=30 -O "$2" "$1"; }
else
    die "needs curl or wget (apt-get install curl)"
fi

mkdir -p "$DIR" || die "cannot create $DIR"
TMP="$(mktemp -d "${TMPDIR:-/tmp}/ict-facekit.XXXXXX")" || die "cannot create a temporary directory"
trap 'rm -rf "$TMP"' EXIT INT TERM

fetch_archive() {
    url="https://codeload.github.com/$REPO/tar.gz/$REF"
    echo "fetch-ict-facekit: downloading $url (a few hundred MB) ..."
    download "$url" "$TMP/repo.tar.gz" || die "download failed: $url (no network? try --minimal, or set ICT_FACEKIT_REF)"
    command -v tar >/dev/null 2>&1 || die "needs tar"
    mkdir -p "$TMP/x"
    tar -xzf "$TMP/repo.tar.gz" -C "$TMP/x" || die "could not unpack the archive"
    src="$(find "$TMP/x" -mindepth 2 -maxdepth 2 -type d -name FaceXModel | head -n 1)"
    [ -n "$src" ] || die "the archive has no FaceXModel folder (did the repository layout change?)"
    cp -R "$src"/. "$DIR"/ || die "could not copy into $DIR"
    top="$(dirname "$src")"
    [ -f "$top/LICENSE" ] && cp "$top/LICENSE" "$DIR/LICENSE"
    return 0
}

fetch_minimal() {
    base="https://raw.githubusercontent.com/$REPO/$REF"
    files="generic_neutral_mesh.obj ICTFaceModelMaterial.mtl"
    i=0
    while [ $i -lt 100 ]; do
        files="$files $(printf 'identity%03d.obj' $i)"
        i=$((i + 1))
    done
    for e in $EXPRESSIONS; do files="$files $e.obj"; done
    download "$base/LICENSE" "$DIR/LICENSE" || die "download failed: $base/LICENSE"
    n=0
    for f in $files; do
        n=$((n + 1))
        printf 'fetch-ict-facekit: [%d] %s\n' "$n" "$f"
        download "$base/FaceXModel/$f" "$TMP/$f" || die "download failed: $base/FaceXModel/$f"
        mv "$TMP/$f" "$DIR/$f"
    done
}

if [ $MINIMAL -eq 1 ]; then fetch_minimal; else fetch_archive; fi

# sanity check: the importer expects this topology
neutral="$DIR/generic_neutral_mesh.obj"
[ -f "$neutral" ] || die "$neutral is missing after the download"
nv="$(grep -c '^v ' "$neutral" || true)"
[ "$nv" = "26719" ] || die "$neutral has $nv vertices, sunprobe expects 26719 (another model version?)"
[ -f "$DIR/LICENSE" ] || echo "fetch-ict-facekit: warning: no LICENSE file was downloaded; the model is MIT-licensed" >&2

echo "fetch-ict-facekit: ICT Face Model is in $DIR (MIT License, see $DIR/LICENSE)"
echo "fetch-ict-facekit: use it with: export SP_ICT_FACEKIT_DIR=\"$DIR\""
