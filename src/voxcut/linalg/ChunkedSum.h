#pragma once
/// @file ChunkedSum.h
/// Deterministic parallel sums over the rows of a vector (the dot products of the conjugate
/// gradients, ConjugateGradients.h): the rows are cut into fixed chunks, each chunk is summed in
/// row order into its own slot, and the slots are added in chunk order, so the result does not
/// depend on the thread count or on how the scheduler splits the range.
///
/// Thread-safety: `body` runs concurrently on different rows; `partial` is the caller's
/// scratch and must not be shared between concurrent sums.

#include <algorithm>
#include <cstddef>
#include <utility>
#include <vector>

#include "voxcut/core/Parallel.h"

namespace voxcut {

/// Rows per chunk of a sum.
inline constexpr std::size_t kSumChunk = 256;

/// sum_i body(i) over [0, rows), chunked as above; `partial` is resized to the chunk count.
/// body may also write row i's outputs (one pass over the rows for both).
template <class Body>
double chunkedSum(std::size_t rows, std::vector<double>& partial, bool threaded, Body&& body) {
  const std::size_t chunks = (rows + kSumChunk - 1) / kSumChunk;
  partial.resize(chunks);
  parallelFor(
      0, chunks, 1,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t c = b; c < e; ++c) {
          double s = 0.0;
          const std::size_t end = std::min(rows, (c + 1) * kSumChunk);
          for (std::size_t i = c * kSumChunk; i < end; ++i) s += body(i);
          partial[c] = s;
        }
      },
      threaded);
  double sum = 0.0;
  for (std::size_t c = 0; c < chunks; ++c) sum += partial[c];
  return sum;
}

/// Two sums at once: body(i) returns a pair, summed as chunkedSum sums each of its members.
template <class Body>
std::pair<double, double> chunkedSum2(std::size_t rows, std::vector<double>& partial,
                                      std::vector<double>& partial2, bool threaded, Body&& body) {
  const std::size_t chunks = (rows + kSumChunk - 1) / kSumChunk;
  partial.resize(chunks);
  partial2.resize(chunks);
  parallelFor(
      0, chunks, 1,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t c = b; c < e; ++c) {
          double s = 0.0, s2 = 0.0;
          const std::size_t end = std::min(rows, (c + 1) * kSumChunk);
          for (std::size_t i = c * kSumChunk; i < end; ++i) {
            const auto [x, y] = body(i);
            s += x;
            s2 += y;
          }
          partial[c] = s;
          partial2[c] = s2;
        }
      },
      threaded);
  double sum = 0.0, sum2 = 0.0;
  for (std::size_t c = 0; c < chunks; ++c) {
    sum += partial[c];
    sum2 += partial2[c];
  }
  return {sum, sum2};
}

/// `count` sums at once: body(i, out) adds row i's term of sum m to out[m] (m < count); each
/// sum is chunked as chunkedSum chunks one. `partial` is resized to chunks * count.
template <class Body>
std::vector<double> chunkedSums(std::size_t rows, std::size_t count, std::vector<double>& partial,
                                bool threaded, Body&& body) {
  const std::size_t chunks = (rows + kSumChunk - 1) / kSumChunk;
  partial.assign(chunks * count, 0.0);
  parallelFor(
      0, chunks, 1,
      [&](std::size_t b, std::size_t e) {
        for (std::size_t c = b; c < e; ++c) {
          const std::size_t end = std::min(rows, (c + 1) * kSumChunk);
          for (std::size_t i = c * kSumChunk; i < end; ++i) body(i, partial.data() + c * count);
        }
      },
      threaded);
  std::vector<double> sum(count, 0.0);
  for (std::size_t c = 0; c < chunks; ++c)
    for (std::size_t m = 0; m < count; ++m) sum[m] += partial[c * count + m];
  return sum;
}

}  // namespace voxcut
