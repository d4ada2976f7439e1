#!/bin/bash
# SPDX-License-Identifier: MIT
# The bash completion offers the commands from `sunprobe --help` and each command's options from its own
# --help (so a new option shows up without touching the script).
# Usage: test_completion.sh SUNPROBE SCRIPT
SP=$1
. "$2" || exit 1
fails=0
complete_at() { # words... -> COMPREPLY for the last word
    COMP_WORDS=("$SP" "$@"); COMP_CWORD=$#
    _sunprobe
}
want() { # description word...: each word must be offered
    local what=$1; shift
    for w in "$@"; do
        printf '%s\n' "${COMPREPLY[@]}" | grep -qxF -- "$w" || { echo "FAIL: $what: '$w' not offered (${COMPREPLY[*]})"; fails=$((fails + 1)); }
    done
}
complete_at fi;              want "command prefix" fit
complete_at "";              want "all commands" info fit relight probe export record --version
complete_at fit --rep;       want "fit options" --report
complete_at fit --;          want "fit options" --keyframes --texture --dlib-model
complete_at synth s;         want "synth kinds" selfie street
complete_at synth selfie --ut; want "synth selfie options" --utc
complete_at relight --s;     want "relight options" --sun
[ ${#COMPREPLY[@]} -gt 0 ] || { echo "FAIL: nothing offered"; fails=$((fails + 1)); }
complete_at fit --no-such-; [ ${#COMPREPLY[@]} -eq 0 ] || { echo "FAIL: offered ${COMPREPLY[*]} for --no-such-"; fails=$((fails + 1)); }
exit $((fails > 0))
