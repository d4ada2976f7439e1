#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Makes a variant of a path-traced selfie capture (the layout of ../shared/captures), so a fit can be measured
on more than one sequence of a head and on frames as a phone would deliver them:
  even, odd   its even or odd frames alone, renumbered from 0;
  half        every frame at half the width and height (2 x 2 box filter), the intrinsics and the true
              landmarks moved with them (pixel centres at integers, as meta.json says);
  jpegQ       every frame re-encoded as JPEG at quality Q (1-95; Pillow, 4:2:0 chroma), e.g. jpeg50;
  aeA         every frame's light scaled by 2^(A sin(2 pi k / 60)) at frame k (an auto-exposure drift of
              +-A stops, 0 < A <= 2, e.g. ae0.5; sRGB decoded and encoded, clipped at 1, PNG) and no exposure
              written anywhere, as a phone's video without metadata.
Variants chain: a variant's directory is a capture directory (jpeg50 of the even frames: make `even`, then
`jpeg50` from it).

Usage: selfie_variant.py CAPTURE_DIR OUT_DIR even|odd|half|jpegQ|aeA

OUT_DIR must not exist or be empty. It gets symbolic links to the capture's files that stay as they are
(imu.csv, gt/'s files, and the frames for even and odd: nothing large is copied), frames written anew for half,
jpegQ and aeA, and, written anew, frames.csv, gt/landmarks.csv and meta.json, whose "frames" list is what
`sunprobe evaluate` reads to pair the fit's keyframes with the true cameras. The IMU log is the whole
capture's. Import and fit the variant as tests/integration/test_shared_selfie.sh does with the capture itself."""
import csv, json, math, os, re, sys


def link_all(src, dst, skip):
    for name in os.listdir(src):
        if name not in skip:
            os.symlink(os.path.join(src, name), os.path.join(dst, name))


def parse_mode(mode):
    m = re.fullmatch(r"jpeg(\d+)", mode)
    if m and 1 <= int(m.group(1)) <= 95:
        return "jpeg", int(m.group(1))
    m = re.fullmatch(r"ae(\d*\.?\d+)", mode)
    if m and 0 < float(m.group(1)) <= 2:
        return "ae", float(m.group(1))
    if mode in ("even", "odd", "half"):
        return mode, None
    sys.exit(__doc__)


def reexpose(Image, im, stops):
    """im (Pillow; Image its module), sRGB, with its linear light scaled by 2^stops, clipped, 8 bits again."""
    import numpy as np
    v = np.asarray(im, dtype=np.float64) / 255.0
    lin = np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4) * 2.0 ** stops
    lin = np.clip(lin, 0.0, 1.0)
    out = np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * lin ** (1 / 2.4) - 0.055)
    return Image.fromarray((out * 255.0 + 0.5).astype(np.uint8))


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    src, dst = os.path.abspath(sys.argv[1]), sys.argv[2]
    mode, arg = parse_mode(sys.argv[3])  # arg: the JPEG quality or the drift in stops
    if os.path.exists(dst) and (not os.path.isdir(dst) or os.listdir(dst)):
        sys.exit(f"selfie_variant.py: {dst}: exists and is not an empty directory")
    with open(os.path.join(src, "frames.csv")) as f:
        rows = list(csv.DictReader(f))
    with open(os.path.join(src, "meta.json")) as f:
        meta = json.load(f)
    with open(os.path.join(src, "gt", "landmarks.csv")) as f:
        marks = list(csv.DictReader(f))
    if mode in ("even", "odd"):
        kept = [i for i in range(len(rows)) if i % 2 == (mode == "odd")]
    else:
        kept = list(range(len(rows)))
        from PIL import Image  # only the variants that write frames need Pillow (python3-pil), ae NumPy too
    new_index = {i: k for k, i in enumerate(kept)}
    os.makedirs(os.path.join(dst, "frames"))
    os.makedirs(os.path.join(dst, "gt"))
    link_all(src, dst, ("frames", "frames.csv", "meta.json", "gt"))
    link_all(os.path.join(src, "gt"), os.path.join(dst, "gt"), ("landmarks.csv",))
    by_index = {f["index"]: f for f in meta["frames"]}
    meta["frames"] = []
    with open(os.path.join(dst, "frames.csv"), "w") as out:
        out.write("t_ns,file\n")
        for k, i in enumerate(kept):
            ext = ".jpg" if mode == "jpeg" else ".png" if mode == "ae" else os.path.splitext(rows[i]["file"])[1]
            name = "frames/%05d%s" % (k, ext)
            if mode in ("even", "odd"):
                os.symlink(os.path.join(src, rows[i]["file"]), os.path.join(dst, name))
            else:
                im = Image.open(os.path.join(src, rows[i]["file"])).convert("RGB")
                if mode == "half":
                    im.resize((im.width // 2, im.height // 2), Image.BOX).save(os.path.join(dst, name))
                elif mode == "ae":
                    reexpose(Image, im, arg * math.sin(2 * math.pi * k / 60)).save(os.path.join(dst, name))
                else:
                    im.save(os.path.join(dst, name), quality=arg)
            out.write("%s,%s\n" % (rows[i]["t_ns"], name))
            meta["frames"].append(dict(by_index[i], index=k, file=name))
    meta["image"]["n_frames"] = len(kept)
    img = meta["image"]
    sx, sy = (img["width"] // 2) / img["width"], (img["height"] // 2) / img["height"]  # the box resize's scales
    half = lambda v, s: (float(v) + 0.5) * s - 0.5  # pixel centres at integers, in the half-size image
    if mode == "half":
        cam = meta["camera"]
        cam["fx"], cam["fy"] = cam["fx"] * sx, cam["fy"] * sy
        cam["cx"], cam["cy"] = half(cam["cx"], sx), half(cam["cy"], sy)
        cam["K"] = [[cam["fx"], 0, cam["cx"]], [0, cam["fy"], cam["cy"]], [0, 0, 1]]
        img["width"] //= 2
        img["height"] //= 2
    if mode == "jpeg":
        img["files"], img["encoding"] = "frames/%05d.jpg", "8-bit sRGB JPEG, quality %d (Pillow, 4:2:0)" % arg
    if mode == "ae":
        img["encoding"] = "8-bit sRGB PNG, light scaled by 2^(%g sin(2 pi k / 60)) at frame k" % arg
    with open(os.path.join(dst, "gt", "landmarks.csv"), "w", newline="") as out:
        w = csv.DictWriter(out, fieldnames=list(marks[0].keys()))
        w.writeheader()
        for r in marks:
            if int(r["frame"]) in new_index:
                r = dict(r, frame=new_index[int(r["frame"])])
                if mode == "half":
                    r["u"], r["v"] = "%.4f" % half(r["u"], sx), "%.4f" % half(r["v"], sy)
                w.writerow(r)
    with open(os.path.join(dst, "meta.json"), "w") as out:
        json.dump(meta, out)


if __name__ == "__main__":
    main()
