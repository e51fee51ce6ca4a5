#include "SimRunner.h"

#include <chrono>

#include "voxcut/core/Error.h"

namespace voxcut::view {
namespace {
/// Frames kept in the FPS plot.
constexpr std::size_t kHistory = 4000;
}  // namespace

SimRunner::SimRunner(Session& session, const DrawOptions& options)
    : session_(session), options_(options) {
  publish(nullptr);
  thread_ = std::thread([this] { loop(); });
}

SimRunner::~SimRunner() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

void SimRunner::setPlaying(bool on) {
  {
    // Under the mutex, so that the thread cannot miss the change between its check and its
    // wait.
    const std::lock_guard<std::mutex> lock(mutex_);
    playing_ = on;
    // Paused: the frame run last is shown, also when it was not made drawable while playing.
    if (!on) optionsChanged_ = true;
  }
  wake_.notify_all();
}

void SimRunner::stepOnce() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    ++steps_;
  }
  wake_.notify_all();
}

void SimRunner::reset() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    reset_ = true;
  }
  wake_.notify_all();
}

void SimRunner::undoCut() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    undo_ = true;
  }
  wake_.notify_all();
}

void SimRunner::setUseOctree(bool on) {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    octree_ = on ? 1 : 0;
  }
  wake_.notify_all();
}

void SimRunner::setDrawOptions(const DrawOptions& options) {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    options_ = options;
    optionsChanged_ = true;
  }
  wake_.notify_all();
}

void SimRunner::send(std::vector<ToolCommand> commands) {
  if (commands.empty()) return;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    commands_.insert(commands_.end(), commands.begin(), commands.end());
  }
  wake_.notify_all();
}

void SimRunner::runBetweenFrames(const std::function<void(Session&)>& fn) {
  std::mutex doneMutex;
  std::condition_variable doneCv;
  bool done = false;
  std::exception_ptr failure;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    tasks_.emplace_back([&](Session& s) {
      try {
        fn(s);
      } catch (...) {
        failure = std::current_exception();
      }
      const std::lock_guard<std::mutex> l(doneMutex);
      done = true;
      doneCv.notify_all();
    });
  }
  wake_.notify_all();
  std::unique_lock<std::mutex> lock(doneMutex);
  doneCv.wait(lock, [&] { return done; });
  if (failure) std::rethrow_exception(failure);
}

std::shared_ptr<const DrawData> SimRunner::latest() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  taken_ = true;
  return latest_;
}

std::string SimRunner::error() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return error_;
}

void SimRunner::record(const FrameReport& report) {
  fpsTime_.push_back(static_cast<float>(report.time));
  fps_.push_back(static_cast<float>(1000.0 / std::max(report.totalMs, 1e-3)));
  if (fps_.size() > kHistory) {
    const auto drop = static_cast<std::ptrdiff_t>(kHistory / 4);
    fpsTime_.erase(fpsTime_.begin(), fpsTime_.begin() + drop);
    fps_.erase(fps_.begin(), fps_.begin() + drop);
  }
}

void SimRunner::publish(const FrameReport* report) {
  DrawOptions options;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    options = options_;
  }
  World& world = session_.world();
  auto data = std::make_shared<DrawData>(buildDrawData(world, session_.scene().obstacles, options));
  FrameFigures& f = data->figures;
  f.frame = world.frame();
  f.time = world.time();
  f.octree = session_.useOctree();
  std::size_t cut = 0;
  for (const BodyId b : world.bodies()) {
    cut += world.bodyInfo(b).cutLinks;
    f.activeLinks += world.activity(b, 0).activeLinks;
  }
  // Pieces are recounted only when links were cut (a pass over the voxels).
  if (cut != cutLinks_) {
    pieces_ = 0;
    for (const BodyId b : world.bodies()) pieces_ += world.pieces(b);
    cutLinks_ = cut;
  }
  f.cutLinks = cut;
  f.pieces = pieces_;
  for (const ToolId t : world.tools()) f.toolForces.push_back(world.toolReaction(t).force);
  if (report != nullptr) {
    f.stageMs = report->stageMs;
    f.totalMs = report->totalMs;
    f.cutLinksFrame = report->cutLinks;
    f.contacts = report->contacts;
  }
  data->fpsTime = fpsTime_;
  data->fps = fps_;
  const std::lock_guard<std::mutex> lock(mutex_);
  latest_ = std::move(data);
  taken_ = false;
}

void SimRunner::fail(const char* what) {
  const std::lock_guard<std::mutex> lock(mutex_);
  playing_ = false;
  error_ = what;
}

void SimRunner::loop() {
  using Clock = std::chrono::steady_clock;
  Clock::time_point paceStart = Clock::now();
  double paceTime = session_.world().time();
  for (;;) {
    std::vector<ToolCommand> commands;
    std::deque<std::function<void(Session&)>> tasks;
    bool doReset = false, doUndo = false, doStep = false, redraw = false;
    int octree = -1;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [&] {
        return stop_ || playing_.load() || steps_ > 0 || reset_ || undo_ || !commands_.empty() ||
               !tasks_.empty() || octree_ >= 0 || optionsChanged_;
      });
      if (stop_) return;
      commands.swap(commands_);
      tasks.swap(tasks_);
      doReset = reset_;
      reset_ = false;
      doUndo = undo_;
      undo_ = false;
      octree = octree_;
      octree_ = -1;
      redraw = optionsChanged_;
      optionsChanged_ = false;
      doStep = playing_.load() || steps_ > 0;
      if (steps_ > 0) --steps_;
    }
    for (auto& task : tasks) task(session_);
    // Anything a frame or a rebuild throws pauses the run with its message; nothing leaves
    // the thread.
    try {
      if (doReset) {
        {
          const std::lock_guard<std::mutex> lock(mutex_);
          error_.clear();
        }
        session_.reset();
        fpsTime_.clear();
        fps_.clear();
        cutLinks_ = static_cast<std::size_t>(-1);
        last_.reset();
        redraw = true;
        paceStart = Clock::now();
        paceTime = session_.world().time();
      }
      if (doUndo && session_.undoCut()) {
        cutLinks_ = static_cast<std::size_t>(-1);
        last_.reset();
        redraw = true;
        paceStart = Clock::now();
        paceTime = session_.world().time();
      }
      if (octree >= 0) {
        session_.setUseOctree(octree == 1);
        redraw = true;
      }
      session_.apply(commands);
      if (!doStep) {
        // Tools put down while paused, a reset or new options: shown at once.
        if (redraw || !commands.empty()) publish(last_ ? &*last_ : nullptr);
        paceStart = Clock::now();
        paceTime = session_.world().time();
        continue;
      }
      last_ = session_.step();
      const FrameReport& report = *last_;
      record(report);
      bool taken = false;
      {
        const std::lock_guard<std::mutex> lock(mutex_);
        taken = taken_;
      }
      // Made drawable when the window has taken the last one, when not playing on, or at
      // least every 25th frame: frames that run faster than the window draws are not turned
      // into arrays nobody draws.
      if (taken || !playing_.load() || report.frame % 25 == 0 || redraw || !commands.empty())
        publish(&report);
    } catch (const std::exception& e) {
      fail(e.what());
      continue;
    } catch (...) {
      fail("unknown error");
      continue;
    }
    // Real time: a frame is not run before the wall clock reaches its start.
    if (realTime_.load() && playing_.load()) {
      const double ahead = session_.world().time() - paceTime -
                           std::chrono::duration<double>(Clock::now() - paceStart).count();
      if (ahead > 0.0) {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait_for(lock, std::chrono::duration<double>(ahead),
                       [&] { return stop_ || !playing_.load(); });
      } else if (ahead < -0.25) {
        // Far behind (slow frames): pace from now rather than rush to catch up.
        paceStart = Clock::now();
        paceTime = session_.world().time();
      }
    }
  }
}

}  // namespace voxcut::view
