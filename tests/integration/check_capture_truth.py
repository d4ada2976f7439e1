#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Scores camera orientations against a path-traced capture's ground truth (../shared/captures).

usage: check_capture_truth.py fit FACE_DIR META_JSON [limits]     a fit's keyframe cameras and its sun
       check_capture_truth.py orientation CSV META_JSON [limits]  `sunprobe replay --stage orientation -o CSV`
       check_capture_truth.py to-camera META_JSON                 prints imu.to_camera (w,x,y,z) from R_dev_from_cam
       check_capture_truth.py landmarks CSV LANDMARKS_CSV [limits] `sunprobe replay --stage landmarks -o CSV` against
                                                                  gt/landmarks.csv (visible points only)
limits: --max-camera-deg D --max-up-deg D --max-sun-deg D --min-coverage F --max-landmark-error F
Frames are matched by sequence = the capture's frame index. The fit's world has an arbitrary heading; it
is mapped onto the truth's world by the rotation that best aligns the cameras (a sign-consistent
quaternion mean). The camera tilt (its up axis against the world's up) needs no alignment. Landmark errors
are over the true inter-ocular distance (outer eye corners, points 36 and 45); coverage counts frames with
a visible face that got landmarks. Prints the figures; exits 1 when a limit is exceeded.
"""
import argparse, csv, json, math, sys

def q_to_m(w, x, y, z):
    return [[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]]

def m_to_q(m):
    t = m[0][0] + m[1][1] + m[2][2]
    if t > 0:
        s = math.sqrt(t + 1) * 2
        return [0.25 * s, (m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s]
    i = max(range(3), key=lambda k: m[k][k])
    j, k = (i + 1) % 3, (i + 2) % 3
    s = math.sqrt(1 + m[i][i] - m[j][j] - m[k][k]) * 2
    q = [0.0] * 4
    q[0] = (m[k][j] - m[j][k]) / s
    q[1 + i] = 0.25 * s
    q[1 + j] = (m[j][i] + m[i][j]) / s
    q[1 + k] = (m[k][i] + m[i][k]) / s
    return q

def mul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]

def tr(a):
    return [[a[j][i] for j in range(3)] for i in range(3)]

def angle(a, b):  # degrees between rotations
    d = mul(tr(a), b)
    return math.degrees(math.acos(max(-1.0, min(1.0, (d[0][0] + d[1][1] + d[2][2] - 1) / 2))))

def alignment(pairs):
    acc, first = [0.0] * 4, None
    for est, true in pairs:
        q = m_to_q(mul(true, tr(est)))
        first = first or q
        s = 1.0 if sum(x * y for x, y in zip(q, first)) >= 0 else -1.0
        acc = [u + s * v for u, v in zip(acc, q)]
    n = math.sqrt(sum(x * x for x in acc))
    return q_to_m(*[x / n for x in acc])

def tilt(m):  # degrees between the camera's up (-y) and the world's up (+z)
    return math.degrees(math.acos(max(-1.0, min(1.0, -m[2][1]))))

def score_cameras(label, pairs, a):
    align = alignment(pairs)
    errs = [angle(mul(align, est), true) for est, true in pairs]
    ups = [abs(tilt(est) - tilt(true)) for est, true in pairs]
    print(f"{label}: {len(pairs)} frames, error after heading alignment mean {sum(errs) / len(errs):.2f} max "
          f"{max(errs):.2f} deg; tilt error mean {sum(ups) / len(ups):.2f} max {max(ups):.2f} deg")
    return align, max(errs) > a.max_camera_deg or max(ups) > a.max_up_deg

def score_landmarks(a):
    truth = {}
    for r in csv.DictReader(open(a.paths[1])):
        truth.setdefault(int(r["frame"]), {})[int(r["landmark"])] = (float(r["u"]), float(r["v"]), r["visible"] == "1")
    found = {int(r["sequence"]): r for r in csv.DictReader(open(a.paths[0])) if r["source"] != "none"}
    faces = [f for f, pts in truth.items() if sum(v for _, _, v in pts.values()) >= 17]  # a quarter of the points seen
    errs = []
    for f in faces:
        if f not in found:
            continue
        pts = truth[f]
        iod = math.hypot(pts[45][0] - pts[36][0], pts[45][1] - pts[36][1])
        e = [math.hypot(float(found[f][f"x{k}"]) - u, float(found[f][f"y{k}"]) - v) for k, (u, v, vis) in pts.items() if vis]
        errs.append(sum(e) / len(e) / iod)
    cov = len(errs) / len(faces) if faces else 0.0
    errs.sort()
    mean = sum(errs) / len(errs) if errs else math.inf
    worst = errs[-1] if errs else math.inf
    p90 = errs[int(0.9 * (len(errs) - 1))] if errs else math.inf
    print(f"landmarks: {len(errs)} of {len(faces)} frames with a visible face ({100 * cov:.1f}%); error over the "
          f"inter-ocular distance mean {100 * mean:.2f}%, 90th percentile {100 * p90:.2f}%, max {100 * worst:.2f}%")
    return 1 if cov < a.min_coverage or mean > a.max_landmark_error else 0

def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("mode", choices=["fit", "orientation", "to-camera", "landmarks"])
    ap.add_argument("paths", nargs="+")
    ap.add_argument("--max-camera-deg", type=float, default=math.inf)
    ap.add_argument("--max-up-deg", type=float, default=math.inf)
    ap.add_argument("--max-sun-deg", type=float, default=math.inf)
    ap.add_argument("--min-coverage", type=float, default=0.0)
    ap.add_argument("--max-landmark-error", type=float, default=math.inf)
    a = ap.parse_args()
    if a.mode == "landmarks":
        return score_landmarks(a)
    meta = json.load(open(a.paths[-1]))
    if a.mode == "to-camera":  # camera = R_dev_from_cam^T device: the rotation taking IMU axes to camera axes
        print(",".join(f"{v:.12g}" for v in m_to_q(tr(meta["R_dev_from_cam"]))))
        return 0
    truth = {f["index"]: [r[:3] for r in f["cam_to_world"][:3]] for f in meta["frames"]}
    if a.mode == "orientation":
        rows = list(csv.DictReader(open(a.paths[0])))
        pairs = [(q_to_m(*(float(r[k]) for k in ("qw", "qx", "qy", "qz"))), truth[int(r["sequence"])])
                 for r in rows if int(r["sequence"]) in truth]
        if len(pairs) < len(truth):
            print(f"orientation: {len(truth) - len(pairs)} of {len(truth)} frames have no orientation")
            return 1
        return 1 if score_cameras("orientation", pairs, a)[1] else 0
    face_dir = a.paths[0]
    cams = json.load(open(f"{face_dir}/cameras.json"))["frames"]
    manifest = json.load(open(f"{face_dir}/manifest.json"))
    pairs = [(q_to_m(*c["camera_to_world_wxyz"]), truth[c["sequence"]]) for c in cams if c["sequence"] in truth]
    if not pairs:
        print("no fitted camera matches a ground-truth frame")
        return 1
    align, fails = score_cameras("fit cameras", pairs, a)
    light = manifest["lighting"]
    if meta.get("sun", {}).get("present") and not light["sun_dropped"]:
        s = light["sun_direction"]
        s = [sum(align[i][k] * s[k] for k in range(3)) for i in range(3)]
        t = meta["sun"]["dir_world"]
        e = math.degrees(math.acos(max(-1.0, min(1.0, sum(x * y for x, y in zip(s, t))))))
        print(f"fit sun: error {e:.2f} deg")
        fails |= e > a.max_sun_deg
    elif meta.get("sun", {}).get("present"):
        print("fit sun: dropped on a capture that has one")
        fails |= a.max_sun_deg < 180
    return 1 if fails else 0

if __name__ == "__main__":
    sys.exit(main())
