#include "Interrupt.h"

#include <atomic>
#include <csignal>

namespace voxcut::app {
namespace {

// Set by the handler, read by the main thread: the signal may land on any thread (a worker
// of the thread pool), so the flag is a lock-free atomic rather than a plain sig_atomic_t,
// which is only safe within one thread. Lock-free atomics may be used in a handler.
std::atomic<bool> stopRequested{false};
static_assert(std::atomic<bool>::is_always_lock_free);
struct sigaction previousInt, previousTerm;

extern "C" void onSignal(int) {
  stopRequested.store(true, std::memory_order_relaxed);
}

}  // namespace

InterruptGuard::InterruptGuard() {
  stopRequested.store(false, std::memory_order_relaxed);
  struct sigaction sa {};
  sa.sa_handler = onSignal;
  sigemptyset(&sa.sa_mask);
  // Back to the default action after the first signal: a second Ctrl-C ends the program at
  // once, for a user who will not wait for the frame to finish. System calls the signal
  // interrupts are restarted, so that a write under way does not fail with EINTR.
  sa.sa_flags = SA_RESETHAND | SA_RESTART;
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

}  // namespace voxcut::app
