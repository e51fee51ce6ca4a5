#pragma once
// Output files of the command line: checked before any work starts, written whole or not at
// all, and standard output checked for write errors.

#include <fstream>
#include <optional>
#include <string>

#include "Interrupt.h"

namespace voxcut::app {

/// Checks that `path` (given to `option`) can be written: its folder exists, it is not a
/// folder, and it (or, when missing, its folder) is writable. Throws InputError naming the
/// option otherwise. Creates nothing.
void checkOutputFile(const std::string& path, const std::string& option);

/// Checks that folder `path` (given to `option`) exists and is writable, or can be created:
/// its nearest existing ancestor is a writable folder. Throws InputError naming the option
/// otherwise. Creates nothing.
void checkOutputFolder(const std::string& path, const std::string& option);

/// A text file written as `path + ".tmp"` and renamed to `path` by commit(); the temporary is
/// removed when the object dies uncommitted (an error on the way), so a failed run leaves no
/// partial file and never clobbers an earlier `path`; a signal that ends the program at once
/// removes it too (TemporaryFileGuard). Every line written is flushed to the temporary at
/// once, so what was committed holds whole lines only.
class PendingFile {
 public:
  /// Creates the temporary. Throws InputError naming `option` when it cannot.
  PendingFile(std::string path, std::string option);
  ~PendingFile();
  PendingFile(const PendingFile&) = delete;
  PendingFile& operator=(const PendingFile&) = delete;

  /// Writes `line` (a newline is added) and flushes it. Throws InputError on a write error
  /// (a full disk).
  void writeLine(const std::string& line);
  /// Closes the temporary and renames it to the path. Throws InputError on failure.
  void commit();

 private:
  std::string path_, temporary_, option_;
  std::optional<TemporaryFileGuard> guard_;  ///< until the temporary is renamed or removed
  std::ofstream out_;
  bool committed_ = false;
};

/// Makes write errors on standard output visible: a closed pipe fails the write (EPIPE)
/// instead of killing the program with SIGPIPE, and a closed standard output is refused at
/// once (its descriptor is taken by /dev/null first, so that no file opened later lands on
/// it and receives the output). Throws InputError when standard output is closed.
void prepareStandardOutput();

/// Flushes standard output and throws InputError when anything written to it was lost (a
/// closed pipe, a full disk, /dev/full).
void checkStandardOutput();

}  // namespace voxcut::app
