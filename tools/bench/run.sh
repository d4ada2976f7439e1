#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Builds a release tree and runs the benchmarks; each prints medians and the ratio against its
# named baseline in the same run. Usage: tools/bench/run.sh [replay|record|render|relight|probe|fit|texture|orientation ...]
# (default: all; depopulate and repopulate are run only when named). Scratch captures are cached in ${SP_BENCH_DIR:-/tmp/sp-bench}.
set -euo pipefail
cd "$(dirname "$0")/../.."
build=${SP_BENCH_BUILD:-build-bench}
[ -f "$build/build.ninja" ] || meson setup "$build" -Dbuildtype=release >/dev/null
ninja -C "$build" >/dev/null
dir=${SP_BENCH_DIR:-/tmp/sp-bench}
mkdir -p "$dir"
which=("$@")
[ ${#which[@]} -gt 0 ] || which=(replay record render relight probe fit texture orientation)
for b in "${which[@]}"; do
    if [ "$b" = repopulate ]; then # a script over the command's reports (no timing)
        echo "== repopulate"
        tools/bench/repopulate.sh "$build" "$dir"
        continue
    fi
    exe="$build/tools/bench/bench_$b"
    if [ ! -x "$exe" ]; then
        echo "bench $b: not built in this configuration (missing optional feature?)"
        continue
    fi
    echo "== bench_$b"
    case $b in
        replay | orientation) "$exe" "$dir" ;;
        depopulate) tools/bench/depopulate.sh "$build" "$dir" ;;
        *) "$exe" ;;
    esac
done
