#!/usr/bin/env bash
# How voxcut scales with threads (docs/performance.md, "Thread scaling"): at each thread count,
# the single-frame cutting test's collision total (voxcut bench single-frame), one implicit step
# of the bunny at about 10k and 3k nodes (bench_fem BunnyThreads) and the frame time of four
# shipped scenes (voxcut run --json). Prints the medians over the repeats with their min-max,
# and the speed-ups over 1 thread; scripts/thread_scaling.py makes the tables.
#
# Needs only the build folder's two programs (and their shared libraries, scripts/setup.sh's
# packages), this checkout's scenes/ and data/, bash, coreutils, awk and /usr/bin/python3
# (standard library only).
set -euo pipefail
cd "$(dirname "$0")/.."

usage() {
  cat <<'EOF'
Usage: scripts/thread_scaling.sh [--threads "1 2 4 8 16"] [--repeats 3] [--build build/release]
                                 [--quick] [--out FILE.md]

Measures, at each thread count, and prints one table of medians over the repeats (min-max in
brackets, all in ms) and one of the speed-ups over 1 thread (over the smallest thread count
when 1 is not in the list):
  - single-frame collision: the collision total (position update + intersection test + octree
    subdivision) of `voxcut bench single-frame --threads N --repeat 10` (itself a median of 10
    cuts), for the bunny, the liver and the starfish, with the voxel octree and without it;
  - deformation step: one implicit step of the bunny at resolution 301 (about 10.3k nodes) and
    173 (3.1k), multigrid, start projected onto 8 solutions (`bench_fem
    --benchmark_filter=BunnyThreads/...`; registered for 1, 2, 4, 8 and 16 threads only:
    other counts show '-');
  - scenes: frame mean and p95 of `voxcut run scenes/NAME.json --threads N --json` for
    liver-probe-cut, starfish-stack, bunny-ear and ct-liver-resection.
Each repeat runs the single-frame test and the scenes at every thread count, the thread order
rotated from one repeat to the next, then bench_fem once for all thread counts (building its
bodies costs more than the steps). A thread count above the machine's cores still runs, and
its column is marked "(oversubscribed: N cores)"; oneTBB then runs no more threads than
cores, so such a column measures the cores, not the threads asked for. Below the tables:
whether the single-frame cut links and the scenes' cut sets agree between thread counts (they
must), and the deformation step's solver iterations per step (means over the timed steps,
whose number varies, so they may differ a little). Progress goes to stderr, the header and
tables (Markdown) to stdout.

Options:
  --threads "LIST"  thread counts, space-separated (default "1 2 4 8 16")
  --repeats R       runs of every measurement; the median is reported (default 3)
  --build DIR       build folder holding apps/voxcut/voxcut and bench/bench_fem
                    (default build/release)
  --quick           smoke test: 1 repeat, single-frame --repeat 3, scenes cut to 60 frames,
                    bench_fem at resolution 173 only (--repeats, if given, still applies)
  --out FILE        also write the header and the tables to FILE
  -h, --help        this help

Takes about 35 s per thread count and repeat on a loaded 2-core machine (--quick: about 10 s
per thread count). Run it on an otherwise idle machine: other work on the cores shows up as
poor scaling.
EOF
}

die() {  # STATUS MESSAGE
  echo "thread_scaling.sh: $2" >&2
  exit "$1"
}

threads="1 2 4 8 16"
repeats=3
build=build/release
quick=0
out=""
repeats_given=""
while (($#)); do
  case $1 in
    --threads) (($# >= 2)) || die 2 "--threads needs a list"; threads=$2; shift 2 ;;
    --repeats) (($# >= 2)) || die 2 "--repeats needs a number"; repeats_given=$2; shift 2 ;;
    --build) (($# >= 2)) || die 2 "--build needs a folder"; build=${2%/}; shift 2 ;;
    --quick) quick=1; shift ;;
    --out) (($# >= 2)) || die 2 "--out needs a file"; out=$2; shift 2 ;;
    -h | --help) usage; exit 0 ;;
    *) die 2 "unknown argument '$1' (see --help)" ;;
  esac
done

single_frame_repeat=10
frames_arg=()
resolutions="301|173"
if ((quick)); then
  repeats=1
  single_frame_repeat=3
  frames_arg=(--frames 60)
  resolutions="173"
fi
[[ -n $repeats_given ]] && repeats=$repeats_given
[[ $repeats =~ ^[1-9][0-9]*$ ]] || die 2 "--repeats must be a positive integer, not '$repeats'"
read -r -a thread_list <<<"$threads"
((${#thread_list[@]})) || die 2 "--threads needs at least one thread count"
for t in "${thread_list[@]}"; do
  [[ $t =~ ^[1-9][0-9]*$ ]] || die 2 "--threads takes positive integers, not '$t'"
done

voxcut=$build/apps/voxcut/voxcut
bench_fem=$build/bench/bench_fem
if [[ $build == build/release ]]; then
  build_command="cmake --preset release && cmake --build --preset release --target voxcut bench_fem"
else
  build_command="cmake --build $build --target voxcut bench_fem"
fi
for bin in "$voxcut" "$bench_fem"; do
  [[ -x $bin ]] || die 2 "missing $bin; build it with: $build_command"
done
# A program whose shared libraries are missing fails here with the loader's message.
if ! err=$("$voxcut" --version 2>&1 >/dev/null); then
  die 2 "cannot start $voxcut: ${err%%$'\n'*} (libraries: bash scripts/setup.sh)"
fi
if ! listed=$("$bench_fem" --benchmark_list_tests --benchmark_filter='^BunnyThreads/' 2>&1); then
  die 2 "cannot start $bench_fem: ${listed%%$'\n'*} (libraries: bash scripts/setup.sh)"
fi
[[ $listed == *BunnyThreads/* ]] ||
  die 2 "$bench_fem has no BunnyThreads benchmark (older build); rebuild it with: $build_command"
[[ -x /usr/bin/python3 ]] ||
  die 2 "missing /usr/bin/python3 (scripts/thread_scaling.py makes the tables)"
scenes=(liver-probe-cut starfish-stack bunny-ear ct-liver-resection)
for s in "${scenes[@]}"; do
  [[ -f scenes/$s.json ]] || die 2 "missing scenes/$s.json (run from a full checkout)"
done

raw=$(mktemp -d "${TMPDIR:-/tmp}/thread_scaling.XXXXXX")
trap 'rm -rf "$raw"' EXIT

cores=$(nproc)
cpu=$(awk -F': *' '/^model name/ { print $2; exit }' /proc/cpuinfo 2>/dev/null || true)
commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
if [[ $commit != unknown && -n $(git status --porcelain --untracked-files=no 2>/dev/null) ]]; then
  commit="$commit (with uncommitted changes)"
fi
started=$(date -u '+%Y-%m-%d %H:%M UTC')
load=$(cut -d' ' -f1-3 /proc/loadavg 2>/dev/null || echo unknown)

# Runs a command, its stdout to FILE; on failure shows the end of its stderr and stops.
run() {  # FILE COMMAND...
  local file=$1
  shift
  if ! "$@" >"$file" 2>"$raw/stderr"; then
    echo "thread_scaling.sh: failed: $*" >&2
    tail -n 20 "$raw/stderr" >&2
    exit 1
  fi
}

fem_threads=$(printf '%s|' "${thread_list[@]}")
fem_filter="^BunnyThreads/($resolutions)/(${fem_threads%|})/"
n=${#thread_list[@]}
for ((r = 1; r <= repeats; ++r)); do
  for ((i = 0; i < n; ++i)); do
    t=${thread_list[(i + r - 1) % n]}
    echo "repeat $r/$repeats, threads $t: single-frame" >&2
    run "$raw/stdout" "$voxcut" bench single-frame --threads "$t" --repeat "$single_frame_repeat" \
      --csv "$raw/single-frame.$t.$r.csv"
    for s in "${scenes[@]}"; do
      echo "repeat $r/$repeats, threads $t: $s" >&2
      run "$raw/scene.$s.$t.$r.json" "$voxcut" run "scenes/$s.json" --threads "$t" --json \
        "${frames_arg[@]}"
    done
  done
  # One process for every thread count: building the bodies costs more than the steps.
  if grep -qE "$fem_filter" <<<"$listed"; then
    echo "repeat $r/$repeats: bench_fem $fem_filter" >&2
    run "$raw/fem.$r.json" "$bench_fem" "--benchmark_filter=$fem_filter" --benchmark_format=json
  else
    echo "repeat $r/$repeats: bench_fem skipped (BunnyThreads has none of these thread counts)" >&2
  fi
done

command="scripts/thread_scaling.sh --threads \"$threads\" --repeats $repeats"
((quick)) && command+=" --quick"
[[ $build != build/release ]] && command+=" --build $build"
args=(--raw "$raw" --threads "$threads" --repeats "$repeats" --cores "$cores"
  --machine "$cores cores, ${cpu:-CPU model unknown}, load average at the start $load"
  --commit "$commit" --started "$started" --command "$command"
  --single-frame-repeat "$single_frame_repeat" --scenes "${scenes[*]}")
((quick)) && args+=(--frames 60)
[[ -n $out ]] && args+=(--out "$out")
/usr/bin/python3 scripts/thread_scaling.py "${args[@]}"
