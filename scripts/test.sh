#!/usr/bin/env bash
# Sets up, configures, builds and runs every test. PRESET=asan (or tsan, debug) picks another
# build; the default is the optimised release build.
set -euo pipefail
cd "$(dirname "$0")/.."
preset="${PRESET:-release}"
bash scripts/setup.sh
cmake --preset "$preset" >/dev/null
cmake --build --preset "$preset"
ctest --preset "$preset"
