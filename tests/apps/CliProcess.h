#pragma once
// Runs the voxcut binary as a user would, for the command-line tests: in a given folder, with
// stdout and stderr captured (or stdout sent to a given file such as /dev/full), a time limit
// after which the child is killed, and a cap on its address space so that a runaway input
// cannot take the test machine's memory.

#include <sys/types.h>

#include <filesystem>
#include <string>
#include <vector>

namespace voxcut::cli {

namespace fs = std::filesystem;

/// A fresh folder under the temporary directory, removed with its contents on destruction.
class TempFolder {
 public:
  explicit TempFolder(const std::string& tag);
  ~TempFolder();
  TempFolder(const TempFolder&) = delete;
  TempFolder& operator=(const TempFolder&) = delete;

  [[nodiscard]] const fs::path& path() const { return path_; }
  [[nodiscard]] std::string file(const std::string& name) const { return (path_ / name).string(); }
  /// Writes `bytes` to `name` (relative to the folder) and returns its path.
  std::string write(const std::string& name, const std::string& bytes) const;
  /// Every entry below the folder (files and folders, recursively), relative, sorted.
  [[nodiscard]] std::vector<std::string> entries() const;

 private:
  fs::path path_;
};

/// What one run did.
struct ProcessResult {
  int status = -1;        ///< exit code, or 128 + signal when killed by a signal
  bool timedOut = false;  ///< killed after the time limit
  std::string out, err;   ///< captured stdout (empty when redirected elsewhere) and stderr
  double seconds = 0;
};

/// stdoutPath values: standard output closed, or a pipe whose reading end is closed.
inline const std::string kClosedStdout = "<closed>";
inline const std::string kBrokenPipe = "<broken pipe>";

/// An address-space cap under which voxcut runs every small input and a runaway allocation
/// fails at once: 2 GiB, or none in sanitizer builds, whose shadow memory alone reserves
/// terabytes of addresses.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
inline constexpr std::size_t kRunawayLimit = 0;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
inline constexpr std::size_t kRunawayLimit = 0;
#else
inline constexpr std::size_t kRunawayLimit = std::size_t{2} << 30;
#endif
#else
inline constexpr std::size_t kRunawayLimit = std::size_t{2} << 30;
#endif

/// How to run it.
struct ProcessOptions {
  std::string workingFolder;  ///< empty: the test's own
  /// Empty: captured; a path (such as /dev/full); kClosedStdout; kBrokenPipe.
  std::string stdoutPath;
  double timeLimitSeconds = 60;
  std::size_t addressSpaceLimit = 0;  ///< RLIMIT_AS of the child, bytes; 0: none
};

/// A voxcut process started with `args`; wait() collects it.
class VoxcutProcess {
 public:
  VoxcutProcess(const std::vector<std::string>& args, const ProcessOptions& options = {});
  ~VoxcutProcess();
  VoxcutProcess(const VoxcutProcess&) = delete;
  VoxcutProcess& operator=(const VoxcutProcess&) = delete;

  /// Sends `signal` to the child.
  void signal(int signal) const;
  /// Waits for the child (killing it at the time limit) and returns what it did.
  ProcessResult wait();

 private:
  pid_t pid_ = -1;
  std::string outPath_, errPath_;
  ProcessOptions options_;
  double startSeconds_ = 0;
};

/// Runs voxcut with `args` to the end.
ProcessResult runVoxcut(const std::vector<std::string>& args, const ProcessOptions& options = {});

/// The command line and what it did, for failure messages.
std::string describe(const std::vector<std::string>& args, const ProcessResult& r);

/// Reads a whole file ("" when missing).
std::string readText(const std::string& path);

}  // namespace voxcut::cli
