#!/usr/bin/env bash
# Check a baked hand GLB with the Khronos glTF-Validator and play it in three.js (Node), outside the
# repository: the npm packages go into a scratch folder (default /tmp/fh-gltf-check), never into the tree.
#   scripts/gltf_check/run.sh out/demo/hand_showcase.glb
set -euo pipefail
glb=$(realpath "$1")
here=$(cd "$(dirname "$0")" && pwd)
scratch=${FH_GLTF_CHECK_DIR:-/tmp/fh-gltf-check}
mkdir -p "$scratch"
cp "$here/validate.js" "$here/play.mjs" "$scratch/"
cd "$scratch"
[ -d node_modules/gltf-validator ] && [ -d node_modules/three ] || npm install --silent gltf-validator three@0.160.0
node validate.js "$glb"
node play.mjs "$glb"
