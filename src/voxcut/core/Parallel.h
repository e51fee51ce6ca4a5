#pragma once
/// @file Parallel.h
/// The one parallel wrapper over oneTBB (docs/architecture.md, "Conventions"). Every parallel
/// loop in voxcut goes through parallelFor; results must never depend on the thread count, so
/// bodies write into fixed slots or their outputs are sorted afterwards.

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <cstddef>
#include <algorithm>
#include <memory>
#include <vector>

#if defined(__SANITIZE_THREAD__)
#include <sanitizer/tsan_interface.h>
#define VOXCUT_TSAN 1
#endif

namespace voxcut {

/// Runs body(begin, end) over sub-ranges of [begin, end). With `threaded` false, or a range
/// no larger than `grain`, it runs serially on the calling thread.
template <class Body>
void parallelFor(std::size_t begin, std::size_t end, std::size_t grain, Body&& body,
                 bool threaded = true) {
  if (end <= begin) return;
  if (!threaded || end - begin <= grain) {
    body(begin, end);
    return;
  }
#ifdef VOXCUT_TSAN
  // Debian's oneTBB is not instrumented, so ThreadSanitizer cannot see that parallel_for
  // orders the caller's writes before every task and every task before the return. Tell it,
  // with one object per direction so that tasks are not ordered among themselves (races
  // between tasks are still reported).
  char start = 0, finish = 0;
  __tsan_release(&start);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(begin, end, grain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      __tsan_acquire(&start);
                      body(r.begin(), r.end());
                      __tsan_release(&finish);
                    });
  __tsan_acquire(&finish);
#else
  tbb::parallel_for(tbb::blocked_range<std::size_t>(begin, end, grain),
                    [&](const tbb::blocked_range<std::size_t>& r) { body(r.begin(), r.end()); });
#endif
}

/// Runs f() and g() side by side (each may run parallelFor loops of its own, which share the
/// threads), and returns when both have; with `threaded` false, f() then g() on the calling
/// thread. The two must not touch the same data unless both only read it.
template <class F, class G>
void parallelInvoke(F&& f, G&& g, bool threaded = true) {
  if (!threaded) {
    f();
    g();
    return;
  }
#ifdef VOXCUT_TSAN
  // As in parallelFor: the start happens before both, both happen before the return.
  char start = 0, finish = 0;
  __tsan_release(&start);
  tbb::parallel_invoke(
      [&] {
        __tsan_acquire(&start);
        f();
        __tsan_release(&finish);
      },
      [&] {
        __tsan_acquire(&start);
        g();
        __tsan_release(&finish);
      });
  __tsan_acquire(&finish);
#else
  tbb::parallel_invoke([&] { f(); }, [&] { g(); });
#endif
}

/// Slots for per-thread scratch: threadSlot() of any thread running a parallelFor body (or its
/// caller) is below threadSlots(). Two bodies running at once never share a slot; results must
/// not depend on which slot a body gets.
[[nodiscard]] int threadSlots();
[[nodiscard]] int threadSlot();

/// Tells the scheduler that parallel work follows shortly. A worker that finds no work for
/// some tens of microseconds goes to sleep, and waking it again takes as long or longer on a
/// virtual machine; the next parallelFor then runs its first part on the caller alone. Called
/// before a serial stretch that leads into parallel work, the wake-up overlaps that stretch.
/// The call itself may take tens of microseconds (the system call that wakes the worker,
/// which the next parallelFor would otherwise make). Does nothing when one thread is allowed.
void wakeWorkers();

/// Limits the worker threads for its lifetime (0 = leave the default). Not copyable.
class ThreadLimit {
 public:
  explicit ThreadLimit(int threads);
  ThreadLimit(const ThreadLimit&) = delete;
  ThreadLimit& operator=(const ThreadLimit&) = delete;
  /// Threads the scheduler may use now.
  [[nodiscard]] static int current();

 private:
  std::unique_ptr<tbb::global_control> control_;
};

/// Outputs of parallel work over fixed chunks, one list per chunk, joined in chunk order: the
/// joined list is the same for any thread count (each chunk's own items are in its order).
template <class T>
class ChunkedList {
 public:
  explicit ChunkedList(std::size_t chunks) : parts_(chunks) {}
  [[nodiscard]] std::vector<T>& operator[](std::size_t chunk) { return parts_[chunk]; }
  /// Appends every chunk's items to `out`, chunk by chunk.
  void appendTo(std::vector<T>& out) const {
    for (const std::vector<T>& p : parts_) out.insert(out.end(), p.begin(), p.end());
  }

 private:
  std::vector<std::vector<T>> parts_;
};

/// The largest value raised over parallel work on fixed chunks, one slot per chunk: a maximum
/// is exact, so it is the same for any thread count.
class ChunkedMax {
 public:
  explicit ChunkedMax(std::size_t chunks, double floor = 0.0)
      : parts_(chunks, floor), floor_(floor) {}
  void raise(std::size_t chunk, double value) { parts_[chunk] = std::max(parts_[chunk], value); }
  [[nodiscard]] double value() const {
    double best = floor_;
    for (const double p : parts_) best = std::max(best, p);
    return best;
  }

 private:
  std::vector<double> parts_;
  double floor_;
};

}  // namespace voxcut
