#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Makes a variant of a path-traced selfie capture (the layout of ../shared/captures): its even or odd
frames alone, renumbered from 0, so a fit can be measured on more than one sequence of a head.

Usage: selfie_variant.py CAPTURE_DIR OUT_DIR even|odd

OUT_DIR gets symbolic links to the capture's files (frames, gt/, imu.csv: nothing is copied), a frames.csv
of the kept frames with their own timestamps and a meta.json whose "frames" list is cut and re-indexed the
same way, which is what `sunprobe evaluate` reads to pair the fit's keyframes with the true cameras. The IMU
log is the whole capture's. gt/landmarks.csv keeps the original frame numbers. Import and fit the variant as
tests/integration/test_shared_selfie.sh does with the capture itself."""
import csv, json, os, sys


def main():
    if len(sys.argv) != 4 or sys.argv[3] not in ("even", "odd"):
        sys.exit(__doc__)
    src, dst, parity = os.path.abspath(sys.argv[1]), sys.argv[2], 0 if sys.argv[3] == "even" else 1
    rows = list(csv.DictReader(open(os.path.join(src, "frames.csv"))))
    meta = json.load(open(os.path.join(src, "meta.json")))
    os.makedirs(os.path.join(dst, "frames"), exist_ok=True)
    for name in os.listdir(src):
        if name not in ("frames", "frames.csv", "meta.json") and not os.path.lexists(os.path.join(dst, name)):
            os.symlink(os.path.join(src, name), os.path.join(dst, name))
    by_index = {f["index"]: f for f in meta["frames"]}
    kept = [i for i in range(len(rows)) if i % 2 == parity]
    meta["frames"] = []
    with open(os.path.join(dst, "frames.csv"), "w") as out:
        out.write("t_ns,file\n")
        for k, i in enumerate(kept):
            name = "frames/%05d%s" % (k, os.path.splitext(rows[i]["file"])[1])
            link = os.path.join(dst, name)
            if not os.path.lexists(link):
                os.symlink(os.path.join(src, rows[i]["file"]), link)
            out.write("%s,%s\n" % (rows[i]["t_ns"], name))
            frame = dict(by_index[i], index=k, file=name)
            meta["frames"].append(frame)
    with open(os.path.join(dst, "meta.json"), "w") as out:
        json.dump(meta, out)


if __name__ == "__main__":
    main()
