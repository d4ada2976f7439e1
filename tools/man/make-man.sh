#!/bin/sh
# SPDX-License-Identifier: MIT
# Writes sunprobe.1 from the program's own help: help2man for the top level, and a COMMANDS section
# holding every command's --help, so the man page says what `sunprobe CMD --help` says.
# Usage: make-man.sh SUNPROBE OUT.1
set -eu
sp=$1; out=$2
inc=$out.h2m.tmp
{
    echo "[COMMANDS]"
    "$sp" --help | sed -n '/^commands:/,/^$/p' | awk 'NR > 1 && NF { print $1 }' | while read -r cmd; do
        echo ".SS $cmd"
        echo ".nf"
        if [ "$cmd" = synth ]; then
            for kind in turn selfie street; do "$sp" synth "$kind" --help 2>&1; echo; done
        else
            "$sp" "$cmd" --help 2>&1
        fi | sed -e 's/\\/\\e/g' -e 's/^\./\\\&./' -e "s/^'/\\\\\&'/"
        echo ".fi"
    done
    echo "[SEE ALSO]"
    echo "The README.md and the module documents (capture/FORMAT.md, pipeline/sunstage/SUNSTAGE.md, ...) of the source tree."
} > "$inc"
help2man --no-info --no-discard-stderr --name "relightable 3D assets from casual light captures" --include "$inc" \
    --output "$out.tmp" "$sp"
rm -f "$inc"
mv "$out.tmp" "$out"
