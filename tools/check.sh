#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The test command: installs dependencies, then builds and runs the whole suite three ways —
# a normal -Werror build, an address+undefined sanitizer build, and the core alone with every
# optional feature disabled — and prints one line "N passed, N failed, N skipped" over all of them.
set -uo pipefail
cd "$(dirname "$0")/.."

tools/install-deps.sh full || exit 3

jobs=$(nproc 2>/dev/null || echo 2)
logs=()
status=0

run_suite() { # name, meson options...
    local dir="build-check-$1"; shift
    logs+=("$dir/meson-logs/testlog.json") # a build that fails leaves none: counted as a failure
    echo "=== $dir: meson setup $*"
    if [ ! -f "$dir/build.ninja" ]; then
        meson setup "$dir" -Dwerror=true "$@" >"$dir.setup.log" 2>&1 || { cat "$dir.setup.log"; status=1; return; }
    fi
    ninja -C "$dir" -j "$jobs" >"$dir.build.log" 2>&1 || { tail -50 "$dir.build.log"; status=1; return; }
    meson test -C "$dir" --num-processes "$jobs" --print-errorlogs || status=1
}

export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1
export ASAN_OPTIONS=detect_leaks=1
run_suite normal
run_suite sanitize -Db_sanitize=address,undefined -Db_lundef=false
run_suite minimal -Dauto_features=disabled

python3 tools/test-summary.py "${logs[@]}" || status=1
exit $status
