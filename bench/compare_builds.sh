#!/usr/bin/env bash
# Frame time of two builds of the command line on the same scenes, alternating A and B so
# that the machine's load falls on both alike (docs/performance.md, "Position-independent
# code" uses it for -fPIC). Prints per run the mean and p95 frame time of each and the ratio
# B/A, then the range of the ratios.
#
# Usage: bench/compare_builds.sh VOXCUT_A VOXCUT_B [RUNS=3] [FRAMES=150] [SCENE...]
#   default scenes: scenes/bunny-ear.json scenes/liver-probe-cut.json
set -euo pipefail
a=${1:?usage: compare_builds.sh VOXCUT_A VOXCUT_B [RUNS] [FRAMES] [SCENE...]}
b=${2:?usage: compare_builds.sh VOXCUT_A VOXCUT_B [RUNS] [FRAMES] [SCENE...]}
runs=${3:-3}
frames=${4:-150}
shift $(( $# < 4 ? $# : 4 ))
here=$(cd "$(dirname "$0")/.." && pwd)
scenes=("$@")
((${#scenes[@]})) || scenes=("$here/scenes/bunny-ear.json" "$here/scenes/liver-probe-cut.json")
frame_ms() {  # BIN SCENE -> "mean p95"
  "$1" run "$2" --frames "$frames" --threads 2 --json |
    /usr/bin/python3 -c 'import json,sys; d=json.load(sys.stdin)["frame_ms"]; print(d["mean"], d["p95"])'
}
for scene in "${scenes[@]}"; do
  ratios=()
  for ((r = 1; r <= runs; ++r)); do
    read -r am ap < <(frame_ms "$a" "$scene")
    read -r bm bp < <(frame_ms "$b" "$scene")
    ratio=$(/usr/bin/python3 -c "print(f'{$bm / $am:.3f}')")
    ratios+=("$ratio")
    printf '%s run %d: A mean %.2f p95 %.2f ms, B mean %.2f p95 %.2f ms, B/A %s\n' \
      "$(basename "$scene")" "$r" "$am" "$ap" "$bm" "$bp" "$ratio"
  done
  printf '%s: B/A over %d runs: %s\n' "$(basename "$scene")" "$runs" \
    "$(printf '%s\n' "${ratios[@]}" | sort -n | sed -n '1p;$p' | paste -sd- -)"
done
