#!/usr/bin/env bash
# Builds the fuzz preset (clang, libFuzzer, AddressSanitizer + UndefinedBehaviorSanitizer) and
# runs every harness of tests/fuzz for SECONDS each (default 30), one after the other, on a
# scratch copy of its seed corpus (tests/fuzz/corpus/<harness>; the repository is not written).
# Exits 1 when any harness reports a crash, a sanitizer error, a leak, a timeout or running out
# of memory, after printing the reproducer's path (kept under build/fuzz/artifacts/<harness>/).
#   bash scripts/fuzz.sh [SECONDS]          FUZZERS="fuzz_scene fuzz_run" picks harnesses.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-30}"
if ! [[ $seconds =~ ^[0-9]+$ ]] || ((seconds < 1)); then
  echo "usage: scripts/fuzz.sh [SECONDS >= 1]" >&2
  exit 2
fi
read -r -a fuzzers <<<"${FUZZERS:-fuzz_mesh_obj fuzz_mesh_stl fuzz_mesh_ply fuzz_mesh_off fuzz_scene fuzz_run fuzz_volume_nifti fuzz_volume_nrrd fuzz_volume_mha}"

# Longest input per harness (bytes): room for a few hundred triangles or a scene with several
# bodies and tools, while each run stays far below the 10 s timeout.
declare -A max_len=([fuzz_mesh_obj]=16384 [fuzz_mesh_stl]=16384 [fuzz_mesh_ply]=16384
                    [fuzz_mesh_off]=16384 [fuzz_scene]=16384 [fuzz_run]=4096
                    [fuzz_volume_nifti]=4096 [fuzz_volume_nrrd]=4096 [fuzz_volume_mha]=4096)
# The dictionary of each harness; the run harness reads scenes too.
declare -A dict=([fuzz_mesh_obj]=fuzz_mesh_obj [fuzz_mesh_stl]=fuzz_mesh_stl
                 [fuzz_mesh_ply]=fuzz_mesh_ply [fuzz_mesh_off]=fuzz_mesh_off
                 [fuzz_scene]=fuzz_scene [fuzz_run]=fuzz_scene
                 [fuzz_volume_nifti]=fuzz_volume_nifti [fuzz_volume_nrrd]=fuzz_volume_nrrd
                 [fuzz_volume_mha]=fuzz_volume_mha)

cmake --preset fuzz >/dev/null
cmake --build --preset fuzz

bin=build/fuzz/tests/fuzz
artifacts="$PWD/build/fuzz/artifacts"
work=$(mktemp -d "${TMPDIR:-/tmp}/voxcut-fuzz.XXXXXX")
trap 'rm -rf "$work"' EXIT

export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
failed=()
for h in "${fuzzers[@]}"; do
  if [[ ! -x $bin/$h || -z ${max_len[$h]:-} ]]; then
    echo "fuzz: no harness '$h'" >&2
    exit 2
  fi
  mkdir -p "$work/$h" "$artifacts/$h"
  cp tests/fuzz/corpus/"$h"/* "$work/$h"/
  log="$work/$h.log"
  echo "fuzz: $h for ${seconds} s"
  if "$bin/$h" "$work/$h" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
    -max_len="${max_len[$h]}" -dict="tests/fuzz/${dict[$h]}.dict" \
    -artifact_prefix="$artifacts/$h/" -print_final_stats=1 >"$log" 2>&1; then
    grep -E "^Done [0-9]+ runs" "$log" | sed "s/^/fuzz: $h: /" || true
  else
    failed+=("$h")
    tail -n 60 "$log" >&2
    reproducer=$(grep -oE "(Test unit|artifact) written to [^ ]+" "$log" | sed 's/.* to //' | tail -n 1)
    echo "fuzz: $h FAILED; reproducer: ${reproducer:-none written (see the log above)}" >&2
    echo "fuzz: replay it with: $bin/$h ${reproducer:-<input>}" >&2
  fi
done

if ((${#failed[@]} > 0)); then
  echo "fuzz: findings in ${failed[*]}" >&2
  exit 1
fi
echo "fuzz: ${#fuzzers[@]} harnesses ran ${seconds} s each without a finding"
