#!/bin/sh
# SPDX-License-Identifier: MIT
# The kill-anywhere soak of `sunprobe record`'s recorder: N (default 1000) SIGKILL points through a
# recording of the fake camera and IMU, each capture recovered with `sunprobe recover`, checked with
# `sunprobe verify` and read back for every chunk completed before the kill
# (tests/integration/record_kill.c; the normal suite runs 30). Prints the count and the wall time.
# Usage: tools/record-kill-soak.sh [N] [SEED]   Env: BUILD (default build).
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
build=${BUILD:-$root/build}
ninja -C "$build" tests/integration/record_kill tools/sunprobe >/dev/null
# copies, so a rebuild of the tree during the soak cannot pull the program away under it
bin=$(mktemp -d "${TMPDIR:-/tmp}/sp-soak.XXXXXX")
trap 'rm -rf "$bin"' EXIT INT TERM
cp "$build/tests/integration/record_kill" "$build/tools/sunprobe" "$bin/"
start=$(date +%s)
"$bin/record_kill" "$bin/sunprobe" "${1:-1000}" "${2:-1}"
echo "wall time: $(($(date +%s) - start)) s"
