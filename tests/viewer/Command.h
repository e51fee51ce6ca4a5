#pragma once
// Runs a shell command for the viewer's tests, with its standard output and error captured.

#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace voxcut::view {

/// Runs `command` through the shell; returns its exit status (-1 when it did not exit), its
/// output and errors in `out`.
inline int runCommand(const std::string& command, std::string& out) {
  // Named by the process: CTest runs the tests of a file side by side.
  const std::filesystem::path file =
      std::filesystem::temp_directory_path() /
      ("voxcut-viewer-command-" + std::to_string(::getpid()) + ".txt");
  const int status = std::system((command + " > " + file.string() + " 2>&1").c_str());
  {
    std::ifstream in(file);
    std::stringstream s;
    s << in.rdbuf();
    out = s.str();
  }
  std::filesystem::remove(file);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace voxcut::view
