#pragma once
/// @file Error.h
/// The three kinds of failure (docs/architecture.md, "Conventions"): programming errors trip
/// VOXCUT_ASSERT, bad input throws voxcut::InputError, solvers return a status.

#include <stdexcept>
#include <string>

namespace voxcut {

/// Bad input or I/O: a missing file, a broken mesh, an absurd parameter. The message is one
/// line meant for the user; the command line prints it and exits with a non-zero status.
class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& what) : std::runtime_error(what) {}
};

/// Thrown by a long operation when its interrupter asked it to stop.
class Interrupted : public std::runtime_error {
 public:
  Interrupted() : std::runtime_error("interrupted") {}
};

[[noreturn]] void assertionFailed(const char* expr, const char* file, int line,
                                  const std::string& msg);

}  // namespace voxcut

/// Checked assertion for programming errors; active in every build type.
#define VOXCUT_ASSERT(expr, msg)                                              \
  do {                                                                        \
    if (!(expr)) ::voxcut::assertionFailed(#expr, __FILE__, __LINE__, (msg)); \
  } while (0)
