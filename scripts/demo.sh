#!/usr/bin/env bash
# The main job on the built-in bunny: set up, build, print its linked voxel model and write its
# surface to out/bunny.obj.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cmake --preset release >/dev/null
cmake --build --preset release --target voxcut
mkdir -p out
./build/release/apps/voxcut/voxcut info bunny
./build/release/apps/voxcut/voxcut surface bunny -o out/bunny.obj
