# SPDX-License-Identifier: MIT
# Shared by the command-line test scripts (sourced): a scratch directory removed on exit, a failure
# count, and checks of a command's exit code and output. Usage: . cli_lib.sh NAME
dir=$(mktemp -d "${TMPDIR:-/tmp}/sp-$1.XXXXXX")
trap 'rm -rf "$dir"' EXIT
fails=0
fail() { echo "FAIL: $*"; fails=$((fails + 1)); }

expect() { # expected-exit-code description command...
    local want=$1 what=$2; shift 2
    "$@" >"$dir/out.txt" 2>"$dir/err.txt"
    local got=$?
    if [ "$got" -ne "$want" ]; then
        fail "$what: exit $got, expected $want"; sed 's/^/  | /' "$dir/out.txt" "$dir/err.txt"
    fi
}
contains() { # file pattern description
    grep -qE "$2" "$1" || { fail "$3: no /$2/ in $1"; sed 's/^/  | /' "$1"; }
}
