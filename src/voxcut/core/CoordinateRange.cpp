#include "voxcut/core/CoordinateRange.h"

#include <charconv>

#include "voxcut/core/Error.h"

namespace voxcut {

void requireCoordinate(double x, const std::string& context) {
  if (isCoordinate(x)) return;
  char buf[32];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, x);
  const std::string shown = ec == std::errc() ? std::string(buf, end) : std::string("?");
  throw InputError(context + ": must be in " + kCoordinateRangeText + ", got " + shown);
}

}  // namespace voxcut
