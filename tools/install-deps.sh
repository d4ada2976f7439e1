#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Installs what sunprobe builds and tests with, from Debian 12's archive (apt-get). Idempotent:
# packages already present are not fetched again. Usage: tools/install-deps.sh [minimal|full|vm|cross]
set -euo pipefail

profile=${1:-full}
core=(meson ninja-build pkg-config gcc g++ python3 zlib1g-dev libjpeg62-turbo-dev)
full=(clang libclang-rt-14-dev libopencv-dev opencv-doc libopenimageio-dev libdraco-dev libeigen3-dev
      libcamera-dev libiio-dev libdlib-dev
      clang-format # the layout of changed C lines (tests/integration/test_clang_format.sh)
      libpng-dev # PNG reading (interlaced too) and writing (export/png_libpng.c)
      libzip-dev # Sensor Logger .zip exports (capture/import_bundle.c)
      libmeshoptimizer-dev # export --reorder: vertex cache/fetch order (export/gltf_reorder.c)
      ffmpeg     # ffmpeg: makes the variable-frame-rate video of the import test
      chromium # chromium: the face viewer's headless test (tests/export/test_viewer.sh)
      draco    # draco_encoder: the reference the exported Draco geometry is measured against (test_export.c)
      blender  # headless Blender round trip of the exported face (tests/export/test_blender.sh)
      valgrind # meson test --setup valgrind
      help2man # the man page, made from the program's own --help (tools/man/make-man.sh)
      python3-numpy python3-pil) # scoring probes against the shared street capture's truth (check_street_truth.py)
pkgs=("${core[@]}")
[ "$profile" = full ] && pkgs+=("${full[@]}")
# export checks (tests/export, npm packages): Debian's node + npm unless a node is already installed
if [ "$profile" = full ] && ! command -v node >/dev/null 2>&1; then pkgs+=(nodejs npm); fi
# vm: boot Debian's kernel with vivid under qemu (kmod's depmod indexes the extracted modules)
vm=(qemu-system-x86 busybox-static cpio kmod binutils)
# cross: aarch64 cross compilers and qemu-user to run the unit tests
cross=(gcc-aarch64-linux-gnu g++-aarch64-linux-gnu qemu-user)
[ "$profile" = vm ] && pkgs+=("${vm[@]}")
[ "$profile" = cross ] && pkgs+=("${cross[@]}")

missing=()
for p in "${pkgs[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && { echo "install-deps: all ${#pkgs[@]} packages present"; exit 0; }

as_root=()
if [ "$(id -u)" -ne 0 ]; then
    command -v sudo >/dev/null || { echo "install-deps: need root (or sudo) to install: ${missing[*]}" >&2; exit 3; }
    as_root=(sudo)
fi
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
"${as_root[@]}" apt-get update -qq
"${as_root[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install-deps: done"
