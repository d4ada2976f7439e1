#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The path-traced street from ../shared/captures (Blender Cycles: grainy frames stored as JPEG, skylit
# blue shadows, a car, seven occluders), imported as a user would and probed with the defaults, then
# scored against its ground truth by check_street_truth.py. Issue 17's targets (recall 0.90, false
# rate 1%) are far off on this capture; the limits here guard what is reached (PROBE.md, "The
# path-traced street"; session 30: recall 0.654 measured, 0.64 asked; 18 of 23 car views called car, 0.7
# asked; false rate 0.0002 and open ground 0.47% measured, 0.005 and 1% asked), so a change that loses
# ground fails.
# usage: test_shared_street.sh SUNPROBE CAPTURES_DIR
set -uo pipefail
sp=$1
cap=$2/street-sunny-dev1
here=$(cd "$(dirname "$0")" && pwd)
[ -f "$cap/meta.json" ] || { echo "SKIP: no path-traced street at $cap (../shared/captures)"; exit 77; }
# Debian's python3 with numpy and PIL (tools/install-deps.sh full); a python3 earlier on PATH may lack them
py=
for p in /usr/bin/python3 python3; do
    "$p" -c 'import numpy, PIL' 2>/dev/null && { py=$p; break; }
done
[ -n "$py" ] || { echo "SKIP: scoring needs python3 with numpy and PIL (python3-numpy python3-pil)"; exit 77; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

"$sp" import "$cap/frames" -o "$tmp/s.spcap" --frame-times "$cap/frames.csv" --kind static >"$tmp/import.log" 2>&1
rc=$?
[ $rc = 4 ] && { echo "SKIP: this build cannot import JPEG frames"; cat "$tmp/import.log"; exit 77; }
[ $rc = 0 ] || { cat "$tmp/import.log"; exit 1; }
"$sp" probe "$tmp/s.spcap" -o "$tmp/p" --objects >"$tmp/probe.log" 2>&1
rc=$?
[ $rc = 4 ] && { echo "SKIP: this build cannot decode JPEG frames"; cat "$tmp/probe.log"; exit 77; }
[ $rc = 0 ] || { cat "$tmp/probe.log"; exit 1; }
cat "$tmp/probe.log"
fail=0
"$py" "$here/check_street_truth.py" "$tmp/p" "$cap" --json "$tmp/score.json" --min-recall 0.64 \
    --max-false-rate 0.005 --max-ground-false 0.01 --max-plane-error 0.05 --min-plate-psnr 42 \
    --max-relight-changed 0.38 --min-car-recall 0.7 || fail=1
# people's blue, skylit shadows are shadows (5 of 281 observations cast one before the skylight test,
# 59 with it, 16 once grainy frames get noise-scaled shadow tests)
"$py" - "$tmp/p/probe.json" <<'PY' || fail=1
import json, sys
s = json.load(open(sys.argv[1]))["shadow"]
print(f"hard shadows: {s['shadows']} of {s['candidates']} person observations")
sys.exit(0 if s["shadows"] >= 12 else 1)
PY
exit $fail
