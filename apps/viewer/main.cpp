// voxcut-view: the interactive viewer (docs/viewer.md). Opens a scene, a built-in model or a
// mesh; the simulation runs on its own thread while the window draws its newest frame, the
// mouse drives a blade and a probe, and a panel shows the frame's figures. With --frames,
// --screenshot or --screenshots it runs headless: no window shown, no user, pictures out.

#define GLFW_INCLUDE_NONE
#include <GL/gl.h>
#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>
#include <imgui.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <numbers>
#include <optional>
#include <string>

#include "Camera.h"
#include "DrawData.h"
#include "GlContext.h"
#include "Input.h"
#include "Renderer.h"
#include "Session.h"
#include "SimRunner.h"
#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"

namespace voxcut::view {
namespace {

struct Options {
  std::string what = "bunny";
  int resolution = 64;
  int frames = -1;  // headless: frames to run (-1: none asked)
  std::string screenshot;
  std::string screenshots;
  int every = 1;
  std::string size = "960x720";
  std::string saveScene;
  bool noOctree = false, links = false, cubes = false, slice = false, wireframe = false;
  std::string fit = "now";
  std::vector<double> view;  // yaw and pitch (degrees)
  int threads = 0;
  double measure = 0.0;
  bool noVsync = false;  // window: play for this many seconds, then report the drawing rate
  int width = 960, height = 720;
};

/// Voxelizing's progress on a terminal.
ProgressCallback terminalProgress() {
  if (!isatty(2)) return {};
  return [](std::string_view stage, double fraction) {
    std::fprintf(stderr, "\r%.*s %3.0f%%", static_cast<int>(stage.size()), stage.data(),
                 100.0 * fraction);
    if (fraction >= 1.0) std::fputc('\n', stderr);
    return true;
  };
}

/// The camera's size and angles as asked.
Camera startCamera(const Options& o) {
  Camera c;
  c.width = o.width;
  c.height = o.height;
  if (o.view.size() == 2) {
    c.yaw = o.view[0] * std::numbers::pi / 180.0;
    c.pitch = o.view[1] * std::numbers::pi / 180.0;
  }
  return c;
}

DrawOptions drawOptions(const Options& o) {
  DrawOptions d;
  d.activeLinks = o.links;
  d.octreeCubes = o.cubes;
  d.slice = o.slice;
  return d;
}

// ---- headless ----

int runHeadless(const Options& o) {
  OpenOptions open;
  open.resolution = o.resolution;
  open.useOctree = !o.noOctree;
  open.progress = terminalProgress();
  // The window for pictures first: without a display, the run stops before any work. A run
  // that only saves its scene needs none.
  const bool pictures = !o.screenshot.empty() || !o.screenshots.empty();
  std::optional<GlContext> context;
  std::optional<Renderer> renderer;
  if (pictures) {
    context.emplace(o.width, o.height, false, "voxcut-view");
    renderer.emplace();
  }
  Session session = Session::open(o.what, open);
  const int frames = o.frames >= 0 ? o.frames : 0;
  if (!o.screenshots.empty()) std::filesystem::create_directories(o.screenshots);
  Camera camera = startCamera(o);
  if (o.view.size() != 2 && session.scene().view) {  // the scene's own view, unless --view
    camera.yaw = (*session.scene().view)[0] * std::numbers::pi / 180.0;
    camera.pitch = (*session.scene().view)[1] * std::numbers::pi / 180.0;
  }
  camera.upAgainst(session.scene().gravity);
  camera.fit(session.startBounds());
  const DrawOptions options = drawOptions(o);
  auto shoot = [&](const std::string& path) {
    const DrawData data = buildDrawData(session.world(), session.scene().obstacles, options);
    if (o.fit == "now") camera.fit(data.bodyBounds);
    writePng(renderer->capture(data, camera, o.wireframe), path);
  };
  const bool tty = isatty(2) != 0;
  for (int f = 0; f <= frames; ++f) {
    if (!o.screenshots.empty() && f % o.every == 0) {
      char name[32];
      std::snprintf(name, sizeof name, "frame-%06d.png", f);
      shoot((std::filesystem::path(o.screenshots) / name).string());
    }
    if (f == frames) break;
    (void)session.step();
    if (tty) std::fprintf(stderr, "\rframe %d/%d", f + 1, frames);
  }
  if (tty && frames > 0) std::fputc('\n', stderr);
  if (!o.screenshot.empty()) shoot(o.screenshot);
  if (!o.saveScene.empty()) session.saveRecordedScene(o.saveScene);
  return 0;
}

// ---- the window ----

struct Viewer {
  GLFWwindow* window = nullptr;
  std::unique_ptr<Session> session;
  std::unique_ptr<SimRunner> runner;
  std::unique_ptr<InputController> input;
  std::shared_ptr<const DrawData> shown;
  DrawOptions options;
  bool wireframe = false;
  bool octree = true;
  bool realTime = true;
  int toolMode = 0;
  char openPath[512] = "";
  char savePath[512] = "recorded-scene.json";
  std::string status;
  int shots = 0;
  bool wantShot = false;

  Camera start;
  int resolution = 64;  ///< of a model or mesh opened alone

  /// Opens `what`; on an error the viewer keeps what it had (and the error propagates).
  void open(const std::string& what, int modelResolution) {
    OpenOptions o;
    o.resolution = modelResolution;
    o.useOctree = octree;
    o.progress = terminalProgress();
    auto next = std::make_unique<Session>(Session::open(what, o));
    const Camera camera = input ? input->camera : start;
    runner.reset();  // the old session's thread stops before its session goes
    session = std::move(next);
    input = std::make_unique<InputController>(drivenTools(*session));
    input->camera = camera;
    input->camera.upAgainst(session->scene().gravity);
    input->camera.fit(session->startBounds());
    runner = std::make_unique<SimRunner>(*session, options);
    runner->setRealTime(realTime);
    shown = runner->latest();
    std::snprintf(openPath, sizeof openPath, "%s", what.c_str());
  }
  /// The cursor in the framebuffer's pixels (the camera's), from GLFW's window coordinates
  /// (they differ on screens with a content scale).
  void cursor(double& x, double& y) const {
    int ww = 0, wh = 0, fw = 0, fh = 0;
    glfwGetWindowSize(window, &ww, &wh);
    glfwGetFramebufferSize(window, &fw, &fh);
    if (ww > 0 && wh > 0) {
      x *= static_cast<double>(fw) / ww;
      y *= static_cast<double>(fh) / wh;
    }
  }
  void reset() {
    input->cancel();
    runner->reset();
  }
  void undoCut() {
    input->cancel();
    runner->undoCut();
  }
};

Viewer* viewerOf(GLFWwindow* w) {
  return static_cast<Viewer*>(glfwGetWindowUserPointer(w));
}

void onMouseButton(GLFWwindow* w, int button, int action, int mods) {
  Viewer& v = *viewerOf(w);
  if (ImGui::GetIO().WantCaptureMouse && action == GLFW_PRESS) return;
  double x = 0, y = 0;
  glfwGetCursorPos(w, &x, &y);
  v.cursor(x, y);
  const MouseButton b = button == GLFW_MOUSE_BUTTON_LEFT    ? MouseButton::Left
                        : button == GLFW_MOUSE_BUTTON_RIGHT ? MouseButton::Right
                                                            : MouseButton::Middle;
  v.input->mode = static_cast<ToolMode>(v.toolMode);
  v.runner->send(
      v.input->button(b, action == GLFW_PRESS, x, y, (mods & GLFW_MOD_SHIFT) != 0, *v.shown));
}

void onCursor(GLFWwindow* w, double x, double y) {
  Viewer& v = *viewerOf(w);
  v.cursor(x, y);
  v.runner->send(v.input->move(x, y));
}

void onScroll(GLFWwindow* w, double, double dy) {
  Viewer& v = *viewerOf(w);
  if (ImGui::GetIO().WantCaptureMouse) return;
  v.runner->send(v.input->wheel(dy));
}

void onKey(GLFWwindow* w, int key, int, int action, int mods) {
  Viewer& v = *viewerOf(w);
  if (action != GLFW_PRESS || ImGui::GetIO().WantCaptureKeyboard) return;
  switch (key) {
    case GLFW_KEY_SPACE:
      v.runner->setPlaying(!v.runner->playing());
      break;
    case GLFW_KEY_N:
      v.runner->stepOnce();
      break;
    case GLFW_KEY_R:
      v.reset();
      break;
    case GLFW_KEY_Z:
      if ((mods & GLFW_MOD_CONTROL) != 0) v.undoCut();
      break;
    case GLFW_KEY_C:
      v.toolMode = 0;
      break;
    case GLFW_KEY_B:
      v.toolMode = 1;
      break;
    case GLFW_KEY_P:
      v.toolMode = 2;
      break;
    case GLFW_KEY_F:
      v.input->camera.fit(v.shown->bodyBounds);
      break;
    case GLFW_KEY_W:
      v.wireframe = !v.wireframe;
      break;
    case GLFW_KEY_O:
      v.octree = !v.octree;
      v.runner->setUseOctree(v.octree);
      break;
    case GLFW_KEY_F12:
      v.wantShot = true;
      break;
    default:
      break;
  }
}

void panel(Viewer& v) {
  // Held here: opening another scene from this panel replaces v.shown.
  const std::shared_ptr<const DrawData> shown = v.shown;
  const FrameFigures& f = shown->figures;
  ImGui::SetNextWindowPos(ImVec2(8, 8), ImGuiCond_FirstUseEver);
  ImGui::Begin("voxcut", nullptr, ImGuiWindowFlags_AlwaysAutoResize);
  ImGui::InputText("##open", v.openPath, sizeof v.openPath);
  ImGui::SameLine();
  if (ImGui::Button("Open")) {
    try {
      v.open(v.openPath, v.resolution);
      v.status = std::string("opened ") + v.openPath;
    } catch (const std::exception& e) {
      v.status = e.what();
    }
  }
  if (ImGui::Button(v.runner->playing() ? "Pause" : "Play"))
    v.runner->setPlaying(!v.runner->playing());
  ImGui::SameLine();
  if (ImGui::Button("Step")) v.runner->stepOnce();
  ImGui::SameLine();
  if (ImGui::Button("Reset")) v.reset();
  ImGui::SameLine();
  if (ImGui::Button("Undo cut")) v.undoCut();
  ImGui::SameLine();
  if (ImGui::Checkbox("real time", &v.realTime)) v.runner->setRealTime(v.realTime);
  ImGui::Text("tool:");
  ImGui::SameLine();
  ImGui::RadioButton("camera", &v.toolMode, 0);
  ImGui::SameLine();
  ImGui::RadioButton("blade", &v.toolMode, 1);
  ImGui::SameLine();
  ImGui::RadioButton("probe", &v.toolMode, 2);
  if (ImGui::Checkbox("voxel octree", &v.octree)) v.runner->setUseOctree(v.octree);
  ImGui::SameLine();
  ImGui::Checkbox("wireframe", &v.wireframe);
  bool changed = ImGui::Checkbox("active links", &v.options.activeLinks);
  ImGui::SameLine();
  changed |= ImGui::Checkbox("octree cubes", &v.options.octreeCubes);
  ImGui::SameLine();
  changed |= ImGui::Checkbox("slice", &v.options.slice);
  if (changed) v.runner->setDrawOptions(v.options);
  if (ImGui::Button("Fit camera")) v.input->camera.fit(shown->bodyBounds);
  ImGui::SameLine();
  if (ImGui::Button("Screenshot")) v.wantShot = true;
  ImGui::InputText("##save", v.savePath, sizeof v.savePath);
  ImGui::SameLine();
  if (ImGui::Button("Save recording")) {
    try {
      const std::string path = v.savePath;
      v.runner->runBetweenFrames([&](Session& s) { s.saveRecordedScene(path); });
      v.status = "saved " + path + " (replay: voxcut run " + path + ")";
    } catch (const std::exception& e) {
      v.status = e.what();
    }
  }
  ImGui::Separator();
  ImGui::Text("frame %d, t = %.3f s, %s", f.frame, f.time, f.octree ? "octree" : "baseline");
  ImGui::Text("frame %.2f ms (%.0f FPS), drawing %.0f FPS", f.totalMs,
              f.totalMs > 0 ? 1000.0 / f.totalMs : 0.0,
              static_cast<double>(ImGui::GetIO().Framerate));
  if (!shown->fps.empty()) {
    const std::string label = "FPS over simulated time, " +
                              std::to_string(shown->fpsTime.front()).substr(0, 5) + "-" +
                              std::to_string(shown->fpsTime.back()).substr(0, 5) + " s";
    ImGui::PlotLines("##fps", shown->fps.data(), static_cast<int>(shown->fps.size()), 0,
                     label.c_str(), 0.0f, FLT_MAX, ImVec2(320, 80));
  }
  const std::vector<std::string>& names = frameStageNames();
  if (ImGui::BeginTable("stages", 2)) {
    for (std::size_t s = 0; s < names.size() && s < f.stageMs.size(); ++s) {
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(names[s].c_str());
      ImGui::TableNextColumn();
      ImGui::Text("%.3f ms", f.stageMs[s]);
    }
    ImGui::EndTable();
  }
  ImGui::Text("cut links %zu (+%zu), pieces %d", f.cutLinks, f.cutLinksFrame, f.pieces);
  ImGui::Text("active links %zu, contacts %zu", f.activeLinks, f.contacts);
  for (std::size_t t = 0; t < f.toolForces.size(); ++t)
    ImGui::Text("tool %zu force %.3f N", t, f.toolForces[t].norm());
  const std::string error = v.runner->error();
  if (!error.empty()) ImGui::TextWrapped("error: %s", error.c_str());
  if (!v.status.empty()) ImGui::TextWrapped("%s", v.status.c_str());
  ImGui::TextWrapped(
      "keys: space play/pause, N step, R reset, Ctrl-Z undo the last cut, C/B/P "
      "camera/blade/probe, F fit, W wireframe, "
      "O octree, F12 screenshot. Left drag orbits (on a body with a tool: drives it), right or "
      "shift drag pans, wheel zooms (while driving: depth).");
  ImGui::End();
}

int runWindow(const Options& o) {
  GlContext context(o.width, o.height, true, "voxcut-view");
  Viewer v;
  v.window = context.window();
  v.octree = !o.noOctree;
  v.wireframe = o.wireframe;
  v.options = drawOptions(o);
  v.start = startCamera(o);
  v.resolution = o.resolution;
  v.open(o.what, o.resolution);
  glfwSetWindowUserPointer(v.window, &v);
  glfwSetMouseButtonCallback(v.window, onMouseButton);
  glfwSetCursorPosCallback(v.window, onCursor);
  glfwSetScrollCallback(v.window, onScroll);
  glfwSetKeyCallback(v.window, onKey);
  glfwSwapInterval(o.noVsync ? 0 : 1);
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;
  ImGui::StyleColorsDark();
  // Installed after ours: ImGui's callbacks chain to them.
  ImGui_ImplGlfw_InitForOpenGL(v.window, true);
  ImGui_ImplOpenGL3_Init("#version 330 core");
  using Clock = std::chrono::steady_clock;
  const Clock::time_point started = Clock::now();
  long drawn = 0;
  if (o.measure > 0.0) v.runner->setPlaying(true);
  {
    Renderer renderer;
    while (!glfwWindowShouldClose(v.window)) {
      // The last frame of --measure: with --screenshot it is still drawn, and captured.
      const bool last = o.measure > 0.0 &&
                        std::chrono::duration<double>(Clock::now() - started).count() >= o.measure;
      if (last && o.screenshot.empty()) break;
      ++drawn;
      glfwPollEvents();
      v.shown = v.runner->latest();
      int w = 0, h = 0;
      glfwGetFramebufferSize(v.window, &w, &h);
      v.input->camera.width = std::max(w, 1);
      v.input->camera.height = std::max(h, 1);
      if (v.wantShot) {
        v.wantShot = false;
        char name[64];
        std::snprintf(name, sizeof name, "voxcut-view-%03d.png", v.shots++);
        try {
          writePng(renderer.capture(*v.shown, v.input->camera, v.wireframe), name);
          v.status = std::string("wrote ") + name;
        } catch (const std::exception& e) {
          v.status = e.what();
        }
      }
      renderer.draw(*v.shown, v.input->camera, v.wireframe);
      ImGui_ImplOpenGL3_NewFrame();
      ImGui_ImplGlfw_NewFrame();
      ImGui::NewFrame();
      panel(v);
      ImGui::Render();
      ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
      // --measure with --screenshot: the whole window, panel included, at the end.
      if (last) {
        glReadBuffer(GL_BACK);
        writePng(readPixels(w, h), o.screenshot);
        glfwSwapBuffers(v.window);
        break;
      }
      glfwSwapBuffers(v.window);
    }
  }
  if (o.measure > 0.0) {
    // The drawing rate beside the simulation's: they run on their own threads.
    const double seconds = std::chrono::duration<double>(Clock::now() - started).count();
    // Paused and between frames, the newest frame is the last one run.
    v.runner->setPlaying(false);
    v.runner->runBetweenFrames([](Session&) {});
    const std::shared_ptr<const DrawData> last = v.runner->latest();
    const FrameFigures& f = last->figures;
    double simMs = 0.0;
    for (float fps : last->fps) simMs += 1000.0 / fps;
    const std::size_t n = last->fps.size();
    std::printf(
        "drawn %ld frames in %.2f s: %.1f fps; simulated %d frames (%.3f s of time), frame "
        "mean %.2f ms\n",
        drawn, seconds, static_cast<double>(drawn) / seconds, f.frame, f.time,
        n > 0 ? simMs / static_cast<double>(n) : 0.0);
  }
  v.runner.reset();
  ImGui_ImplOpenGL3_Shutdown();
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
  return 0;
}

}  // namespace
}  // namespace voxcut::view

int main(int argc, char** argv) {
  using namespace voxcut::view;
  Options o;
  CLI::App app{
      "voxcut-view: watch and drive voxcut's cutting simulation. Opens a scene (.json), a "
      "built-in model (bunny, liver, starfish, box:LX,LY,LZ, sphere:R) or a mesh file; the mouse "
      "drives a blade and a probe. With --frames, --screenshot or --screenshots it runs "
      "headless (no window shown; needs a display, e.g. xvfb-run -a)."};
  app.add_option("what", o.what, "scene, model or mesh (default bunny)");
  app.add_option("--resolution", o.resolution, "voxels along a model's longest side (default 64)")
      ->check(CLI::Range(3, 1024));
  app.add_option("--frames", o.frames, "headless: run N frames, then take --screenshot")
      ->check(CLI::Range(0, 100000000));
  app.add_option("--screenshot", o.screenshot,
                 "headless: PNG of the last frame; with --measure: of the whole window at the end");
  app.add_option("--screenshots", o.screenshots, "headless: a PNG every --every frames into DIR");
  app.add_option("--every", o.every, "with --screenshots: frames between pictures (default 1)")
      ->check(CLI::Range(1, 100000000));
  app.add_option("--size", o.size, "window or picture size WxH (default 960x720)");
  app.add_option("--save-scene", o.saveScene,
                 "headless: write the run as a scene that voxcut run replays");
  app.add_option("--fit", o.fit, "headless camera: 'now' fits every picture, 'start' the start")
      ->check(CLI::IsMember({"now", "start"}));
  app.add_option("--view", o.view,
                 "camera angles YAW PITCH in degrees (default: the scene's \"view\", else 34 20)")
      ->expected(2)
      ->check(CLI::Range(-360.0, 360.0));
  app.add_flag("--no-octree", o.noOctree, "start with the voxel octree off (the baseline)");
  app.add_flag("--links", o.links, "draw the active links");
  app.add_flag("--cubes", o.cubes, "draw the voxel octree's cubes");
  app.add_flag("--slice", o.slice,
               "draw the links and cubes of one layer of voxels through the middle only");
  app.add_flag("--wireframe", o.wireframe, "draw the surfaces' edges");
  app.add_option("--measure", o.measure,
                 "window: play for S seconds, then print the drawing and simulation rates")
      ->check(CLI::Range(0.1, 3600.0));
  app.add_flag("--no-vsync", o.noVsync,
               "window: draw as fast as possible instead of at the display's refresh rate");
  app.add_option("--threads", o.threads, "worker threads (default: all cores)")
      ->check(CLI::Range(1, 1024));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    parseViewSize(o.size, "--size", o.width, o.height);
    if (o.view.size() == 2 && std::abs(o.view[1]) > 89.0)
      throw voxcut::InputError("--view: the pitch must be within [-89, 89] degrees");
    std::optional<voxcut::ThreadLimit> limit;
    if (o.threads > 0) limit.emplace(o.threads);
    const bool headless =
        o.measure == 0.0 && (o.frames >= 0 || !o.screenshot.empty() || !o.screenshots.empty());
    if (!headless && !o.saveScene.empty())
      throw voxcut::InputError(
          "--save-scene: only headless, with --frames, --screenshot or --screenshots (the "
          "window saves from its panel)");
    return headless ? runHeadless(o) : runWindow(o);
  } catch (const voxcut::Interrupted&) {
    std::fprintf(stderr, "voxcut-view: interrupted\n");
    return 130;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "voxcut-view: error: %s\n", e.what());
    return 1;
  }
}
