#include "ProcessMemory.h"

#include <malloc.h>

#include <fstream>
#include <sstream>
#include <string>

namespace voxcut::app {

ProcessMemory processMemory() {
  ProcessMemory m;
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line)) {
    // "VmRSS:     12345 kB"
    const auto value = [&line] {
      std::istringstream s(line.substr(line.find(':') + 1));
      double kib = 0.0;
      s >> kib;
      return kib / 1024.0;
    };
    if (line.rfind("VmRSS:", 0) == 0) m.residentMiB = value();
    if (line.rfind("VmHWM:", 0) == 0) m.peakMiB = value();
  }
  return m;
}

bool resetPeakMemory() {
  malloc_trim(0);
  std::ofstream out("/proc/self/clear_refs");
  out << "5";
  out.flush();
  return static_cast<bool>(out);
}

}  // namespace voxcut::app
