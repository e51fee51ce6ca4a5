#include "voxcut/core/Error.h"

#include <cstdio>
#include <cstdlib>

namespace voxcut {

void assertionFailed(const char* expr, const char* file, int line, const std::string& msg) {
  std::fprintf(stderr, "voxcut: internal error: %s (%s) at %s:%d\n", msg.c_str(), expr, file, line);
  std::abort();
}

}  // namespace voxcut
