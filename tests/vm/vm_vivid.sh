#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# vm suite: boots Debian's kernel under qemu (TCG) with an initramfs holding busybox, the vivid module
# (and its dependencies, plus virtio-blk to carry results out) and a static sunprobe, records from
# /dev/video0 inside the VM, then checks the capture on the host with `sunprobe info/verify`.
#   usage: vm_vivid.sh record|unbind|hidgyro|mplane SUNPROBE CACHE_DIR [UHID_GYRO]
# record: 4 s of YUYV 320x180 @ 30 fps; frame count near the rate, timestamps monotonic, format as asked.
# mplane: vivid as a multi-planar device (multiplanar=2); 2 s of each 4:2:0 layout, one memory plane
#         (NV12, NV21, YU12) and two or three (NM12, NM21, YM12), forced through /dev/video0:fourcc=;
#         each stored as NV12 with vivid's colour bars in their colours (a swapped or misplaced chroma
#         plane shows as a wrong bar).
# unbind: the vivid platform device is unbound mid-stream; the capture must stay valid and say so.
# hidgyro: as record, plus a kernel IIO gyro (hid-sensor-gyro-3d behind a sensor hub made through
#          /dev/uhid by UHID_GYRO): samples scaled right, in order, on the frames' clock.
# Downloads (the kernel package, extracted with dpkg-deb -x, never installed) are cached in CACHE_DIR.
# Exit 77 only when qemu cannot run here.
set -euo pipefail

scenario=${1:?scenario}; sunprobe=${2:?sunprobe binary}; cache=${3:?cache dir}; uhid_gyro=${4:-}
here=$(cd "$(dirname "$0")" && pwd)
fps=30; size=320x180; width=320; height=180; duration=4; mplane_duration=2

fail() { echo "FAIL: $*" >&2; exit 1; }
skip() { echo "SKIP: $*" >&2; exit 77; }

command -v qemu-system-x86_64 >/dev/null || skip "qemu-system-x86_64 not installed (tools/install-deps.sh vm)"
[ "$(uname -m)" = x86_64 ] || skip "the vm suite boots an amd64 kernel; this host is $(uname -m)"
if readelf -d "$sunprobe" 2>/dev/null | grep -q NEEDED; then
    fail "$sunprobe is dynamically linked; the VM needs a static build (tools/check.sh run_vm makes one)"
fi
busybox=$(command -v busybox || true)
[ -n "$busybox" ] && ! readelf -d "$busybox" | grep -q NEEDED || fail "a static busybox is needed (busybox-static)"
for tool in dpkg-deb cpio gzip apt-get readelf; do command -v $tool >/dev/null || fail "$tool not found"; done

mkdir -p "$cache"
cache=$(cd "$cache" && pwd)

# ---- kernel: resolve the version linux-image-amd64 points at, download once, extract ----
kernel_pkg() {
    apt-cache depends linux-image-amd64 2>/dev/null | sed -n 's/^ *Depends: \(linux-image-[0-9][^ ]*\)$/\1/p' | head -1
}
download_kernel() { # resolves the package and extracts it into $kroot; 1 when apt cannot get it
    pkg=$(kernel_pkg)
    [ -n "$pkg" ] || return 1
    kroot="$cache/$pkg"
    [ -d "$kroot/boot" ] && return 0
    echo "vm: downloading $pkg"
    (cd "$cache" && apt-get download -o APT::Sandbox::User=root "$pkg" >/dev/null 2>&1) || return 1
    rm -rf "$kroot.tmp" && dpkg-deb -x "$cache/$pkg"_*.deb "$kroot.tmp" && mv "$kroot.tmp" "$kroot" || return 1
    rm -f "$cache/$pkg"_*.deb
}
if ! download_kernel; then # package lists missing or stale (the archive moved on): refresh once
    apt-get update -qq >/dev/null 2>&1 || true
    download_kernel || fail "cannot download the kernel behind linux-image-amd64 (apt-cache depends; apt-get download)"
fi
vmlinuz=$(ls "$kroot"/boot/vmlinuz-* | head -1)
moddir=$(ls -d "$kroot"/lib/modules/* | head -1)
if [ ! -f "$moddir/modules.dep" ]; then # the package leaves this to its postinst: make it here
    depmod=$(command -v depmod || echo /sbin/depmod)
    "$depmod" -b "$kroot" "$(basename "$moddir")" || fail "depmod failed (package kmod)"
fi
[ -f "$vmlinuz" ] && [ -f "$moddir/modules.dep" ] || fail "kernel package $pkg lacks vmlinuz or modules.dep"

# ---- modules: the wanted ones and their dependencies from modules.dep, dependencies first ----
declare -A loaded=()
order=()
dep_line() { grep -E "(^|/)$1\.ko(\.xz|\.zst)?:" "$moddir/modules.dep" | head -1; }
add_module() { # path relative to moddir
    local path=$1
    [ -n "${loaded[$path]:-}" ] && return
    local line deps d
    line=$(grep -E "^${path//./\\.}:" "$moddir/modules.dep" | head -1)
    deps=${line#*:}
    local rev=()
    for d in $deps; do rev=("$d" "${rev[@]}"); done
    for d in "${rev[@]}"; do add_module "$d"; done
    loaded[$path]=1
    order+=("$path")
}
modules=(virtio_blk virtio_pci vivid)
declare -A module_args=()
[ "$scenario" = mplane ] && module_args[vivid]="multiplanar=2"
mplane_fourccs=(NV12 NV21 YU12 NM12 NM21 YM12)
[ "$scenario" = hidgyro ] && modules+=(uhid hid-sensor-hub hid-sensor-gyro-3d)
for m in "${modules[@]}"; do
    line=$(dep_line "$m")
    [ -n "$line" ] || fail "module $m not in $pkg"
    add_module "${line%%:*}"
done

# ---- initramfs ----
work=$(mktemp -d "${TMPDIR:-/tmp}/sp_vm_XXXXXX")
trap 'rm -rf "$work"' EXIT
root="$work/root"
mkdir -p "$root"/{bin,dev,proc,sys,out,lib/modules}
cp "$busybox" "$root/bin/busybox"
cp "$sunprobe" "$root/bin/sunprobe"
if [ "$scenario" = hidgyro ]; then
    [ -x "$uhid_gyro" ] && ! readelf -d "$uhid_gyro" | grep -q NEEDED || fail "hidgyro needs the static uhid_gyro helper"
    cp "$uhid_gyro" "$root/bin/uhid_gyro"
fi
: >"$root/modules.order"
for path in "${order[@]}"; do
    name=$(basename "$path")
    case "$name" in
    *.xz) xz -dc "$moddir/$path" >"$root/lib/modules/${name%.xz}"; name=${name%.xz} ;;
    *.zst) zstd -qdc "$moddir/$path" >"$root/lib/modules/${name%.zst}"; name=${name%.zst} ;;
    *) cp "$moddir/$path" "$root/lib/modules/$name" ;;
    esac
    stem=${name%.ko}
    echo "$name ${module_args[$stem]:-}" >>"$root/modules.order"
done

rec_args="--camera /dev/video0 --format yuyv --size $size --fps $fps --lock-exposure"
case "$scenario" in
record) run="sunprobe record $rec_args --mode static --duration $duration -o /out/cap.spcap >/out/log.txt 2>&1; echo \$? >/out/rc" ;;
unbind) run="sunprobe record $rec_args --mode static --duration 60 -o /out/cap.spcap >/out/log.txt 2>&1 &
pid=\$!
sleep 3
echo vivid.0 >/sys/bus/platform/drivers/vivid/unbind && echo unbound >>/out/events.txt
wait \$pid; echo \$? >/out/rc" ;;
mplane) run=""
    for cc in "${mplane_fourccs[@]}"; do
        run+="SP_LOG=info sunprobe record --camera /dev/video0:fourcc=$cc --format nv12 --size $size --fps $fps --lock-exposure \
--mode static --duration $mplane_duration -o /out/cap-$cc.spcap >/out/log-$cc.txt 2>&1; echo \$? >/out/rc-$cc
cat /out/log-$cc.txt >>/out/log.txt
"
    done ;;
hidgyro) run="uhid_gyro 60 &
i=0; while [ ! -e /sys/bus/iio/devices/iio:device0 ] && [ \$i -lt 100 ]; do sleep 0.1; i=\$((i+1)); done
ls /sys/bus/iio/devices/iio:device0 >/out/iio.txt 2>&1
sunprobe devices >/out/devices.txt 2>&1
sunprobe record $rec_args --imu gyro_3d --mode static --duration $duration -o /out/cap.spcap >/out/log.txt 2>&1; echo \$? >/out/rc" ;;
*) fail "unknown scenario $scenario" ;;
esac

cat >"$root/init" <<EOF
#!/bin/busybox sh
/bin/busybox --install -s /bin
export PATH=/bin
mount -t proc proc /proc
mount -t sysfs sys /sys
mount -t devtmpfs dev /dev
while read -r m args; do insmod /lib/modules/\$m \$args || echo "SP-VM: insmod \$m failed"; done </modules.order
i=0
while { [ ! -e /dev/video0 ] || [ ! -e /dev/vda ]; } && [ \$i -lt 100 ]; do sleep 0.1; i=\$((i+1)); done
echo "SP-VM: \$(ls /dev/video* /dev/vda 2>&1 | tr '\n' ' ')"
sunprobe devices >/out/devices.txt 2>&1
$run
cat /out/log.txt
tar -cf /dev/vda -C /out .
sync
echo SP-VM-DONE
reboot -f
EOF
chmod +x "$root/init"
(cd "$root" && find . | cpio -o -H newc --quiet | gzip -1) >"$work/initramfs.gz"
truncate -s 64M "$work/out.img"

# ---- boot ----
echo "vm: booting $(basename "$vmlinuz") with ${#order[@]} modules ($scenario)"
start=$(date +%s)
set +e
timeout 600 qemu-system-x86_64 -accel tcg -m 512 -smp 1 -nographic -no-reboot \
    -kernel "$vmlinuz" -initrd "$work/initramfs.gz" \
    -append "console=ttyS0 panic=-1 quiet loglevel=3" \
    -drive file="$work/out.img",format=raw,if=virtio \
    -net none >"$work/console.txt" 2>&1
qrc=$?
set -e
echo "vm: qemu exited $qrc after $(( $(date +%s) - start )) s"
if ! grep -q SP-VM-DONE "$work/console.txt"; then
    tail -40 "$work/console.txt" >&2
    if [ $qrc -ne 0 ] && grep -qiE "could not|failed to initialize|not supported" "$work/console.txt"; then
        skip "qemu cannot run here (exit $qrc)"
    fi
    fail "the VM did not finish its scenario"
fi
grep "SP-VM" "$work/console.txt" || true

mkdir -p "$work/out"
tar -xf "$work/out.img" -C "$work/out" 2>/dev/null || fail "no results on the VM's disk"
cat "$work/out/devices.txt" || true
cat "$work/out/log.txt" || true
within() { awk -v v="$1" -v lo="$2" -v hi="$3" 'BEGIN { exit !(v >= lo && v <= hi) }'; }

# Checks one capture made in the VM: verify, info, format and size as negotiated, clean close, the v4l2
# backend named, a rate near the negotiated one, the gain locked. Sets frames and info.
check_capture() { # CAPTURE FORMAT
    local cap=$1 want_fmt=$2 line fmt wxh secs rate
    [ -f "$cap" ] || fail "no capture $(basename "$cap") came out of the VM"
    cp "$cap" "$cache/last-$scenario-$(basename "$cap")"
    "$sunprobe" verify "$cap" || fail "sunprobe verify rejected $(basename "$cap")"
    info=$("$sunprobe" info "$cap") || fail "sunprobe info failed"
    echo "$info"
    line=$(echo "$info" | grep '^frames\[0\]:') || fail "no frames in the capture"
    read -r frames fmt wxh secs rate <<<"$(echo "$line" |
        sed -E 's/^frames\[0\]: +([0-9]+) ([a-z0-9]+) ([0-9]+x[0-9]+)[^,]*, ([0-9.]+) s, ([0-9.]+) fps.*/\1 \2 \3 \4 \5/')"
    echo "vm: $(basename "$cap"): $frames frames $fmt $wxh over $secs s at $rate fps"
    [ "$fmt" = "$want_fmt" ] && [ "$wxh" = "${width}x${height}" ] || fail "format $fmt $wxh, negotiated $want_fmt ${width}x${height}"
    echo "$info" | grep -q "mixed formats" && fail "frames changed format mid-stream"
    echo "$info" | grep -q "timestamps go backwards" && fail "frame timestamps are not monotonic"
    echo "$info" | grep -q "^end: *closed cleanly" || fail "the capture was not closed cleanly"
    echo "$info" | grep -q '^camera: .*(v4l2)' || fail "META does not name the v4l2 backend"
    # the timestamps' rate is what the driver delivered; vivid paces itself on the kernel clock
    within "$rate" "$(awk -v f=$fps 'BEGIN{print 0.6*f}')" "$(awk -v f=$fps 'BEGIN{print 1.05*f}')" ||
        fail "frame rate $rate fps is not near the negotiated $fps fps"
    python3 "$here/check_capture.py" --gain "$cap" || fail "per-frame gain missing or not locked"
}
# frames cover a recording of $1 s: count near duration x rate (the first frame arrives after stream start)
check_frame_count() {
    within "$frames" "$(awk -v f=$fps -v d="$1" 'BEGIN{print 0.5*f*d}')" "$(awk -v f=$fps -v d="$1" 'BEGIN{print 1.05*f*d+2}')" ||
        fail "$frames frames in $1 s at $fps fps"
}

# ---- checks on the host ----
if [ "$scenario" = mplane ]; then
    for cc in "${mplane_fourccs[@]}"; do
        rc=$(cat "$work/out/rc-$cc" 2>/dev/null || echo none)
        [ "$rc" = 0 ] || fail "sunprobe record with fourcc $cc exited $rc"
        grep -q "memory plane" "$work/out/log-$cc.txt" || [ "$cc" = NV12 ] || fail "the log does not say $cc was repacked"
        check_capture "$work/out/cap-$cc.spcap" nv12
        check_frame_count "$mplane_duration"
        python3 "$here/check_capture.py" --bars "$work/out/cap-$cc.spcap" || fail "$cc: colour bars wrong after repacking"
    done
    echo "vm: $scenario OK"
    exit 0
fi
check_capture "$work/out/cap.spcap" yuyv
rc=$(cat "$work/out/rc")
case "$scenario" in
record | hidgyro)
    [ "$rc" = 0 ] || fail "sunprobe record exited $rc"
    check_frame_count "$duration"
    ;;
unbind)
    grep -q unbound "$work/out/events.txt" 2>/dev/null || fail "the vivid device was not unbound"
    [ "$rc" = 3 ] || fail "sunprobe record exited $rc after the device went away (expected 3)"
    grep -q "device lost" "$work/out/log.txt" || fail "record did not report the lost device"
    within "$frames" 30 200 || fail "$frames frames kept from about 3 s of streaming"
    ;;
esac
if [ "$scenario" = hidgyro ]; then
    echo "$info" | grep -q '^imu: *gyro_3d' || fail "META does not name the gyro_3d IIO device"
    echo "$info" | grep -q '^imu gyro' || fail "no gyro samples in the capture"
    python3 "$here/check_capture.py" --gyro "$work/out/cap.spcap" || fail "gyro samples wrong (values, order or clock)"
fi
echo "vm: $scenario OK"
