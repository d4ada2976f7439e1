#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
# vm suite helper: walks a capture's chunks (layout in capture/FORMAT.md) and checks
#   --gain: every frame carries the camera's gain (read per frame from the V4L2 control), and it
#           stayed constant (the exposure lock holds);
#   --gyro: gyro samples carry the rate of turn the uhid sensor hub reported (x 10, y -20, z 30 deg/s),
#           are in time order, and lie on the frames' clock (their span overlaps the frames' span).
#   --bars: the last frame (NV12) shows vivid's default test pattern, eight 75% colour bars (white,
#           yellow, cyan, green, magenta, red, blue, black): each bar's centre, converted BT.601 limited
#           range, has its high and low R, G, B channels where they belong.
# usage: check_capture.py [--gain] [--gyro] [--bars] CAPTURE
import math
import struct
import sys

want_gain, want_gyro, want_bars = "--gain" in sys.argv, "--gyro" in sys.argv, "--bars" in sys.argv
data = open(sys.argv[-1], "rb").read()
pos = struct.unpack_from("<I", data, 12)[0]
frames, gains, gyro, problems = [], [], [], []
last_image = None
while pos + 32 <= len(data):
    sync, ctype, _flags, size, _crc, ts = struct.unpack_from("<IHHIIq", data, pos)
    if sync != 0x4B43538A:
        problems.append("bad chunk sync at %d" % pos)
        break
    payload = data[pos + 32:pos + 32 + size]
    if ctype == 2:
        frames.append(ts)
        gains.append(struct.unpack_from("<f", payload, 36)[0])
        last_image = payload
    elif ctype == 3:
        rec_size, count = struct.unpack_from("<II", payload, 0)
        for i in range(count):
            t, sensor, x, y, z = struct.unpack_from("<qIfff", payload, 8 + i * rec_size)
            if sensor == 1:
                gyro.append((t, x, y, z))
    pos += 32 + size

if want_gain:
    if not gains or any(math.isnan(g) for g in gains):
        problems.append("frames without a gain value")
    elif len(set(gains)) != 1:
        problems.append("gain changed while locked: %s" % sorted(set(gains))[:5])
    else:
        print("gain %g on all %d frames" % (gains[0], len(gains)))
want = [math.radians(v) for v in (10.0, -20.0, 30.0)]
if not want_gyro:
    gyro = None
elif len(gyro) < 50:
    problems.append("only %d gyro samples" % len(gyro))
for t, x, y, z in gyro or []:
    if any(abs(a - b) > 1e-3 for a, b in zip((x, y, z), want)):
        problems.append("gyro sample %.4f %.4f %.4f rad/s, expected %.4f %.4f %.4f" % (x, y, z, *want))
        break
if gyro and any(b[0] < a[0] for a, b in zip(gyro, gyro[1:])):
    problems.append("gyro timestamps go backwards")
if frames and gyro:
    f0, f1, g0, g1 = min(frames), max(frames), gyro[0][0], gyro[-1][0]
    print("frames %.3f..%.3f s, gyro %.3f..%.3f s (monotonic clock), %d gyro samples" %
          (f0 * 1e-9, f1 * 1e-9, g0 * 1e-9, g1 * 1e-9, len(gyro)))
    if g0 > f1 + 1e9 or g1 < f0 - 1e9:
        problems.append("gyro and frame timestamps are not on one clock")
BARS = [("white", 1, 1, 1), ("yellow", 1, 1, 0), ("cyan", 0, 1, 1), ("green", 0, 1, 0),
        ("magenta", 1, 0, 1), ("red", 1, 0, 0), ("blue", 0, 0, 1), ("black", 0, 0, 0)]


def bar_problems(payload):
    hdr, fmt, width, height, stride = struct.unpack_from("<IIIII", payload, 0)
    if fmt != 4:
        return ["--bars needs an NV12 frame, this one has format %d" % fmt]
    img, found = payload[hdr:], []
    y = height - 1 - height // 16  # below vivid's text overlay, which reaches 3/4 down at 320x180
    for i, (name, *want) in enumerate(BARS):
        x = (2 * i + 1) * width // 16
        luma = img[y * stride + x]
        uv = height * stride + (y // 2) * stride + (x // 2) * 2
        cb, cr = img[uv] - 128, img[uv + 1] - 128
        yy = 1.164 * (luma - 16)
        rgb = (yy + 1.596 * cr, yy - 0.392 * cb - 0.813 * cr, yy + 2.017 * cb)
        found.append("%s (%d %d %d)" % (name, *[round(c) for c in rgb]))
        if [1 if c > 96 else 0 for c in rgb] != want:
            return ["bar %d should be %s, is R G B %d %d %d (Y %d Cb %d Cr %d)" %
                    (i, name, *[round(c) for c in rgb], luma, cb + 128, cr + 128)]
    print("bars:", ", ".join(found))
    return []


if want_bars:
    problems += bar_problems(last_image) if last_image else ["no frame to check the bars on"]
for p in problems:
    print("FAIL:", p)
sys.exit(1 if problems else 0)
