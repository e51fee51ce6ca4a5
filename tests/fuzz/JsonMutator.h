#pragma once
/// @file JsonMutator.h
/// A structure-aware libFuzzer mutation for JSON inputs such as scenes: changes values, not
/// bytes, so that a valid scene mostly stays one (keys stay spelled right) while its numbers,
/// names, lists and nesting vary.

#include <cstddef>
#include <cstdint>

namespace voxcut::fuzz {

/// Mutates the JSON text `data[0, size)` in place and returns its new size (<= maxSize): one to
/// three value edits (a number replaced by an extreme one or scaled, a string replaced by a
/// model spec or keyword, a list element duplicated or removed, a key removed, a value replaced
/// by a copy of another) chosen from `seed`. Returns 0 when `data` is not JSON or the edited
/// text would not fit in maxSize, leaving `data` unchanged. Not thread-safe (libFuzzer calls it
/// from one thread).
[[nodiscard]] std::size_t mutateJsonValues(std::uint8_t* data, std::size_t size,
                                           std::size_t maxSize, unsigned int seed);

}  // namespace voxcut::fuzz
