#include "OutputFiles.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <system_error>

#include "voxcut/core/Error.h"

namespace voxcut::app {
namespace {

namespace fs = std::filesystem;

fs::path folderOf(const std::string& path) {
  const fs::path parent = fs::path(path).parent_path();
  return parent.empty() ? fs::path(".") : parent;
}

// Throws unless `folder` is one this process may create entries in.
void requireWritableFolder(const fs::path& folder, const std::string& what) {
  if (::access(folder.c_str(), W_OK | X_OK) != 0)
    throw InputError(what + ": cannot create files in folder '" + folder.string() + "' (" +
                     std::strerror(errno) + ")");
}

}  // namespace

void checkOutputFile(const std::string& path, const std::string& option) {
  const std::string what = option + " '" + path + "'";
  if (path.empty()) throw InputError(option + ": empty file name");
  std::error_code ec;
  const fs::path folder = folderOf(path);
  if (!fs::is_directory(folder, ec))
    throw InputError(what + ": folder '" + folder.string() + "' does not exist");
  const fs::file_status status = fs::status(path, ec);
  if (fs::is_directory(status)) throw InputError(what + ": is a folder");
  if (fs::exists(status)) {
    if (!fs::is_regular_file(status)) throw InputError(what + ": is not a regular file");
    if (::access(path.c_str(), W_OK) != 0)
      throw InputError(what + ": cannot write (" + std::strerror(errno) + ")");
  }
  // The file is written beside itself first (PendingFile, writeSurface).
  requireWritableFolder(folder, what);
}

void checkOutputFolder(const std::string& path, const std::string& option) {
  const std::string what = option + " '" + path + "'";
  if (path.empty()) throw InputError(option + ": empty folder name");
  std::error_code ec;
  fs::path p = fs::absolute(path, ec).lexically_normal();
  if (ec) throw InputError(what + ": " + ec.message());
  // The nearest existing ancestor (the folder itself when it exists) must be a folder we may
  // write in; create_directories makes the rest.
  while (!fs::exists(fs::symlink_status(p, ec)) && p.has_parent_path() && p != p.parent_path())
    p = p.parent_path();
  if (!fs::is_directory(p, ec)) throw InputError(what + ": '" + p.string() + "' is not a folder");
  requireWritableFolder(p, what);
}

PendingFile::PendingFile(std::string path, std::string option)
    : path_(std::move(path)), temporary_(path_ + ".tmp"), option_(std::move(option)) {
  guard_.emplace(temporary_);
  out_.open(temporary_, std::ios::trunc);
  if (!out_)
    throw InputError(option_ + ": cannot create '" + temporary_ + "' (" + std::strerror(errno) +
                     ")");
}

PendingFile::~PendingFile() {
  if (committed_) return;
  out_.close();
  std::error_code ec;
  fs::remove(temporary_, ec);
}

void PendingFile::writeLine(const std::string& line) {
  out_ << line << '\n';
  out_.flush();
  if (!out_) throw InputError(option_ + ": writing '" + temporary_ + "' failed (disk full?)");
}

void PendingFile::commit() {
  out_.close();
  if (!out_) throw InputError(option_ + ": writing '" + temporary_ + "' failed (disk full?)");
  std::error_code ec;
  fs::rename(temporary_, path_, ec);
  if (ec)
    throw InputError(option_ + ": cannot rename '" + temporary_ + "' to '" + path_ + "' (" +
                     ec.message() + ")");
  committed_ = true;
  guard_.reset();
}

void prepareStandardOutput() {
  std::signal(SIGPIPE, SIG_IGN);
  if (::fcntl(STDOUT_FILENO, F_GETFD) != -1 || errno != EBADF) return;
  const int fd = ::open("/dev/null", O_WRONLY);
  if (fd >= 0 && fd != STDOUT_FILENO) {
    ::dup2(fd, STDOUT_FILENO);
    ::close(fd);
  }
  throw InputError("standard output is closed");
}

void checkStandardOutput() {
  if (std::fflush(stdout) != 0 || std::ferror(stdout) != 0) {
    const int e = errno;
    throw InputError(std::string("cannot write to standard output (") +
                     (e != 0 ? std::strerror(e) : "write error") + ")");
  }
}

}  // namespace voxcut::app
