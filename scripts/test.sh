#!/usr/bin/env bash
# Sets up, configures, builds and runs every test. PRESET=asan (or tsan, debug) picks another
# build; the default is the optimised release build, after whose tests every libFuzzer harness
# runs for FUZZ_SECONDS (default 20; 0 skips them) through scripts/fuzz.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
preset="${PRESET:-release}"
bash scripts/setup.sh
cmake --preset "$preset" >/dev/null
cmake --build --preset "$preset"
# The viewer's tests draw: without a display, they run under a virtual one (Xvfb).
if [[ -z ${DISPLAY:-} ]]; then
  xvfb-run -a -s "-screen 0 1280x1024x24" ctest --preset "$preset"
else
  ctest --preset "$preset"
fi
if [[ $preset == release && ${FUZZ_SECONDS:-20} != 0 ]]; then
  bash scripts/fuzz.sh "${FUZZ_SECONDS:-20}"
fi
