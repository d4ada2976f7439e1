#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The test command: installs dependencies, then builds and runs the suite five ways — a normal
# -Werror build, an address+undefined sanitizer build, the core alone with every optional feature
# disabled, the vm suite (a real V4L2 driver under qemu) and an aarch64 cross build whose unit tests
# run under qemu-aarch64 — and prints one line "N passed, N failed, N skipped" over all of them.
set -uo pipefail
cd "$(dirname "$0")/.."

tools/install-deps.sh full || exit 3

jobs=$(nproc 2>/dev/null || echo 2)
logs_dir=build-check-logs # setup and build logs, beside the build trees (ignored by git), never in the source root
mkdir -p "$logs_dir"
logs=()
status=0

run_suite() { # name, meson options...
    local dir="build-check-$1"; shift
    local setup=() log=testlog.json # the sanitizer build's runtime options (meson.build's test setups)
    [ "$dir" = build-check-sanitize ] && setup=(--setup sanitize) && log=testlog-sanitize.json
    logs+=("$dir/meson-logs/$log") # a build that fails leaves none: counted as a failure
    echo "=== $dir: meson setup $*"
    if [ ! -f "$dir/build.ninja" ]; then
        meson setup "$dir" -Dwerror=true "$@" >"$logs_dir/$dir.setup.log" 2>&1 || { cat "$logs_dir/$dir.setup.log"; status=1; return; }
    fi
    ninja -C "$dir" -j "$jobs" >"$logs_dir/$dir.build.log" 2>&1 || { tail -50 "$logs_dir/$dir.build.log"; status=1; return; }
    meson test -C "$dir" "${setup[@]}" --num-processes "$jobs" --print-errorlogs || status=1
}

# ---- run_vm (live capture): the vm suite. A static minimal build (V4L2 only) boots Debian's kernel
# under qemu with the vivid driver, records inside the VM and checks the capture on the host. ----
run_vm() {
    local dir="build-check-vm"
    tools/install-deps.sh vm || { status=1; return; }
    logs+=("$dir/meson-logs/testlog.json")
    echo "=== $dir: static minimal build, vm suite"
    if [ ! -f "$dir/build.ninja" ]; then
        meson setup "$dir" -Dwerror=true -Dauto_features=disabled -Dv4l2=enabled -Dvm_tests=true \
            -Dc_link_args=-static -Dcpp_link_args=-static >"$logs_dir/$dir.setup.log" 2>&1 || { cat "$logs_dir/$dir.setup.log"; status=1; return; }
    fi
    ninja -C "$dir" -j "$jobs" tools/sunprobe tests/vm/uhid_gyro >"$logs_dir/$dir.build.log" 2>&1 || { tail -50 "$logs_dir/$dir.build.log"; status=1; return; }
    meson test -C "$dir" --no-rebuild --suite vm --print-errorlogs || status=1
}
# ---- end run_vm ----

# ---- run_cross (live capture): core + V4L2/IIO backends cross-built for aarch64, unit tests under qemu-aarch64 ----
run_cross() {
    local dir="build-check-cross"
    tools/install-deps.sh cross || { status=1; return; }
    logs+=("$dir/meson-logs/testlog.json")
    echo "=== $dir: aarch64 cross build, unit suite under qemu-aarch64"
    if [ ! -f "$dir/build.ninja" ]; then
        meson setup "$dir" --cross-file cross/aarch64-linux-gnu.txt -Dwerror=true -Dauto_features=disabled \
            -Dv4l2=enabled >"$logs_dir/$dir.setup.log" 2>&1 || { cat "$logs_dir/$dir.setup.log"; status=1; return; }
    fi
    ninja -C "$dir" -j "$jobs" >"$logs_dir/$dir.build.log" 2>&1 || { tail -50 "$logs_dir/$dir.build.log"; status=1; return; }
    meson test -C "$dir" --no-rebuild --suite unit --num-processes "$jobs" --timeout-multiplier 2 \
        --print-errorlogs || status=1
}
# ---- end run_cross ----

run_suite normal
# the sanitizer build also covers the shims linked in directly (the normal build loads them as modules)
run_suite sanitize -Db_sanitize=address,undefined -Db_lundef=false -Dlazy_modules=false
run_suite minimal -Dauto_features=disabled
run_vm
run_cross

python3 tools/test-summary.py "${logs[@]}" || status=1
exit $status
