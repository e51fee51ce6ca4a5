#pragma once
/// @file Progress.h
/// Optional callback for long operations: it receives progress and may ask to stop
/// (docs/architecture.md, "Conventions"; after OpenVDB's NullInterrupter).

#include <functional>
#include <string_view>

#include "voxcut/core/Error.h"

namespace voxcut {

/// Called with a stage name and a fraction in [0,1]; returns false to interrupt the work.
/// May be called from any thread but never concurrently with itself.
using ProgressCallback = std::function<bool(std::string_view stage, double fraction)>;

/// Reports progress; throws Interrupted when the callback asks to stop.
inline void reportProgress(const ProgressCallback& cb, std::string_view stage, double fraction) {
  if (cb && !cb(stage, fraction)) throw Interrupted();
}

}  // namespace voxcut
