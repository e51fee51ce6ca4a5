#pragma once
// The random user of `voxcut bench soak` (SoakBench.h): blades and a probe driven frame by frame
// through episodes of cutting, poking and resting, drawn from a seed. Every episode aims at the
// body's surface as it is when the episode starts, so the tools keep meeting material while
// the body falls apart.
//
// Deterministic: the same seed, world and settings give the same poses, on any standard
// library (the generator is std::mt19937_64 with our own mapping to numbers, no std::
// distributions) and any thread count (the world's results do not depend on it).
// Thread-safety: one object per world, used by the thread that steps it.

#include <cstddef>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "voxcut/core/Types.h"
#include "voxcut/sim/World.h"

namespace voxcut::app {

/// Uniform numbers from std::mt19937_64, mapped by hand so that every platform draws the same.
class SoakRandom {
 public:
  explicit SoakRandom(std::uint64_t seed) : engine_(seed) {}
  /// In [0, 1): the top 53 bits of one draw.
  double uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  /// In [lo, hi).
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  /// In [lo, hi], both included; lo <= hi.
  int integer(int lo, int hi) {
    const auto span = static_cast<std::uint64_t>(hi - lo) + 1;
    return lo + static_cast<int>(static_cast<std::uint64_t>(uniform() * static_cast<double>(span)));
  }
  /// True with probability p.
  bool chance(double p) { return uniform() < p; }

 private:
  std::mt19937_64 engine_;
};

/// What the interaction is set up with.
struct SoakInteractionParams {
  std::uint64_t seed = 1;
  int blades = 0;  ///< 1..3; 0: drawn from the seed
  int upAxis = 1;  ///< the world axis that points up (gravity points down it): 0 x, 1 y, 2 z
};

/// The random user. Adds its tools to the world (blades first, then the probe), parked far
/// above the body; then, called before every step, sets every moving tool's pose for the
/// frame (World::setToolPose) and puts tools down and away between episodes (placeTool).
class SoakInteraction {
 public:
  /// Adds the tools to `world`, sized and parked after body `body`'s surface now.
  SoakInteraction(World& world, BodyId body, const SoakInteractionParams& params);

  /// Sets the tools' poses for the next frame, starting a new episode when the last one ended.
  void beforeStep(World& world);

  /// The current episode's name (one of episodeNames()).
  [[nodiscard]] const std::string& episode() const { return episodeName_; }
  [[nodiscard]] int blades() const { return static_cast<int>(blades_.size()); }
  [[nodiscard]] ToolId probe() const { return probe_; }

  /// Every episode the interaction draws from, by name.
  [[nodiscard]] static const std::vector<std::string>& episodeNames();

 private:
  /// A straight move of one tool to `to` over `frames` frames (>= 1).
  struct Leg {
    BladePose to;
    int frames = 1;
  };
  /// One tool's part in an episode: put down at `start`, then moved along the legs.
  struct Motion {
    ToolId tool;
    BladePose start;
    std::vector<Leg> legs;
  };
  /// Where the surface is when an episode starts.
  struct Target;

  void startEpisode(World& world);
  [[nodiscard]] Target target(World& world) const;
  [[nodiscard]] Vec3d horizontal(double angle) const;
  [[nodiscard]] ToolId pickBlade();
  [[nodiscard]] int framesFor(double distance, double speedVoxels) const;
  Motion verticalCut(const Target& t, ToolId blade, const Vec3d& through, const Vec3d& edge,
                     double lengthScale, double depthFraction, bool withdraw);
  Motion horizontalCut(const Target& t, ToolId blade, double height);
  Motion zigzagCut(const Target& t, ToolId blade);
  Motion sliverCut(const Target& t, ToolId blade);
  Motion probeMotion(const Target& t, bool drag, bool cutFace);

  SoakRandom random_;
  std::vector<ToolId> blades_;
  ToolId probe_;
  BodyId body_;
  Vec3d up_ = Vec3d::UnitY(), side1_ = Vec3d::UnitZ(), side2_ = Vec3d::UnitX();
  double voxel_ = 0.0;
  double probeRadius_ = 0.0, probeHalfLength_ = 0.0;
  std::vector<BladePose> parked_;      ///< per tool
  Vec3d lastCutEdge_ = Vec3d::Zero();  ///< edge direction of the last vertical cut, if any

  std::string episodeName_;
  std::vector<Motion> motions_;
  std::vector<BladePose> from_;  ///< per motion, the pose its current leg starts at
  int episodeFrame_ = 0, episodeFrames_ = 0;
};

}  // namespace voxcut::app
