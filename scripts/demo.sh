#!/usr/bin/env bash
# The main job on the built-in bunny: set up, build, print its linked voxel model, then run the
# shipped scene scenes/bunny-ear.json (a blade cuts an ear off, the ear falls away) and write
# its deformed surfaces to out/bunny-ear/frame_NNNNN.obj every 10 frames; last, the same kind
# of story from Python (examples/python/embed_world.py, the package from the build folder).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cmake --preset release >/dev/null
cmake --build --preset release --target voxcut voxcut_python
mkdir -p out
./build/release/apps/voxcut/voxcut info bunny
./build/release/apps/voxcut/voxcut run scenes/bunny-ear.json --export out/bunny-ear --every 10
PYTHONPATH=build/release/python /usr/bin/python3 examples/python/embed_world.py
