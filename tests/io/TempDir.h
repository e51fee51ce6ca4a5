#pragma once
/// @file TempDir.h
/// A fresh directory per test, removed with its contents when the test ends.

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

namespace voxcut::test {

/// A directory under the system temporary directory named after the running test and the
/// process (tests may run in parallel processes). Removed recursively on destruction.
class TempDir {
 public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string name = std::string("voxcut_io_") + info->test_suite_name() + "_" + info->name() +
                       "_" + std::to_string(::getpid());
    for (char& c : name)
      if (c == '/') c = '_';
    path_ = std::filesystem::temp_directory_path() / name;
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  /// The directory.
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }
  /// The path of `file` inside the directory, as a string.
  [[nodiscard]] std::string file(std::string_view file) const { return (path_ / file).string(); }
  /// Writes `bytes` to `file` inside the directory and returns its path.
  std::string write(std::string_view file, std::string_view bytes) const {
    const std::string p = this->file(file);
    std::ofstream out(p, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    return p;
  }

 private:
  std::filesystem::path path_;
};

}  // namespace voxcut::test
