"""What Python costs over C++ (docs/performance.md, "Python"):

- frames stepped from Python, one World.step() call each, against frames stepped by a loop
  in C++ (World._step_timed: World::step called from C++, no Python between frames), in
  alternating blocks of ten on the same world, so both see the same kind of frames; the
  ratio of their wall times, and the median time per frame outside World::step on each
  side (what Python adds, including what the machine does right after a frame);
- reading a body's surface as an owning copy (Body.surface) and as a zero-copy view
  (Body.surface_view with its arrays), against a frame.

Usage: PYTHONPATH=build/release/python /usr/bin/python3 bench/bench_python.py
       [--scene scenes/bunny-ear.json] [--frames 150] [--repeats 3]
Prints one table per repeat and the ranges over repeats.
"""

import argparse
import os
import statistics
import sys
import time

import voxcut


def one_run(scene, frames, block=10):
    world = voxcut.World.from_scene(scene)
    body = world.bodies()[0]
    cpp_wall = py_wall = 0.0
    cpp_extra, py_extra, inside = [], [], []
    for start in range(0, frames, 2 * block):
        t0 = time.perf_counter()
        timed = world._step_timed(block)
        cpp_wall += time.perf_counter() - t0
        for wall, total in timed:
            cpp_extra.append(wall - total)
            inside.append(total)
        for _ in range(block):
            t0 = time.perf_counter()
            report = world.step()
            dt = time.perf_counter() - t0
            py_wall += dt
            py_extra.append(dt * 1e3 - report.total_ms)
            inside.append(report.total_ms)
    # Surface reads, at the final (cut) state.
    copy_ms, view_ms = [], []
    for _ in range(20):
        t0 = time.perf_counter()
        s = body.surface()
        copy_ms.append((time.perf_counter() - t0) * 1e3)
        del s
        t0 = time.perf_counter()
        v = body.surface_view()
        arrays = (v.vertices, v.normals, v.triangles, v.materials, v.cut)
        view_ms.append((time.perf_counter() - t0) * 1e3)
        del v, arrays
    return {
        "frame_ms": statistics.mean(inside),
        "overhead_ratio": py_wall / cpp_wall,
        "cpp_extra_us": statistics.median(cpp_extra) * 1e3,
        "overhead_us": statistics.median(py_extra) * 1e3,
        "copy_ms": statistics.median(copy_ms),
        "view_ms": statistics.median(view_ms),
        "triangles": body.info.surface_triangles,
    }


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default=os.path.join(here, "..", "scenes", "bunny-ear.json"))
    parser.add_argument("--frames", type=int, default=150)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    runs = []
    for r in range(args.repeats):
        res = one_run(args.scene, args.frames)
        runs.append(res)
        print(f"run {r + 1}: frame {res['frame_ms']:.2f} ms; Python loop / C++ loop wall time "
              f"{res['overhead_ratio']:.4f}; outside World::step per frame: C++ "
              f"{res['cpp_extra_us']:.1f} us, Python {res['overhead_us']:.1f} us; surface of "
              f"{res['triangles']} triangles: copy {res['copy_ms']:.3f} ms "
              f"({res['copy_ms'] / res['frame_ms']:.3f} frames), view {res['view_ms']:.4f} ms "
              f"({res['view_ms'] / res['frame_ms']:.5f} frames)", flush=True)

    def rng(key, fmt):
        vals = [r[key] for r in runs]
        return f"{fmt.format(min(vals))}-{fmt.format(max(vals))}"

    print(f"ranges over {len(runs)} runs: step ratio {rng('overhead_ratio', '{:.4f}')}, "
          f"overhead {rng('overhead_us', '{:.1f}')} us/frame, copy {rng('copy_ms', '{:.3f}')} "
          f"ms, view {rng('view_ms', '{:.4f}')} ms")
    return 0


if __name__ == "__main__":
    sys.exit(main())
