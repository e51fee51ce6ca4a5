#include "Interrupt.h"

#include <unistd.h>

#include <atomic>
#include <csignal>
#include <cstring>

namespace voxcut::app {
namespace {

// Set by the handler, read by the main thread: the signal may land on any thread (a worker
// of the thread pool), so the flag is a lock-free atomic rather than a plain sig_atomic_t,
// which is only safe within one thread. Lock-free atomics may be used in a handler.
std::atomic<bool> stopRequested{false};
std::atomic<int> signalsCaught{0};
static_assert(std::atomic<bool>::is_always_lock_free);
static_assert(std::atomic<int>::is_always_lock_free);
struct sigaction previousInt, previousTerm;

/// The signal that ends the program at once.
constexpr int kForcingSignal = 3;

/// Temporary files to remove on a forced end. The handler may not allocate or lock, so the
/// paths live in fixed storage, each slot's state saying whether its path may be read.
constexpr int kSlots = 64;
constexpr std::size_t kPathBytes = 4096;
enum SlotState : int { kFree, kWriting, kReady };
struct TemporarySlot {
  std::atomic<int> state{kFree};
  char path[kPathBytes];
};
TemporarySlot temporaries[kSlots];

void say(const char* text) {
  // write(2) is async-signal-safe; what it returns does not matter here.
  [[maybe_unused]] const ssize_t n = ::write(STDERR_FILENO, text, std::strlen(text));
}

extern "C" void onSignal(int sig) {
  stopRequested.store(true, std::memory_order_relaxed);
  const int caught = signalsCaught.fetch_add(1, std::memory_order_relaxed) + 1;
  if (caught < kForcingSignal) {
    if (caught == kForcingSignal - 1)
      say("voxcut: stopping at the next safe point; signal once more to end at once\n");
    return;
  }
  // A slot freed and taken again while this runs could give a torn path; unlinking a
  // nonexistent file is harmless, and the writer's own clean-up is gone with the process.
  for (TemporarySlot& t : temporaries)
    if (t.state.load(std::memory_order_acquire) == kReady) ::unlink(t.path);
  struct sigaction dfl {};
  dfl.sa_handler = SIG_DFL;
  sigemptyset(&dfl.sa_mask);
  sigaction(sig, &dfl, nullptr);
  // Blocked while the handler runs: delivered, with its default action, when it returns.
  raise(sig);
}

}  // namespace

InterruptGuard::InterruptGuard() {
  stopRequested.store(false, std::memory_order_relaxed);
  signalsCaught.store(0, std::memory_order_relaxed);
  struct sigaction sa {};
  sa.sa_handler = onSignal;
  sigemptyset(&sa.sa_mask);
  sigaddset(&sa.sa_mask, SIGINT);
  sigaddset(&sa.sa_mask, SIGTERM);
  // System calls the signal interrupts are restarted, so that a write under way does not
  // fail with EINTR.
  sa.sa_flags = SA_RESTART;
  sigaction(SIGINT, &sa, &previousInt);
  sigaction(SIGTERM, &sa, &previousTerm);
}

InterruptGuard::~InterruptGuard() {
  sigaction(SIGINT, &previousInt, nullptr);
  sigaction(SIGTERM, &previousTerm, nullptr);
}

bool interruptRequested() {
  return stopRequested.load(std::memory_order_relaxed);
}

TemporaryFileGuard::TemporaryFileGuard(const std::string& path) {
  if (path.empty() || path.size() >= kPathBytes) return;
  for (int i = 0; i < kSlots; ++i) {
    int expected = kFree;
    if (!temporaries[i].state.compare_exchange_strong(expected, kWriting,
                                                      std::memory_order_acquire))
      continue;
    std::memcpy(temporaries[i].path, path.c_str(), path.size() + 1);
    temporaries[i].state.store(kReady, std::memory_order_release);
    slot_ = i;
    return;
  }
}

TemporaryFileGuard::~TemporaryFileGuard() {
  if (slot_ >= 0) temporaries[slot_].state.store(kFree, std::memory_order_release);
}

}  // namespace voxcut::app
