#include "voxcut/io/VolumeData.h"

#include <zlib.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>

#include "voxcut/core/Error.h"
#include "voxcut/io/VolumeReader.h"

namespace voxcut::volumeio {

std::string escaped(std::string_view bytes, std::size_t maxChars) {
  std::string out;
  for (const char ch : bytes) {
    if (out.size() >= maxChars) {
      out += "...";
      break;
    }
    const auto c = static_cast<unsigned char>(ch);
    if (c == '\\') {
      out += "\\\\";
    } else if (c >= 0x20 && c < 0x7f) {
      out += static_cast<char>(c);
    } else {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02X", c);
      out += buf;
    }
  }
  return out;
}

std::string lowerCase(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

std::string_view trimmed(std::string_view s) {
  const auto blank = [](char c) { return c == ' ' || c == '\t'; };
  while (!s.empty() && blank(s.front())) s.remove_prefix(1);
  while (!s.empty() && blank(s.back())) s.remove_suffix(1);
  return s;
}

std::ifstream openRegularFile(const std::string& path, const std::string& what,
                              std::uint64_t& size) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (ec || !fs::exists(st)) throw InputError(what + ": no such file");
  if (fs::is_directory(st)) throw InputError(what + ": is a directory, not a file");
  if (!fs::is_regular_file(st)) throw InputError(what + ": not a regular file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(what + ": cannot be opened for reading");
  in.seekg(0, std::ios::end);
  const std::streamoff end = in.tellg();
  if (end < 0) throw InputError(what + ": cannot be read");
  in.seekg(0, std::ios::beg);
  size = static_cast<std::uint64_t>(end);
  return in;
}

std::string readWholeFile(const std::string& path, const std::string& what,
                          std::size_t maxBytes) {
  std::uint64_t size = 0;
  std::ifstream in = openRegularFile(path, what, size);
  if (maxBytes != 0 && size > maxBytes)
    throw InputError(what + ": file of " + std::to_string(size) + " bytes is larger than the " +
                     std::to_string(maxBytes) + " bytes allowed");
  std::string data(static_cast<std::size_t>(size), '\0');
  if (size > 0 && !in.read(data.data(), static_cast<std::streamsize>(size)))
    throw InputError(what + ": read error");
  return data;
}

std::string inflateExactly(std::string_view compressed, std::size_t expectedBytes,
                           const std::string& what) {
  z_stream zs{};
  // 15 + 32: zlib or gzip, detected from the header.
  if (inflateInit2(&zs, 15 + 32) != Z_OK) throw InputError(what + ": zlib could not start");
  std::string out;
  // Grow with what the stream produces, so that a header that lies costs nothing.
  out.resize(std::min<std::size_t>(expectedBytes, std::max<std::size_t>(compressed.size() * 4,
                                                                        std::size_t{1} << 16)));
  std::size_t produced = 0;
  std::size_t consumed = 0;
  int rc = Z_OK;
  constexpr std::size_t kChunk = std::size_t{1} << 30;  // zlib counts in 32-bit unsigned
  while (true) {
    if (produced == out.size()) {
      if (out.size() >= expectedBytes) {
        // All expected bytes are in: the stream must end here.
        char extra;
        zs.next_out = reinterpret_cast<Bytef*>(&extra);
        zs.avail_out = 1;
        const std::size_t in = std::min(compressed.size() - consumed, kChunk);
        zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(compressed.data() + consumed));
        zs.avail_in = static_cast<uInt>(in);
        rc = inflate(&zs, Z_NO_FLUSH);
        const bool more = zs.avail_out == 0;
        inflateEnd(&zs);
        if (more)
          throw InputError(what + ": compressed data hold more than the " +
                           std::to_string(expectedBytes) + " bytes the header declares");
        if (rc != Z_STREAM_END && rc != Z_OK && rc != Z_BUF_ERROR)
          throw InputError(what + ": corrupt gzip data at compressed byte " +
                           std::to_string(consumed));
        return out;
      }
      out.resize(std::min(expectedBytes, out.size() * 2));
    }
    const std::size_t in = std::min(compressed.size() - consumed, kChunk);
    const std::size_t room = std::min(out.size() - produced, kChunk);
    zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(compressed.data() + consumed));
    zs.avail_in = static_cast<uInt>(in);
    zs.next_out = reinterpret_cast<Bytef*>(out.data() + produced);
    zs.avail_out = static_cast<uInt>(room);
    rc = inflate(&zs, Z_NO_FLUSH);
    consumed += in - zs.avail_in;
    produced += room - zs.avail_out;
    if (rc == Z_STREAM_END) {
      inflateEnd(&zs);
      if (produced != expectedBytes)
        throw InputError(what + ": compressed data hold " + std::to_string(produced) +
                         " bytes, the header declares " + std::to_string(expectedBytes));
      return out;
    }
    if (rc == Z_BUF_ERROR && consumed == compressed.size() && produced < out.size()) {
      inflateEnd(&zs);
      throw InputError(what + ": compressed data are truncated after " +
                       std::to_string(produced) + " of " + std::to_string(expectedBytes) +
                       " bytes");
    }
    if (rc != Z_OK && rc != Z_BUF_ERROR) {
      inflateEnd(&zs);
      throw InputError(what + ": corrupt gzip data at compressed byte " +
                       std::to_string(consumed) + (zs.msg ? std::string(" (") + zs.msg + ")" : ""));
    }
  }
}

std::size_t checkVolumeSize(const std::string& what, long long nx, long long ny, long long nz,
                            long long layers, std::size_t sampleBytes, std::size_t maxMemory) {
  const long long dims[4] = {nx, ny, nz, layers};
  for (long long d : dims)
    if (d <= 0)
      throw InputError(what + ": dimensions " + std::to_string(nx) + " x " + std::to_string(ny) +
                       " x " + std::to_string(nz) + " must be positive");
  constexpr long long kMaxVoxels = 1LL << 31;
  long long total = 1;
  for (long long d : dims) {
    if (d > kMaxVoxels || total > kMaxVoxels / d)
      throw InputError(what + ": dimensions " + std::to_string(nx) + " x " + std::to_string(ny) +
                       " x " + std::to_string(nz) +
                       (layers > 1 ? " x " + std::to_string(layers) : std::string()) +
                       " exceed 2^31 voxels");
    total *= d;
  }
  const std::size_t voxels = static_cast<std::size_t>(total);
  const std::size_t bytes = volumeMemoryBytes(voxels, sampleBytes);
  if (maxMemory != 0 && bytes > maxMemory)
    throw InputError(what + ": reading " + std::to_string(voxels) + " voxels needs about " +
                     std::to_string(bytes >> 20) + " MiB, over the limit of " +
                     std::to_string(maxMemory >> 20) + " MiB (--max-memory)");
  return voxels;
}

std::optional<std::string_view> nextHeaderLine(std::string_view text, std::size_t& pos) {
  if (pos >= text.size()) return std::nullopt;
  const std::size_t start = pos;
  const std::size_t end = text.find('\n', start);
  std::string_view line;
  if (end == std::string_view::npos) {
    line = text.substr(start);
    pos = text.size();
  } else {
    line = text.substr(start, end - start);
    pos = end + 1;
  }
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  return line;
}

std::string resolveDataFile(const std::string& folder, std::string_view name,
                            const std::string& what) {
  namespace fs = std::filesystem;
  const std::string quoted = "data file '" + escaped(name) + "'";
  if (name.empty()) throw InputError(what + ": the data file name is empty");
  if (name.find('\0') != std::string_view::npos)
    throw InputError(what + ": " + quoted + " holds a NUL byte");
  std::error_code ec;
  const fs::path folderPath = folder.empty() ? fs::path(".") : fs::path(folder);
  // Both paths absolute, with "..", "." and symbolic links resolved as far as they exist, so
  // that neither "../x" nor a link can reach outside the folder.
  const fs::path base = fs::weakly_canonical(fs::absolute(folderPath, ec), ec);
  if (ec) throw InputError(what + ": the folder of the header cannot be resolved");
  const fs::path given{std::string(name)};
  const fs::path candidate = given.is_absolute() ? given : folderPath / given;
  const fs::path resolved = fs::weakly_canonical(fs::absolute(candidate, ec), ec);
  if (ec) throw InputError(what + ": " + quoted + " cannot be resolved");
  const auto [b, r] = std::mismatch(base.begin(), base.end(), resolved.begin(), resolved.end());
  if (b != base.end() || r == resolved.end())
    throw InputError(what + ": " + quoted +
                     " lies outside the folder of the header (data files must be inside it)");
  if (!fs::exists(resolved, ec) || ec) throw InputError(what + ": " + quoted + " does not exist");
  return resolved.string();
}

std::size_t regularFileSize(const std::string& path, const std::string& what) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (ec || !fs::exists(st)) throw InputError(what + ": no such file");
  if (!fs::is_regular_file(st)) throw InputError(what + ": not a regular file");
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec) throw InputError(what + ": cannot be read");
  return static_cast<std::size_t>(size);
}

std::string readFileRange(const std::string& path, const std::string& what, std::size_t offset,
                          std::size_t count) {
  const std::size_t size = regularFileSize(path, what);
  if (offset > size || count > size - offset)
    throw InputError(what + ": holds " + std::to_string(size) + " bytes, fewer than the " +
                     std::to_string(offset) + " + " + std::to_string(count) + " needed");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(what + ": cannot be opened for reading");
  std::string data(count, '\0');
  in.seekg(static_cast<std::streamoff>(offset), std::ios::beg);
  if (count > 0 && !in.read(data.data(), static_cast<std::streamsize>(count)))
    throw InputError(what + ": read error");
  return data;
}

}  // namespace voxcut::volumeio

namespace voxcut {

std::size_t volumeMemoryBytes(std::size_t voxels, std::size_t sampleBytes) {
  return voxels * (sampleBytes + sizeof(std::uint16_t));
}

}  // namespace voxcut
