#pragma once
// The memory this process holds, as Linux reports it in /proc/self/status, for the benchmarks'
// logs: the resident set now and at its peak.

namespace voxcut::app {

/// Resident memory of the process (MiB): VmRSS (now) and VmHWM (the peak since the start or
/// since resetPeakMemory). Zero where /proc/self/status cannot be read (not Linux).
struct ProcessMemory {
  double residentMiB = 0.0;
  double peakMiB = 0.0;
};

/// Reads /proc/self/status. Thread-safe.
[[nodiscard]] ProcessMemory processMemory();

/// Gives freed heap memory back to the system (malloc_trim) and starts the peak afresh from the
/// resident set now (writes 5 to /proc/self/clear_refs). Returns false where the peak could not
/// be reset (then VmHWM keeps counting from the process's start).
bool resetPeakMemory();

}  // namespace voxcut::app
