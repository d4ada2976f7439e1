#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Scores a probe directory against a path-traced street capture's ground truth (../shared/captures).

usage: check_street_truth.py PROBE_DIR CAPTURE_DIR [--json OUT] [limits]
limits: --min-recall F --max-false-rate F --max-ground-false F --max-plane-error F --max-shadow-deg D
        --min-plate-psnr DB --max-relight-changed F --min-car-recall F (needs objects.csv)
Figures (each printed, one per line):
  recall        share of the occluder pixels a person passed behind (gt/occlusion_hits > 0) where the map
                would hide a figure standing as far as the farthest one hidden there (Z >= that foot row - 2)
  false rate    share of the pixels where a person was seen (gt/ids) where the map would hide a figure
                standing as far as the farthest one seen there (Z >= that foot row + 2)
  ground false  share of the visible ground (gt/ground.png, no occluder) marked occluding at all
  per occluder  marked share of each occluder's passed-behind pixels, and the spread of Z over them
  plane         median |h - height_px| / height_px over people rows that are neither occluded nor truncated
  shadow        when the probe says a sun shadow is present: median angle between its direction at each
                such foot point and the true one (towards meta.sun.shadow_vanishing_point)
  plate         PSNR (dB, 8-bit) of clean_plate.png against gt/clean_plate.png
  classes       with objects.csv (probe --objects): each object's true class from gt/ids inside its box
                (car or person when that kind has more pixels there than the other and covers a fifth of the
                box, else none): the share of true cars called car, of true people called person, and how
                many cars were called person
  relighting    how well the lighting map carries a person's colour from one place to another (eq. 3.4):
                for 200 random pairs of unoccluded views (>= 150 visible px) of each person, the median relative
                luma error of colour(a) * L(box b) / L(box a) against colour(b), L the map's mean over the
                covered pixels of the true box (at least a quarter covered); beside it the error of assuming
                no change, colour(b) = colour(a), and both over the pairs whose colour changed by > 25%
Rows are image rows: a foot at foot_y (pixel-centre coordinates, centres at +0.5) is on row floor(foot_y).
Exits 1 when a limit is exceeded, 2 on unreadable input.
"""
import argparse, csv, json, math, os, sys

import numpy as np
from PIL import Image


def read_pfm(path):
    with open(path, "rb") as f:
        kind = f.readline().strip()
        w, h = (int(v) for v in f.readline().split())
        scale = float(f.readline())
        ch = 3 if kind == b"PF" else 1
        data = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4", count=w * h * ch)
    return np.flipud(data.reshape(h, w, ch) if ch == 3 else data.reshape(h, w))


def png(path, dtype=None):
    a = np.asarray(Image.open(path))
    return a.astype(dtype) if dtype else a


def luma(c):
    return 0.299 * c[0] + 0.587 * c[1] + 0.114 * c[2]


def classes(path, gt):
    rows = list(csv.DictReader(open(path)))
    c = {k: 0 for k in ("cars", "car_as_car", "car_as_person", "people", "person_as_person", "person_as_car",
                        "none", "none_as_person")}
    ids_cache = {}
    for r in rows:
        f = int(r["frame"])
        if f not in ids_cache:
            ids_cache.clear()
            ids_cache[f] = png(os.path.join(gt, "ids", f"{f:05d}.png"))
        ids = ids_cache[f]
        box = ids[int(r["y0"]):int(r["y1"]) + 1, int(r["x0"]):int(r["x1"]) + 1]
        car, person = int((box > 100).sum()), int(((box > 0) & (box < 100)).sum())
        truth = ("car" if car > person and car >= 0.2 * box.size else
                 "person" if person > car and person >= 0.2 * box.size else "none")
        said = r["class"]
        if truth == "car":
            c["cars"] += 1
            c["car_as_car"] += said == "car"
            c["car_as_person"] += said == "person"
        elif truth == "person":
            c["people"] += 1
            c["person_as_person"] += said == "person"
            c["person_as_car"] += said == "car"
        else:
            c["none"] += 1
            c["none_as_person"] += said == "person"
    return c


def relighting(light, people):
    views = {}
    for r in people:
        if (int(r["occluded"]) or int(r["truncated"]) or int(r["occluded_by_person"]) or int(r["occluded_by_car"])
                or int(r["vis_px"]) < 150):
            continue
        x0, y0, x1, y1 = (int(r[k]) for k in ("bbox_x0", "bbox_y0", "bbox_x1", "bbox_y1"))
        v = light[y0:y1, x0:x1].reshape(-1, 3)
        v = v[v.sum(1) > 0]
        if len(v) < 0.25 * (x1 - x0) * (y1 - y0):
            continue
        colour = np.array([float(r[k]) for k in ("mean_r", "mean_g", "mean_b")])
        views.setdefault(r["id"], []).append((colour, v.mean(0)))
    rng = np.random.default_rng(1)
    err, none = [], []
    for vs in views.values():
        for _ in range(200 if len(vs) > 1 else 0):
            i, j = rng.choice(len(vs), 2, replace=False)
            (ca, la), (cb, lb) = vs[i], vs[j]
            err.append(abs(luma(ca * lb / np.maximum(la, 1e-3)) - luma(cb)) / luma(cb))
            none.append(abs(luma(ca) - luma(cb)) / luma(cb))
    if not err:
        return None
    err, none = np.array(err), np.array(none)
    ch = none > 0.25
    return {"pairs": int(err.size), "map": float(np.median(err)), "none": float(np.median(none)),
            "changed": int(ch.sum()), "map_changed": float(np.median(err[ch])) if ch.any() else None,
            "none_changed": float(np.median(none[ch])) if ch.any() else None}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("probe_dir")
    ap.add_argument("capture_dir")
    ap.add_argument("--json")
    ap.add_argument("--min-recall", type=float)
    ap.add_argument("--max-false-rate", type=float)
    ap.add_argument("--max-ground-false", type=float)
    ap.add_argument("--max-plane-error", type=float)
    ap.add_argument("--max-shadow-deg", type=float)
    ap.add_argument("--min-plate-psnr", type=float)
    ap.add_argument("--max-relight-changed", type=float)
    ap.add_argument("--min-car-recall", type=float)
    a = ap.parse_args()
    cap, gt = a.capture_dir, os.path.join(a.capture_dir, "gt")
    try:
        meta = json.load(open(os.path.join(cap, "meta.json")))
        probe = json.load(open(os.path.join(a.probe_dir, "probe.json")))
        z = read_pfm(os.path.join(a.probe_dir, "occlusion.pfm"))
        hits = png(os.path.join(gt, "occlusion_hits.png"), np.int64)
        zmax = png(os.path.join(gt, "occlusion_zmax.png"), np.int64)
        occluders = png(os.path.join(gt, "occluders.png"))
        ground = png(os.path.join(gt, "ground.png")) > 0
        people = list(csv.DictReader(open(os.path.join(gt, "people.csv"))))
    except (OSError, ValueError, KeyError) as e:
        print(f"check_street_truth: {e}", file=sys.stderr)
        return 2
    h, w = hits.shape
    if z.shape != (h, w):
        print(f"check_street_truth: {a.probe_dir}/occlusion.pfm is {z.shape[1]}x{z.shape[0]}, the truth {w}x{h}",
              file=sys.stderr)
        return 2
    out = {}
    behind = hits > 0
    far_row = np.floor(zmax / 16.0)
    recalled = behind & (z >= 0) & (z >= far_row - 2)
    out["recall"] = float(recalled.sum() / max(behind.sum(), 1))
    out["occluder_pixels_passed_behind"] = int(behind.sum())

    # farthest foot row seen at each pixel, from the id images and the people rows
    foot = {}
    for r in people:
        foot[(int(r["frame"]), int(r["id"]))] = math.floor(float(r["foot_y"]))
    seen = np.full((h, w), -1, dtype=np.int64)
    frames = sorted({f for f, _ in foot})
    for f in frames:
        ids = png(os.path.join(gt, "ids", f"{f:05d}.png"))
        lut = np.full(256, -1, dtype=np.int64)
        for (ff, pid), row in foot.items():
            if ff == f and pid < 100:
                lut[pid] = row
        seen = np.maximum(seen, lut[ids])
    was_seen = seen >= 0
    wrong = was_seen & (z >= 0) & (z >= seen + 2)
    out["false_rate"] = float(wrong.sum() / max(was_seen.sum(), 1))
    open_ground = ground & (occluders == 0)
    out["ground_false"] = float((open_ground & (z >= 0)).sum() / max(open_ground.sum(), 1))

    per = {}
    for o in meta.get("occluders", []):
        m = behind & (occluders == o["index"])
        if m.sum() < 20:
            continue
        zs = z[m & (z >= 0)]
        per[o["name"]] = {"passed_behind": int(m.sum()), "recall": float((recalled & m).sum() / m.sum()),
                          "marked": float((m & (z >= 0)).sum() / m.sum()),
                          "z_p10_p90": [float(np.percentile(zs, 10)), float(np.percentile(zs, 90))] if zs.size else None}
    out["occluders"] = per

    plane = probe.get("plane", {})
    errs, angs = [], []
    shadow = probe.get("shadow", {})
    vp = meta.get("sun", {}).get("shadow_vanishing_point")
    for r in people:
        if int(r["occluded"]) or int(r["truncated"]) or int(r["occluded_by_person"]) or int(r["occluded_by_car"]):
            continue
        x, y = float(r["foot_x"]) - 0.5, float(r["foot_y"]) - 0.5  # pixel-centre coordinates at integers
        if plane.get("status") == "ok":
            hp = plane["a"] * x + plane["b"] * y + plane["c"]
            errs.append(abs(hp - float(r["height_px"])) / float(r["height_px"]))
        if shadow.get("present") and vp:
            u, v = x / w, y / h
            dx = shadow["ox"][0] + shadow["ox"][1] * u + shadow["ox"][2] * v
            dy = shadow["oy"][0] + shadow["oy"][1] * u + shadow["oy"][2] * v
            d = abs(math.atan2(dy, dx) - math.atan2(vp[1] - y, vp[0] - x)) * 180 / math.pi
            angs.append(min(d, 360 - d))
    out["plane_status"] = plane.get("status")
    out["plane_error"] = float(np.median(errs)) if errs else None
    out["shadow_present"] = bool(shadow.get("present"))
    out["shadow_deg"] = float(np.median(angs)) if angs else None
    try:
        mine = png(os.path.join(a.probe_dir, "clean_plate.png"), np.float64)[..., :3]
        true = png(os.path.join(gt, "clean_plate.png"), np.float64)[..., :3]
        mse = float(np.mean((mine - true) ** 2))
        out["plate_psnr_db"] = 10 * math.log10(255.0 ** 2 / max(mse, 1e-12))
    except OSError as e:
        print(f"check_street_truth: {e}", file=sys.stderr)
        return 2

    print(f"recall {out['recall']:.3f} of {out['occluder_pixels_passed_behind']} occluder pixels passed behind")
    print(f"false rate {out['false_rate']:.4f} of {int(was_seen.sum())} pixels where people were seen")
    print(f"ground false {out['ground_false']:.4f} of {int(open_ground.sum())} open ground pixels")
    for name, p in per.items():
        print(f"  {name}: marked {p['marked']:.3f}, recall {p['recall']:.3f} of {p['passed_behind']} px, "
              f"Z p10..p90 {p['z_p10_p90']}")
    pe = out["plane_error"]
    print(f"plane {out['plane_status']}: median relative height error "
          + (f"{pe:.4f} over {len(errs)} rows" if pe is not None else "n/a"))
    sd = out["shadow_deg"]
    print("shadow " + (f"present: median direction error {sd:.2f} deg over {len(angs)} rows" if sd is not None
                       else "left out: " + str(shadow.get("note"))))
    print(f"plate PSNR {out['plate_psnr_db']:.2f} dB")
    try:
        light = read_pfm(os.path.join(a.probe_dir, "lighting.pfm"))
    except OSError as e:
        print(f"check_street_truth: {e}", file=sys.stderr)
        return 2
    out["relighting"] = relighting(light, people)
    objects_csv = os.path.join(a.probe_dir, "objects.csv")
    if os.path.exists(objects_csv):
        out["classes"] = classes(objects_csv, gt)
        c = out["classes"]
        print(f"classes: {c['car_as_car']}/{c['cars']} cars called car, {c['car_as_person']} called person; "
              f"{c['person_as_person']}/{c['people']} people called person, {c['person_as_car']} called car; "
              f"{c['none_as_person']}/{c['none']} objects that are neither called person")
    r = out["relighting"]
    if r:
        print(f"relighting: median relative luma error {r['map']:.3f} over {r['pairs']} pairs (no change assumed: "
              f"{r['none']:.3f}); over the {r['changed']} pairs that changed by > 25%: {r['map_changed']:.3f} "
              f"(no change: {r['none_changed']:.3f})")
    if a.json:
        json.dump(out, open(a.json, "w"), indent=1)

    fails = []
    if a.min_recall is not None and not out["recall"] >= a.min_recall:
        fails.append(f"recall {out['recall']:.3f} < {a.min_recall}")
    if a.max_false_rate is not None and not out["false_rate"] <= a.max_false_rate:
        fails.append(f"false rate {out['false_rate']:.4f} > {a.max_false_rate}")
    if a.max_ground_false is not None and not out["ground_false"] <= a.max_ground_false:
        fails.append(f"ground false {out['ground_false']:.4f} > {a.max_ground_false}")
    if a.max_plane_error is not None and not (pe is not None and pe <= a.max_plane_error):
        fails.append(f"plane error {pe} > {a.max_plane_error}")
    if a.max_shadow_deg is not None and not (sd is not None and sd <= a.max_shadow_deg):
        fails.append(f"shadow direction {sd} > {a.max_shadow_deg} deg (or left out)")
    if a.min_plate_psnr is not None and not out["plate_psnr_db"] >= a.min_plate_psnr:
        fails.append(f"plate PSNR {out['plate_psnr_db']:.2f} < {a.min_plate_psnr} dB")
    if a.max_relight_changed is not None and not (r and r["map_changed"] is not None and
                                                  r["map_changed"] <= a.max_relight_changed):
        fails.append(f"relighting error over changed pairs {r and r['map_changed']} > {a.max_relight_changed}")
    if a.min_car_recall is not None:
        c = out.get("classes")
        if not c or not c["cars"] or c["car_as_car"] < a.min_car_recall * c["cars"]:
            fails.append(f"cars called car: {c and c['car_as_car']} of {c and c['cars']} (or no objects.csv)")
        elif c["car_as_person"] or c["person_as_car"]:
            fails.append(f"{c['car_as_person']} cars called person, {c['person_as_car']} people called car")
    for f in fails:
        print("check_street_truth: FAIL " + f, file=sys.stderr)
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main())
