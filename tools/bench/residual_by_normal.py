#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Where a fitted face's held-out renders are too bright or too dark (SUNSTAGE.md, "The residual by normal").

Usage: residual_by_normal.py DIR [KIND]   (KIND relight, the default, or nvs)
DIR holds the KIND_NN.f32 files of `sunprobe evaluate FACE CAPTURE_DIR --renders DIR --passes`. Over the
pixels of the true mask that the rendered face covers (coverage > 0.5), the residual render - truth in the
units evaluate scores (display values of the capture's encoding), binned by the rendered shading normal in
world space (its vertical component; its cosine to the image's sun), by the render's own sun shading (lit,
attached shadow, cast shadow), and, for comparison, over each image's darkest and brightest 30 % chosen by
the truth and by the render. A table per binning: pixels, the truth's mean, the mean residual (RGB and per
channel), the bin's share of the squared error and the range of the per-image means (images with >= 50
pixels in the bin). Pure Python, no NumPy."""
import array, glob, math, struct, sys


def read(path):
    raw = open(path, "rb").read()
    magic, version, w, h = struct.unpack_from("<4siii", raw, 0)
    if magic != b"SPEV" or version != 1:
        sys.exit(f"{path}: not an evaluate --passes file (version 1)")
    sun = struct.unpack_from("<4f", raw, 16)
    a = array.array("f")
    a.frombytes(raw[32:])
    n = w * h
    o, planes = 0, {}
    for name, ch in (("render", 3), ("truth", 3), ("cover", 1), ("mask", 1), ("normal", 3), ("vis", 1)):
        planes[name] = a[o:o + ch * n]
        o += ch * n
    return n, sun, planes


def nz_bin(z):
    return ("1 down (nz < -0.5)" if z < -0.5 else "2 down-side (-0.5..-0.2)" if z < -0.2 else
            "3 side (-0.2..0.2)" if z < 0.2 else "4 up-side (0.2..0.5)" if z < 0.5 else "5 up (nz > 0.5)")


def ns_bin(c):
    return ("1 away (< -0.2)" if c < -0.2 else "2 grazing (-0.2..0.2)" if c < 0.2 else
            "3 towards (0.2..0.6)" if c < 0.6 else "4 facing (> 0.6)")


def main():
    d = sys.argv[1]
    kind = sys.argv[2] if len(sys.argv) > 2 else "relight"
    files = sorted(glob.glob(f"{d}/{kind}_*.f32"))
    if not files:
        sys.exit(f"no {kind}_*.f32 in {d} (run evaluate with --renders {d} --passes)")
    tabs, sel, total_sq = {}, {}, 0.0

    def add(table, b, r, t, img):
        e = tabs.setdefault(table, {}).setdefault(b, {"n": 0, "t": 0.0, "r": [0.0] * 3, "sq": 0.0, "img": {}})
        e["n"] += 1
        e["t"] += t
        for k in range(3):
            e["r"][k] += r[k]
        e["sq"] += sum(x * x for x in r) / 3
        pi = e["img"].setdefault(img, [0, 0.0])
        pi[0] += 1
        pi[1] += sum(r) / 3

    for img, path in enumerate(files):
        n, sun, p = read(path)
        ren, tru, cov, msk, nrm, vis = (p[k] for k in ("render", "truth", "cover", "mask", "normal", "vis"))
        ls = math.sqrt(sum(x * x for x in sun[:3])) or 1.0
        s = [x / ls for x in sun[:3]]
        px = []
        for i in range(n):
            if msk[i] < 0.5 or cov[i] <= 0.5:
                continue
            nx, ny, nz = nrm[3 * i], nrm[3 * i + 1], nrm[3 * i + 2]
            if nx * nx + ny * ny + nz * nz < 0.5:
                continue  # no head under the face mask's sample
            r = [ren[3 * i + k] - tru[3 * i + k] for k in range(3)]
            t = sum(tru[3 * i:3 * i + 3]) / 3
            ns = nx * s[0] + ny * s[1] + nz * s[2]
            total_sq += sum(x * x for x in r) / 3
            add("all", "all", r, t, img)
            add("by the normal's vertical component nz (world up)", nz_bin(nz), r, t, img)
            add("by the normal's cosine to the image's sun", ns_bin(ns), r, t, img)
            shade = ("3 lit (n.s > 0.05, V >= 0.5)" if ns > 0.05 and vis[i] >= 0.5 else
                     "1 attached shadow (n.s <= 0.05)" if ns <= 0.05 else "2 cast shadow (n.s > 0.05, V < 0.5)")
            add("by the render's sun shading (V: its sun visibility)", shade, r, t, img)
            lit = shade.startswith("3")
            add("lit pixels by nz" if lit else "shadowed pixels (attached or cast) by nz", nz_bin(nz), r, t, img)
            px.append((sum(ren[3 * i:3 * i + 3]) / 3, t))
        k30 = int(0.3 * len(px))
        for by, key in (("truth", lambda q: q[1]), ("render", lambda q: q[0])):
            srt = sorted(px, key=key)
            for part, sub in (("darkest", srt[:k30]), ("brightest", srt[len(srt) - k30:])):
                if sub:
                    sel.setdefault((by, part), []).append(sum(a - b for a, b in sub) / len(sub))
    print(f"{len(files)} {kind} images in {d}; residual = render - truth (display units), truth mask & covered")
    for table, bins in tabs.items():
        print(f"\n{table}\n")
        print("| bin | pixels | truth mean | residual | R / G / B | share of squared error | per image |")
        print("|---|---|---|---|---|---|---|")
        for b in sorted(bins):
            e = bins[b]
            c = e["n"]
            per = [v[1] / v[0] for v in e["img"].values() if v[0] >= 50]
            rng = f"{min(per):+.3f}..{max(per):+.3f}" if per else ""
            rgb = " / ".join(f"{x / c:+.3f}" for x in e["r"])
            name = b if b == "all" else b[2:]
            print(f"| {name} | {c} | {e['t'] / c:.3f} | {sum(e['r']) / 3 / c:+.4f} | {rgb} | "
                  f"{100 * e['sq'] / total_sq:.0f}% | {rng} |")
    print("\nmean over images of the residual over each image's darkest / brightest 30 %, chosen by:")
    for by in ("truth", "render"):
        v = [sel.get((by, part), []) for part in ("darkest", "brightest")]
        if v[0] and v[1]:
            print(f"  the {by}: {sum(v[0]) / len(v[0]):+.4f} / {sum(v[1]) / len(v[1]):+.4f}")


if __name__ == "__main__":
    main()
