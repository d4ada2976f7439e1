#!/bin/sh
# SPDX-License-Identifier: MIT
# libsunprobe's exports against libsunprobe.map's promise: every SUNPROBE_0 name is declared in an installed
# header (the API), and every SUNPROBE_PRIVATE_0 name is one the sunprobe command calls (no private export
# left behind after the command stopped needing it). Data the command uses shows as its own copy
# (a copy relocation) bound to the same version.
# Usage: test_exports.sh LIBSUNPROBE SUNPROBE INCLUDE_DIR
set -u
lib=$1; sp=$2; inc=$3
command -v readelf >/dev/null || { echo "SKIP: no readelf"; exit 77; }
readelf -d "$sp" | grep -q 'NEEDED.*libsunprobe' || { echo "SKIP: this sunprobe links the static libraries"; exit 77; }
tmp=$(mktemp -d "${TMPDIR:-/tmp}/sp-exports.XXXXXX") || exit 1
trap 'rm -rf "$tmp"' EXIT
# defined dynamic symbols of a version node: "name@@NODE" in readelf's eighth column
readelf --dyn-syms -W "$lib" | awk '$7 != "UND" && $8 ~ /@@SUNPROBE_0$/ { sub(/@.*/, "", $8); print $8 }' | sort -u >"$tmp/api"
readelf --dyn-syms -W "$lib" | awk '$7 != "UND" && $8 ~ /@@SUNPROBE_PRIVATE_0$/ { sub(/@.*/, "", $8); print $8 }' | sort -u >"$tmp/private"
readelf --dyn-syms -W "$sp" | awk '$8 ~ /@SUNPROBE_PRIVATE_0/ { sub(/@.*/, "", $8); print $8 }' | sort -u >"$tmp/used"
status=0
[ -s "$tmp/api" ] || { echo "FAIL: no SUNPROBE_0 symbols in $lib"; status=1; }
[ -s "$tmp/used" ] || { echo "FAIL: sunprobe calls no SUNPROBE_PRIVATE_0 symbol"; status=1; }
unused=$(comm -23 "$tmp/private" "$tmp/used")
[ -z "$unused" ] || { echo "FAIL: exported as private but not called by sunprobe (drop SP_PRIVATE and the map entry):"; echo "$unused"; status=1; }
while read -r name; do
    grep -qw "$name" "$inc"/sunprobe/*.h || { echo "FAIL: $name is exported as API but no installed header declares it"; status=1; }
done <"$tmp/api"
echo "$(wc -l <"$tmp/api") API names, $(wc -l <"$tmp/private") private names ($(wc -l <"$tmp/used") called by sunprobe)"
exit $status
