#include "CliProcess.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <fstream>
#include <thread>

namespace voxcut::cli {
namespace {

double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

}  // namespace

TempFolder::TempFolder(const std::string& tag) {
  static int counter = 0;
  path_ = fs::temp_directory_path() /
          ("voxcut_" + tag + "_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
  fs::remove_all(path_);
  fs::create_directories(path_);
}

TempFolder::~TempFolder() {
  std::error_code ec;
  fs::remove_all(path_, ec);
}

std::string TempFolder::write(const std::string& name, const std::string& bytes) const {
  const std::string p = file(name);
  fs::create_directories(fs::path(p).parent_path());
  std::ofstream(p, std::ios::binary) << bytes;
  return p;
}

std::vector<std::string> TempFolder::entries() const {
  std::vector<std::string> names;
  for (const auto& e : fs::recursive_directory_iterator(path_))
    names.push_back(fs::relative(e.path(), path_).string());
  std::sort(names.begin(), names.end());
  return names;
}

std::string readText(const std::string& path) {
  std::error_code ec;
  const auto size = fs::file_size(path, ec);
  if (ec) return {};
  std::string bytes(size, '\0');
  std::ifstream(path, std::ios::binary).read(bytes.data(), static_cast<std::streamsize>(size));
  return bytes;
}

VoxcutProcess::VoxcutProcess(const std::vector<std::string>& args, const ProcessOptions& options)
    : options_(options) {
  static int counter = 0;
  const fs::path base =
      fs::temp_directory_path() /
      ("voxcut_process_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
  outPath_ = options.stdoutPath.empty() ? base.string() + ".out" : options.stdoutPath;
  errPath_ = base.string() + ".err";
  std::vector<std::string> store{VOXCUT_EXE};
  store.insert(store.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& a : store) argv.push_back(a.data());
  argv.push_back(nullptr);
  const rlimit limit{options.addressSpaceLimit, options.addressSpaceLimit};
  const bool closed = options.stdoutPath == kClosedStdout;
  int pipeEnds[2] = {-1, -1};
  if (options.stdoutPath == kBrokenPipe) {
    if (::pipe(pipeEnds) != 0) ADD_FAILURE() << "pipe failed";
    ::close(pipeEnds[0]);  // nobody reads: a write fails with EPIPE (or raises SIGPIPE)
  }
  const bool special = closed || pipeEnds[1] >= 0;
  startSeconds_ = now();
  pid_ = ::fork();
  if (pid_ == 0) {
    // Child: only async-signal-safe calls until exec.
    const int in = ::open("/dev/null", O_RDONLY);
    const int out =
        special ? pipeEnds[1] : ::open(outPath_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    const int err = ::open(errPath_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    if (in < 0 || (!closed && out < 0) || err < 0) ::_exit(125);
    ::dup2(in, 0);
    if (closed)
      ::close(1);
    else
      ::dup2(out, 1);
    ::dup2(err, 2);
    if (limit.rlim_cur != 0) ::setrlimit(RLIMIT_AS, &limit);
    if (!options_.workingFolder.empty() && ::chdir(options_.workingFolder.c_str()) != 0)
      ::_exit(125);
    ::execv(VOXCUT_EXE, argv.data());
    ::_exit(126);
  }
  if (pid_ < 0) ADD_FAILURE() << "fork failed";
  if (pipeEnds[1] >= 0) ::close(pipeEnds[1]);
}

VoxcutProcess::~VoxcutProcess() {
  if (pid_ > 0) {
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, nullptr, 0);
  }
  std::error_code ec;
  if (options_.stdoutPath.empty()) fs::remove(outPath_, ec);  // captured output only
  fs::remove(errPath_, ec);
}

void VoxcutProcess::signal(int signal) const {
  if (pid_ > 0) ::kill(pid_, signal);
}

ProcessResult VoxcutProcess::wait() {
  ProcessResult r;
  if (pid_ <= 0) return r;
  int wstatus = 0;
  for (;;) {
    const pid_t done = ::waitpid(pid_, &wstatus, WNOHANG);
    if (done == pid_) break;
    if (now() - startSeconds_ > options_.timeLimitSeconds && !r.timedOut) {
      r.timedOut = true;
      ::kill(pid_, SIGKILL);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  pid_ = -1;
  r.seconds = now() - startSeconds_;
  r.status = WIFEXITED(wstatus) ? WEXITSTATUS(wstatus) : 128 + WTERMSIG(wstatus);
  if (options_.stdoutPath.empty()) r.out = readText(outPath_);
  r.err = readText(errPath_);
  return r;
}

ProcessResult runVoxcut(const std::vector<std::string>& args, const ProcessOptions& options) {
  VoxcutProcess p(args, options);
  return p.wait();
}

std::string describe(const std::vector<std::string>& args, const ProcessResult& r) {
  std::string s = "voxcut";
  for (const auto& a : args) s += " '" + a + "'";
  return s + "\n  status " + std::to_string(r.status) +
         (r.timedOut ? " (killed at the time limit)" : "") + ", " + std::to_string(r.seconds) +
         " s\n  stdout: " + r.out.substr(0, 500) + "\n  stderr: " + r.err.substr(0, 500);
}

}  // namespace voxcut::cli
