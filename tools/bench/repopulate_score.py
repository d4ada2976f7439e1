#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Scores `sunprobe repopulate` reports against a scene's truth (tools/bench/repopulate.sh).

Usage: repopulate_score.py LABEL KIND TRUTH,FRAME,BACKGROUND,COLLECTION,REPORT...
KIND synth: TRUTH is synth street's .truth.json (heights and shadow directions at sample ground points);
KIND street: TRUTH is a path-traced capture's meta.json (height model of a 1.75 m person, the shadow
vanishing point). Per placed person: the sky of the cut-out chosen against the scene's true sky, the height against
the truth's, the shadow's image direction against the truth's, and the luminance of the inserted person
(the cut-out's opaque pixels times the gain) over that of the true people in the frame (pixels far from the
empty background that are no shadow of it). Prints one line per report and the medians over all."""
import json, math, struct, sys, zlib


def png(path):  # 8-bit RGB/RGBA/grey, non-interlaced -> (w, h, channels, bytes)
    data = open(path, "rb").read()
    pos, idat, w = 8, b"", 0
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            w, h, depth, colour = struct.unpack(">IIBB", body[:10])
            ch = {0: 1, 2: 3, 4: 2, 6: 4}[colour]
            assert depth == 8, path
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    raw, stride, out, prev = zlib.decompress(idat), w * ch, bytearray(), bytearray(w * ch)
    for y in range(h):
        f, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - ch] if i >= ch else 0
            b, c = prev[i], prev[i - ch] if i >= ch else 0
            if f == 1: line[i] = (line[i] + a) & 255
            elif f == 2: line[i] = (line[i] + b) & 255
            elif f == 3: line[i] = (line[i] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        out += line
        prev = line
    return w, h, ch, out


def frame_rgb(path):
    if path.endswith(".jpg"):
        return None
    w, h, ch, px = png(path)
    return w, h, [tuple(px[i * ch:i * ch + 3]) for i in range(w * h)]


def luma(p):
    return 0.299 * p[0] + 0.587 * p[1] + 0.114 * p[2]


def people_luma(frame, background):  # true people: far from the background, and no shadow of it
    vals = []
    for f, b in zip(frame[2], background[2]):
        if sum(abs(x - y) for x, y in zip(f, b)) < 60:
            continue
        r = [(x + 1) / (y + 1) for x, y in zip(f, b)]
        if max(r) < 0.95 and max(r) - min(r) < 0.12:
            continue  # darker with the colour kept: a shadow
        vals.append(luma(f))
    return sum(vals) / len(vals) if len(vals) > 20 else float("nan")


def cutout_luma(path, gain):
    w, h, ch, px = png(path)
    vals = [luma([px[i * 4 + c] * gain[c] for c in range(3)]) for i in range(w * h) if px[i * 4 + 3] == 255]
    return sum(vals) / len(vals)


def truth_at(kind, truth, x, y):  # (height px, shadow direction deg)
    if kind == "synth":
        s = min(truth["samples"], key=lambda s: (s["x"] - x) ** 2 + (s["y"] - y) ** 2)
        rows = sorted({(t["y"], t["height"]) for t in truth["samples"]})
        h = float("nan")
        for (y0, h0), (y1, h1) in zip(rows, rows[1:]):
            if y0 <= y <= y1:
                h = h0 + (h1 - h0) * (y - y0) / (y1 - y0)
        return h, math.degrees(math.atan2(s["shadow_dy"], s["shadow_dx"]))
    m = truth["height_model"]["person_1.75m"]
    vp = truth["sun"]["shadow_vanishing_point"]
    return m["a"] * x + m["b"] * y + m["c"], math.degrees(math.atan2(vp[1] - (y + 0.5), vp[0] - (x + 0.5)))


def med(v):
    v = sorted(x for x in v if x == x)
    return float("nan") if not v else v[len(v) // 2] if len(v) % 2 else 0.5 * (v[len(v) // 2 - 1] + v[len(v) // 2])


def main():
    label, kind, rows, groups = sys.argv[1], sys.argv[2], [], {}
    for arg in sys.argv[3:]:
        truth_path, frame_path, bg_path, coll, rep = arg.split(",")
        truth, r = json.load(open(truth_path)), json.load(open(rep))
        frame, bg = frame_rgb(frame_path), frame_rgb(bg_path)
        true_l = people_luma(frame, bg) if frame and bg else float("nan")
        for p in r["placed"]:
            if not p["cutout"]:
                continue
            h, sdir = truth_at(kind, truth, *p["at"])
            d = p.get("shadow_offset_per_height")
            derr = float("nan")
            if p["shadow"] and d:
                derr = abs((math.degrees(math.atan2(d[1], d[0])) - sdir + 180) % 360 - 180)
            lum = cutout_luma(coll + "/" + p["image"], p["gain"]) / true_l if true_l == true_l else float("nan")
            sky = "overcast" if kind == "synth" and truth["sun"]["overcast"] else "sunny"
            groups.setdefault(truth_path, []).append(len(rows))
            rows.append((p["cutout_sky"] == sky, p["height_px"] / h - 1 if h == h else float("nan"),
                         derr, lum))
        sc = r["scene"]
        print("  %s: sky %s (%s), sun %s, %d placed" % (rep.split("/")[-1], sc["sky"], sc["sun_from"], "%.1f/%.1f" % (
            sc["sun_azimuth_deg"], sc["sun_elevation_deg"]) if "sun_azimuth_deg" in sc else "-", len(r["placed"])))
    n = len(rows)
    print("%s: %d placed; cut-out's sky the true one %d; median |height error| %.1f %% (max %.1f); median shadow direction error "
          "%.1f deg (max %.1f, %d shadows); luminance ratio median %.2f (%.2f..%.2f)" % (
              label, n, sum(r[0] for r in rows), 100 * med([abs(r[1]) for r in rows]),
              100 * max([abs(r[1]) for r in rows if r[1] == r[1]] or [float("nan")]), med([r[2] for r in rows]),
              max([r[2] for r in rows if r[2] == r[2]] or [float("nan")]), sum(r[2] == r[2] for r in rows),
              med([r[3] for r in rows]), min([r[3] for r in rows if r[3] == r[3]] or [float("nan")]),
              max([r[3] for r in rows if r[3] == r[3]] or [float("nan")])))

    for g, idx in groups.items():  # the spread over scenes (seeds): each one's medians
        r = [rows[i] for i in idx]
        print("  %s: %d placed, median |height error| %.1f %%, shadow direction %.1f deg, luminance ratio %.2f" % (
            g.split("/")[-1], len(r), 100 * med([abs(x[1]) for x in r]), med([x[2] for x in r]),
            med([x[3] for x in r])))


main()
