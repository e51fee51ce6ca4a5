// voxcut: the command line. Thin: every step lives in the library.

#include <malloc.h>

#include <CLI/CLI.hpp>
#include <cctype>
#include <filesystem>
#include <cstdio>
#include <iostream>
#include <new>
#include <nlohmann/json.hpp>

#include "CutCommand.h"
#include "Interrupt.h"
#include "ModelOptions.h"
#include "OutputFiles.h"
#include "RunCommand.h"
#include "voxcut/core/Parallel.h"
#include "voxcut/io/SurfaceWriter.h"
#include "voxcut/sim/WorldTypes.h"

namespace voxcut::app {
namespace {

// The label volume as read: its grid, placement in world space (metres, RAS) and labels.
nlohmann::json volumeJson(const LabelVolume& v) {
  nlohmann::json j;
  j["dims"] = {v.dims.x, v.dims.y, v.dims.z};
  const Vec3d spacing = v.spacing();
  j["spacing"] = {spacing.x(), spacing.y(), spacing.z()};
  j["origin"] = {v.origin.x(), v.origin.y(), v.origin.z()};
  nlohmann::json axes = nlohmann::json::array();
  for (int a = 0; a < 3; ++a) {
    const Vec3d dir = v.axes.col(a) / spacing[a];
    axes.push_back({dir.x(), dir.y(), dir.z()});
  }
  j["axes"] = axes;
  j["placement"] = v.placement;
  nlohmann::json labels = nlohmann::json::array();
  const std::vector<std::size_t> counts = v.labelCounts();
  for (std::size_t l = 0; l < v.labels.size(); ++l)
    labels.push_back({{"value", v.labels[l].value},
                      {"name", v.labels[l].name},
                      {"voxels", counts[l]}});
  j["labels"] = labels;
  return j;
}

nlohmann::json toJson(const std::string& name, const ModelBuild& b, int threads) {
  const auto& g = b.grid;
  const auto& s = b.stats;
  nlohmann::json j;
  j["model"] = name;
  j["grid"] = {g.dims().x, g.dims().y, g.dims().z};
  j["voxel_size"] = g.voxelSize();
  j["origin"] = {g.origin().x(), g.origin().y(), g.origin().z()};
  j["voxels"] = s.voxels;
  nlohmann::json perMat = nlohmann::json::object();
  for (const auto& [m, n] : s.voxelsPerMaterial) perMat[m] = n;
  j["voxels_per_material"] = perMat;
  const double voxelVolume = g.voxelSize() * g.voxelSize() * g.voxelSize();
  nlohmann::json volumes = nlohmann::json::object();
  for (const auto& [m, n] : s.voxelsPerMaterial) volumes[m] = static_cast<double>(n) * voxelVolume;
  j["volume_per_material_m3"] = volumes;
  if (b.volume) j["label_volume"] = volumeJson(*b.volume);
  j["links"] = s.connectedLinks;
  j["disconnected_links"] = s.surfaceLinks + s.cutLinks;
  j["disconnected_links_by_kind"] = {{"surface", s.surfaceLinks}, {"cut", s.cutLinks}};
  j["interface_links"] = s.interfaceLinks;
  j["surface_vertices"] = b.surface.positions.size();
  j["surface_triangles"] = b.surface.triangles.size();
  j["surface_closed"] = s.topology.closed;
  j["surface_manifold"] = s.topology.manifold;
  j["surface_pieces"] = s.topology.pieces;
  j["surface_genus"] = s.topology.genusSum;
  j["pieces"] = s.pieces;
  j["bytes_per_voxel"] = static_cast<double>(s.bytes) / static_cast<double>(g.voxelCount());
  j["octree_cubes"] = s.octreeCubes;
  j["active_voxels"] = s.activeVoxels;
  j["active_links"] = s.activeLinks;
  j["deformation_elements"] = s.deformationElements;
  j["deformation_nodes"] = s.deformationNodes;
  j["hanging_nodes"] = s.hangingNodes;
  j["threads"] = threads;
  j["memory_estimate_bytes"] = b.memory.bytes;
  nlohmann::json t = nlohmann::json::object();
  for (const auto& [stage, ms] : b.timings) t[stage] = ms;
  j["timings_ms"] = t;
  return j;
}

void printText(const std::string& name, const ModelBuild& b) {
  const auto& g = b.grid;
  const auto& s = b.stats;
  std::printf("model               %s\n", name.c_str());
  std::printf("grid                %d x %d x %d (%zu voxels, padding included)\n", g.dims().x,
              g.dims().y, g.dims().z, g.voxelCount());
  std::printf("voxel size          %.6g m\n", g.voxelSize());
  if (b.volume) {
    const LabelVolume& v = *b.volume;
    const Vec3d sp = v.spacing();
    std::printf("label volume        %d x %d x %d, spacing %.6g x %.6g x %.6g m, %zu labels, "
                "placed by %s\n",
                v.dims.x, v.dims.y, v.dims.z, sp.x(), sp.y(), sp.z(), v.labels.size(),
                v.placement.c_str());
  }
  std::printf("voxels              %zu\n", s.voxels);
  for (const auto& [m, n] : s.voxelsPerMaterial) std::printf("  %-17s %zu\n", m.c_str(), n);
  std::printf("links (connected)   %zu, of which %zu between materials\n", s.connectedLinks,
              s.interfaceLinks);
  std::printf("disconnected links  %zu surface, %zu cut\n", s.surfaceLinks, s.cutLinks);
  std::printf("surface             %zu vertices, %zu triangles, %s, %d piece(s), genus %d\n",
              b.surface.positions.size(), b.surface.triangles.size(),
              s.topology.closed
                  ? (s.topology.manifold ? "closed 2-manifold" : "closed, not manifold")
                  : "NOT closed",
              s.topology.pieces, s.topology.genusSum);
  std::printf("pieces              %d\n", s.pieces);
  std::printf("voxel octree        cubes per level (1 up):");
  for (std::size_t n : s.octreeCubes) std::printf(" %zu", n);
  std::printf("; %zu active voxels, %zu active links\n", s.activeVoxels, s.activeLinks);
  std::printf("deformation octree  elements per level (0 up):");
  for (std::size_t n : s.deformationElements) std::printf(" %zu", n);
  std::printf("; nodes per level:");
  for (std::size_t n : s.deformationNodes) std::printf(" %zu", n);
  std::printf(" (%zu hanging)\n", s.hangingNodes);
  std::printf("memory              %.1f bytes per voxel\n",
              static_cast<double>(s.bytes) / static_cast<double>(g.voxelCount()));
  std::printf("time (ms)          ");
  for (const auto& [stage, ms] : b.timings) std::printf(" %s %.1f", stage.c_str(), ms);
  std::printf("\n");
}

// OUTPUT's stem + "_" + the material's name (letters, digits, '-' and '.' kept, others '_')
// + OUTPUT's extension.
std::string materialFileName(const std::string& output, const std::string& material) {
  const std::filesystem::path p(output);
  std::string safe;
  for (const unsigned char c : material)
    safe += std::isalnum(c) || c == '-' || c == '.' ? static_cast<char>(c) : '_';
  return (p.parent_path() / (p.stem().string() + "_" + safe + p.extension().string())).string();
}

int run(int argc, char** argv) {
  CLI::App app{"voxcut: interactive cutting of deformable objects modeled as linked voxels"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "voxcut 0.1.0");

  ModelOptions infoOpt;
  auto* info =
      app.add_subcommand("info", "Voxelize a model and print its linked voxel model and surface");
  addModelOptions(*info, infoOpt);

  ModelOptions surfOpt;
  std::string output;
  auto* surface =
      app.add_subcommand("surface", "Voxelize a model and write its dual-contoured surface");
  addModelOptions(*surface, surfOpt);
  surface->add_option("-o,--output", output,
                      "Output surface, .obj or .ply; a model of several materials keeps them "
                      "(OBJ groups, a PLY face property 'material')")
      ->required();
  bool perMaterial = false;
  surface->add_flag("--per-material", perMaterial,
                    "Write one file per material instead, named OUTPUT's stem + _NAME");

  CutOptions cutOpt;
  CLI::App* cut = nullptr;
  addCutCommand(app, cutOpt, cut);
  BenchOptions benchOpt;
  CLI::App* bench = nullptr;
  addBenchCommand(app, benchOpt, bench);
  RunOptions runOpt;
  CLI::App* runCmd = nullptr;
  addRunCommand(app, runOpt, runCmd);

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    // One line, like every other error; --help has the details.
    std::fprintf(stderr, "voxcut: error: %s (see --help)\n", e.what());
    return 2;
  }
  if (cut->parsed()) return runCut(cutOpt);
  if (bench->parsed()) return runBench(benchOpt);
  if (benchOpt.complex.selected) return runComplexBench(benchOpt.complex);
  if (benchOpt.soak.selected) return runSoakBench(benchOpt.soak);
  if (runCmd->parsed()) return runRun(runOpt);
  ModelOptions& opt = info->parsed() ? infoOpt : surfOpt;
  ThreadLimit limit(opt.threads);
  if (surface->parsed()) checkSurfacePath(output);
  std::string name;
  // `surface` prints the octrees only in its JSON; it does not build them otherwise.
  const ModelBuild b = buildFromOptions(opt, name, info->parsed() || opt.json);
  if (surface->parsed()) {
    const std::vector<std::string>& names = b.grid.materialNames();
    if (perMaterial) {
      std::vector<std::pair<std::string, std::uint8_t>> parts;
      for (std::size_t m = 0; m < names.size(); ++m)
        parts.emplace_back(materialFileName(output, names[m]), static_cast<std::uint8_t>(m + 1));
      for (const auto& [path, m] : parts) checkSurfacePath(path);
      for (const auto& [path, m] : parts) writeSurface(materialPart(b.surface, m), path, names);
    } else {
      writeSurface(b.surface, output,
                   names.size() > 1 ? names : std::vector<std::string>{});
    }
  }
  if (opt.json)
    std::cout << toJson(name, b, ThreadLimit::current()).dump(2) << "\n";
  else if (info->parsed())
    printText(name, b);
  else
    std::printf("wrote %s: %zu vertices, %zu triangles\n", output.c_str(),
                b.surface.positions.size(), b.surface.triangles.size());
  return 0;
}

}  // namespace
}  // namespace voxcut::app

int main(int argc, char** argv) {
  // Keep freed memory for reuse instead of giving it back to the system: glibc trims the heap
  // and unmaps large blocks as soon as they are freed, so the next frame's buffers (the cut
  // step's scratch, a cube array that grows, a copied model) come back as fresh pages, and a
  // page fault costs microseconds on a virtual machine (docs/performance.md, "Memory kept for
  // reuse").
  mallopt(M_TRIM_THRESHOLD, 512 << 20);
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TOP_PAD, 16 << 20);
  // Exit status: 0 success; 2 any error, reported as one "voxcut: error:" line (bad input or
  // usage, a file that cannot be read or written, a frame that cannot finish, out of memory,
  // or an internal error, which its line names as such); 130 interrupted (SIGINT or SIGTERM during `run` or a benchmark).
  try {
    voxcut::app::prepareStandardOutput();
    const int status = voxcut::app::run(argc, argv);
    voxcut::app::checkStandardOutput();
    return status;
  } catch (const voxcut::InputError& e) {
    std::fprintf(stderr, "voxcut: error: %s\n", e.what());
  } catch (const voxcut::StepError& e) {
    // A frame that could not finish (a diverged solve): the message names the body and frame.
    std::fprintf(stderr, "voxcut: error: %s\n", e.what());
  } catch (const voxcut::Interrupted&) {
    std::fprintf(stderr, "voxcut: interrupted\n");
    return voxcut::app::kInterruptedStatus;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "voxcut: error: out of memory\n");
  } catch (const std::length_error& e) {
    // A container asked for more elements than it can hold: a size computed from the input.
    std::fprintf(stderr, "voxcut: error: out of memory (%s)\n", e.what());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "voxcut: error: internal error: %s\n", e.what());
  }
  return 2;
}
