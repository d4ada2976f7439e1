#!/bin/sh
# SPDX-License-Identifier: MIT
# Fuzzes the .spcap reader and recovery with libFuzzer (+ ASan/UBSan) for N seconds (default 60),
# starting from the generated seed corpus. Exit 77 (skip) when clang or libFuzzer is missing.
# Env: CLANG (compiler, default clang), SP_FUZZ_ARTIFACTS (where crashing inputs go, default $TMPDIR or /tmp).
set -eu
secs=${1:-60}
root=$(cd "$(dirname "$0")/.." && pwd)
cc=${CLANG:-clang}
if ! command -v "$cc" >/dev/null 2>&1; then
    echo "SKIP: $cc not found (install clang and libclang-rt-14-dev to fuzz)"
    exit 77
fi
work=$(mktemp -d "${TMPDIR:-/tmp}/sp_fuzz.XXXXXX")
trap 'rm -rf "$work"' EXIT INT TERM
printf 'int LLVMFuzzerTestOneInput(const unsigned char *d, unsigned long n) { return d && n; }\n' >"$work/probe.c"
if ! "$cc" -fsanitize=fuzzer "$work/probe.c" -o "$work/probe" >/dev/null 2>&1; then
    echo "SKIP: $cc cannot link -fsanitize=fuzzer (libFuzzer missing: install libclang-rt-14-dev)"
    exit 77
fi

srcs="capture/container_writer.c capture/container_reader.c capture/container_recover.c
      common/crc32c.c common/json.c common/clock.c common/frame.c common/error.c common/log.c"
flags="-std=c11 -D_GNU_SOURCE -D_FILE_OFFSET_BITS=64 -g -O1 -I$root -I$root/include"
cd "$root"
# shellcheck disable=SC2086
"$cc" $flags -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=undefined -DSP_LIBFUZZER \
    tests/fuzz/fuzz_capture_reader.c $srcs -lm -lpthread -o "$work/fuzz_capture_reader"
# shellcheck disable=SC2086
"$cc" $flags tests/fuzz/make_seed_corpus.c $srcs -lm -lpthread -o "$work/make_seed_corpus"
"$work/make_seed_corpus" "$work/seeds"
mkdir -p "$work/corpus"
artifacts=${SP_FUZZ_ARTIFACTS:-${TMPDIR:-/tmp}}
echo "fuzzing the .spcap reader for ${secs}s; crashing inputs go to $artifacts/spcap-crash-*"
# new inputs go to the first (scratch) corpus directory, never into the seeds
"$work/fuzz_capture_reader" -max_total_time="$secs" -max_len=65536 -rss_limit_mb=1024 -timeout=10 \
    -print_final_stats=1 -artifact_prefix="$artifacts/spcap-" "$work/corpus" "$work/seeds"
