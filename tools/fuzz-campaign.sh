#!/bin/sh
# SPDX-License-Identifier: MIT
# A fuzzing campaign over every harness in tests/fuzz, one libFuzzer process at a time under nice -n 19:
# sets up BUILD (default build-fuzz: clang, -Dfuzzer=enabled, ASan + UBSan, the libraries instrumented
# with -fsanitize=fuzzer-no-link), then runs each target for SECONDS (default 60) from its committed
# corpus (a copy: new inputs never go into the repository) and prints one line per target: executions,
# corpus size (inputs, bytes), coverage (libFuzzer's cov/ft) and whether it found anything.
# Usage: tools/fuzz-campaign.sh [SECONDS] [TARGET...]   Env: BUILD, SP_FUZZ_ARTIFACTS (crashes go there).
# Exit 77 when clang/libFuzzer is missing, 1 when a target crashed.
set -u
secs=${1:-60}
[ $# -gt 0 ] && shift
root=$(cd "$(dirname "$0")/.." && pwd)
build=${BUILD:-$root/build-fuzz}
command -v clang >/dev/null 2>&1 || { echo "SKIP: clang not found (install clang and libclang-rt-14-dev)"; exit 77; }
targets=${*:-"frame_times meta_json png face_dir gltf capture_reader imu_logs"}
if [ ! -f "$build/build.ninja" ]; then
    # the native file stays in the build tree: meson reads it again whenever it regenerates build.ninja
    mkdir -p "$build"
    printf "[binaries]\nc = 'clang'\ncpp = 'clang++'\n" >"$build/clang.ini"
    nice -n 19 meson setup "$build" "$root" --native-file "$build/clang.ini" -Dbuildtype=debugoptimized \
        -Dauto_features=disabled -Dzlib=enabled -Dfuzzer=enabled -Db_sanitize=address,undefined -Db_lundef=false \
        -Dc_args="-fsanitize=fuzzer-no-link -fno-sanitize-recover=undefined" -Dcpp_args=-fsanitize=fuzzer-no-link \
        >/dev/null || exit 1
fi
exes=""
for t in $targets; do exes="$exes tests/fuzz/libfuzzer_$t"; done
# shellcheck disable=SC2086
nice -n 19 ninja -C "$build" -j1 $exes >/dev/null || exit 1
[ -d "$build/tests/fuzz/capture_seeds" ] || nice -n 19 ninja -C "$build" -j1 tests/fuzz/capture_seeds >/dev/null
# the harnesses that read files write each input to TMPDIR: a tmpfs runs them 10-50x faster than a disk
[ -z "${TMPDIR:-}" ] && [ -w /dev/shm ] && export TMPDIR=/dev/shm
work=$(mktemp -d "${TMPDIR:-/tmp}/sp-campaign.XXXXXX")
trap 'rm -rf "$work"' EXIT INT TERM
artifacts=${SP_FUZZ_ARTIFACTS:-$work/artifacts}
mkdir -p "$artifacts"
found=0
printf "%-15s %12s %8s %10s %7s %7s %s\n" target executions inputs bytes cov ft result
for t in $targets; do
    case $t in
    gltf) seeds=$root/tests/fuzz/corpus/face_dir ;;
    capture_reader) seeds=$build/tests/fuzz/capture_seeds ;;
    imu_logs) seeds="$root/tests/data/gyroflow $root/tests/data/opencamera $root/tests/data/sensor_logger" ;;
    *) seeds=$root/tests/fuzz/corpus/$t ;;
    esac
    mkdir -p "$work/$t"
    # shellcheck disable=SC2086
    cp $(find $seeds -maxdepth 1 -type f) "$work/$t/" 2>/dev/null
    SP_LOG=none nice -n 19 "$build/tests/fuzz/libfuzzer_$t" -max_total_time="$secs" -max_len=65536 -timeout=10 \
        -rss_limit_mb=1024 -print_final_stats=1 -artifact_prefix="$artifacts/$t-" "$work/$t" >"$work/$t.log" 2>&1
    rc=$?
    execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$work/$t.log" | tail -1)
    cov=$(grep -o 'cov: [0-9]*' "$work/$t.log" | tail -1 | cut -d' ' -f2)
    ft=$(grep -o 'ft: [0-9]*' "$work/$t.log" | tail -1 | cut -d' ' -f2)
    n=$(find "$work/$t" -type f | wc -l)
    bytes=$(du -sb "$work/$t" | cut -f1)
    result=clean
    art=$(ls -t "$artifacts" | grep "^$t-" | head -1)
    # libFuzzer's timeout is wall-clock time: at nice 19 on a busy machine a quick input can wait past it.
    # A timeout counts only when the input, run again alone, still takes over the limit.
    if [ $rc -ne 0 ] && [ "${art#"$t"-timeout-}" != "$art" ] &&
        SP_LOG=none "$build/tests/fuzz/libfuzzer_$t" -timeout=10 -runs=3 "$artifacts/$art" >"$work/$t.again.log" 2>&1; then
        result="clean (a timeout that did not recur: $art ran 3 times within the limit, the process had been starved)"
        rc=0
    fi
    [ $rc -eq 0 ] || { result="FOUND (exit $rc): $art"; found=1;
                       grep -E "ERROR|SUMMARY|^[^ ]*:[0-9]+: " "$work/$t.log" | head -3; }
    printf "%-15s %12s %8s %10s %7s %7s %s\n" "$t" "${execs:-0}" "$n" "$bytes" "${cov:-?}" "${ft:-?}" "$result"
done
[ $found -eq 0 ] || { echo "crashing inputs in $artifacts"; exit 1; }
