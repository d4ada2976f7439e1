#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Makes a variant of a path-traced selfie capture (the layout of ../shared/captures): its even or odd
frames alone, renumbered from 0, so a fit can be measured on more than one sequence of a head.

Usage: selfie_variant.py CAPTURE_DIR OUT_DIR even|odd

OUT_DIR must not exist or be empty. It gets symbolic links to the capture's files (frames, imu.csv, gt/'s
files: nothing large is copied) and, written anew and renumbered the same way, frames.csv (the kept frames
with their own timestamps), gt/landmarks.csv and meta.json, whose "frames" list is what `sunprobe evaluate`
reads to pair the fit's keyframes with the true cameras. The IMU log is the whole capture's. Import and fit
the variant as tests/integration/test_shared_selfie.sh does with the capture itself."""
import csv, json, os, sys


def link_all(src, dst, skip):
    for name in os.listdir(src):
        if name not in skip:
            os.symlink(os.path.join(src, name), os.path.join(dst, name))


def main():
    if len(sys.argv) != 4 or sys.argv[3] not in ("even", "odd"):
        sys.exit(__doc__)
    src, dst, parity = os.path.abspath(sys.argv[1]), sys.argv[2], 0 if sys.argv[3] == "even" else 1
    if os.path.exists(dst) and (not os.path.isdir(dst) or os.listdir(dst)):
        sys.exit(f"selfie_variant.py: {dst}: exists and is not an empty directory")
    with open(os.path.join(src, "frames.csv")) as f:
        rows = list(csv.DictReader(f))
    with open(os.path.join(src, "meta.json")) as f:
        meta = json.load(f)
    with open(os.path.join(src, "gt", "landmarks.csv")) as f:
        marks = list(csv.DictReader(f))
    kept = [i for i in range(len(rows)) if i % 2 == parity]
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
            name = "frames/%05d%s" % (k, os.path.splitext(rows[i]["file"])[1])
            os.symlink(os.path.join(src, rows[i]["file"]), os.path.join(dst, name))
            out.write("%s,%s\n" % (rows[i]["t_ns"], name))
            meta["frames"].append(dict(by_index[i], index=k, file=name))
    meta["image"]["n_frames"] = len(kept)
    with open(os.path.join(dst, "gt", "landmarks.csv"), "w", newline="") as out:
        w = csv.DictWriter(out, fieldnames=list(marks[0].keys()))
        w.writeheader()
        for r in marks:
            if int(r["frame"]) in new_index:
                w.writerow(dict(r, frame=new_index[int(r["frame"])]))
    with open(os.path.join(dst, "meta.json"), "w") as out:
        json.dump(meta, out)


if __name__ == "__main__":
    main()
