#!/bin/sh
# SPDX-License-Identifier: MIT
# Serves the face viewer for one exported face on this machine only (127.0.0.1) and prints the URL
# to open in a browser. Installs three.js from package-lock.json on first use (npm ci; no CDN at run
# time). The environment map is used when the .glb names one (extras environment_map.uri, a file
# beside it): a STEM.env.hdr left over from an older export of a fit without environment is ignored.
# usage: tools/viewer/serve.sh FACE.glb [PORT]     (default port 8765; Ctrl-C stops the server)
set -eu
[ $# -ge 1 ] || { echo "usage: $0 FACE.glb [PORT]" >&2; exit 1; }
GLB=$1 PORT=${2:-8765}
[ -f "$GLB" ] || { echo "serve.sh: no such file: $GLB" >&2; exit 1; }
HERE=$(cd "$(dirname "$0")" && pwd)
command -v python3 >/dev/null 2>&1 || { echo "serve.sh: python3 is needed for the local server" >&2; exit 1; }
if [ ! -f "$HERE/node_modules/three/package.json" ]; then
    command -v npm >/dev/null 2>&1 || { echo "serve.sh: npm is needed once to install three.js" >&2; exit 1; }
    echo "serve.sh: installing three.js (npm ci) into $HERE/node_modules"
    (cd "$HERE" && npm ci --omit=dev --no-audit --no-fund --loglevel=error)
fi
# A throw-away web root: the page, three.js and the asset, linked (the server follows links).
ROOT=$(mktemp -d)
trap 'rm -rf "$ROOT"' EXIT INT TERM
ln -s "$HERE/index.html" "$HERE/viewer.js" "$HERE/node_modules" "$ROOT/"
ln -s "$(cd "$(dirname "$GLB")" && pwd)/$(basename "$GLB")" "$ROOT/face.glb"
query="glb=face.glb"
# the environment map's file name from the .glb's JSON chunk (header 12 bytes, chunk length + type 8)
ENV_NAME=$(python3 - "$GLB" <<'PY'
import json, struct, sys
def find(node):
    if isinstance(node, dict):
        env = node.get("environment_map")
        if isinstance(env, dict) and isinstance(env.get("uri"), str):
            return env["uri"]
        node = list(node.values())
    if isinstance(node, list):
        for v in node:
            hit = find(v)
            if hit:
                return hit
    return None
with open(sys.argv[1], "rb") as f:
    magic, _, _, length, kind = struct.unpack("<4sIIII", f.read(20))
    if magic == b"glTF" and kind == 0x4E4F534A:
        name = find(json.loads(f.read(length)))
        if name and "/" not in name:
            print(name)
PY
) || ENV_NAME=""
ENV="$(dirname "$GLB")/$ENV_NAME"
if [ -n "$ENV_NAME" ] && [ -f "$ENV" ]; then
    ln -s "$(cd "$(dirname "$ENV")" && pwd)/$(basename "$ENV")" "$ROOT/face.env.hdr"
    query="$query&env=face.env.hdr"
fi
echo "open http://127.0.0.1:$PORT/index.html?$query"
cd "$ROOT"
python3 -m http.server "$PORT" --bind 127.0.0.1 >/dev/null 2>"$ROOT/.server.log" ||
    { tail -n 3 "$ROOT/.server.log" >&2; exit 1; }
