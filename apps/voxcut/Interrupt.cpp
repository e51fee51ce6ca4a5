#include "Interrupt.h"

#include <csignal>

namespace voxcut::app {
namespace {

volatile std::sig_atomic_t stopRequested = 0;
struct sigaction previousInt, previousTerm;

extern "C" void onSignal(int) {
  stopRequested = 1;
}

}  // namespace

InterruptGuard::InterruptGuard() {
  stopRequested = 0;
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
  return stopRequested != 0;
}

}  // namespace voxcut::app
