#pragma once
/// @file VolumeData.h
/// What the volume readers share (internal to io/): bounded reading of files, gzip inflation
/// that stops at a byte limit, escaping of quoted bytes, and the memory check made from a
/// header.

#include <cstddef>
#include <cstdint>
#include <fstream>
#include <optional>
#include <string>
#include <string_view>

namespace voxcut::volumeio {

/// `bytes` quoted for a message: printable ASCII kept, everything else written as \xHH (and
/// backslash as \\), cut to `maxChars` characters with "..." after.
[[nodiscard]] std::string escaped(std::string_view bytes, std::size_t maxChars = 60);

/// `s` in lower case (ASCII).
[[nodiscard]] std::string lowerCase(std::string_view s);

/// `s` without leading and trailing spaces and tabs.
[[nodiscard]] std::string_view trimmed(std::string_view s);

/// The regular file at `path` opened for binary reading, and its size in bytes. Throws
/// InputError naming `what` for a missing file, a directory, something that is not a regular
/// file and a file that cannot be opened or measured.
[[nodiscard]] std::ifstream openRegularFile(const std::string& path, const std::string& what,
                                            std::uint64_t& size);

/// The whole file at `path`. Throws InputError naming `what` for a missing file, a directory
/// or something that is not a regular file, an unreadable file, and one larger than
/// `maxBytes` (0: no limit).
[[nodiscard]] std::string readWholeFile(const std::string& path, const std::string& what,
                                        std::size_t maxBytes = 0);

/// Inflates the gzip (or zlib) stream `compressed` and returns exactly `expectedBytes` bytes.
/// Memory grows with the bytes actually produced, never beyond expectedBytes; throws
/// InputError naming `what` for a stream that is corrupt, that ends (or is truncated) before
/// producing expectedBytes, or that holds more than expectedBytes.
[[nodiscard]] std::string inflateExactly(std::string_view compressed, std::size_t expectedBytes,
                                         const std::string& what);

/// Refuses (InputError naming `what`) a volume of dims nx x ny x nz (x layers) of
/// `sampleBytes`-byte samples when the voxel count overflows, exceeds 2^31 voxels, or its
/// volumeMemoryBytes exceed `maxMemory` (0: no limit). Returns the voxel count (layers
/// included).
std::size_t checkVolumeSize(const std::string& what, long long nx, long long ny, long long nz,
                            long long layers, std::size_t sampleBytes, std::size_t maxMemory);

/// The line of a text header that starts at `pos`, without its terminator ('\n' or "\r\n");
/// `pos` moves past the terminator (to text.size() when the text ends without one). nullopt
/// when `pos` is already at the end.
[[nodiscard]] std::optional<std::string_view> nextHeaderLine(std::string_view text,
                                                             std::size_t& pos);

/// The path of a header's detached data file `name` (a relative name taken in `folder`, the
/// header's folder, "" for the working directory; an absolute name as it is). Throws
/// InputError naming `what` and the escaped name when the path, with `..` and symbolic links
/// resolved, lies outside `folder`, and when no file is there.
[[nodiscard]] std::string resolveDataFile(const std::string& folder, std::string_view name,
                                          const std::string& what);

/// The size in bytes of the regular file at `path`; InputError naming `what` for a missing
/// file or something that is not a regular file.
[[nodiscard]] std::size_t regularFileSize(const std::string& path, const std::string& what);

/// `count` bytes of the file at `path` from byte `offset`; InputError naming `what` when the
/// file cannot be read or holds fewer bytes. Memory: `count` bytes.
[[nodiscard]] std::string readFileRange(const std::string& path, const std::string& what,
                                        std::size_t offset, std::size_t count);

}  // namespace voxcut::volumeio
