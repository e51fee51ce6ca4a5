// A body's energy read through the world (World::energy), and what contact between cut pieces
// does to momentum and energy.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>

#include "voxcut/io/SceneBodies.h"
#include "voxcut/io/SceneReader.h"
#include "voxcut/sim/World.h"

namespace voxcut {
namespace {

World worldOf(const std::string& json) {
  const Scene scene = parseScene(json, "test.json", std::filesystem::current_path());
  return World::fromScene(scene, voxelizeSceneBodies(scene));
}

// The body's momentum, sum m_n v_n (kg m/s).
Vec3d momentum(const World& w, std::size_t body) {
  const NodeState nodes = w.nodes(w.bodies()[body]);
  Vec3d p = Vec3d::Zero();
  for (std::size_t n = 0; n < nodes.masses.size(); ++n) p += nodes.masses[n] * nodes.velocities[n];
  return p;
}

// The body's mass (kg): its nodes' lumped masses summed.
double totalMass(const World& w, std::size_t body) {
  double sum = 0.0;
  for (const double m : w.nodes(w.bodies()[body]).masses) sum += m;
  return sum;
}

// A free-falling box: the kinetic energy is 1/2 M (g t)^2 (free fall is a pure translation,
// exact for backward Euler), the potential falls by M g times the drop, nothing is strained,
// and the total never grows (backward Euler only takes energy out).
TEST(ContactEnergy, EnergyOfAFallingBody) {
  World w = worldOf(R"({"time_step": 0.004, "gravity": [0, -9.81, 0],
    "solver": {"tolerance": 1e-8, "max_iterations": 1000},
    "bodies": [{"model": "box:0.1,0.06,0.08", "resolution": 16, "element_level": 1,
      "materials": {"default": {"young_modulus": 1e5, "poisson_ratio": 0.3, "density": 1000,
                                "damping": [0, 0]}}}]})");
  const double mass = totalMass(w, 0);
  const BodyEnergy start = w.energy(w.bodies()[0]);
  EXPECT_EQ(start.kinetic, 0.0);
  EXPECT_NEAR(start.elastic, 0.0, 1e-12);
  double last = start.total();
  for (int f = 1; f <= 25; ++f) {
    (void)w.step();
    const BodyEnergy e = w.energy(w.bodies()[0]);
    const double t = f * 0.004;
    EXPECT_NEAR(e.kinetic, 0.5 * mass * std::pow(9.81 * t, 2), 1e-9 * mass);
    EXPECT_NEAR(e.elastic, 0.0, 1e-12);
    EXPECT_LE(e.total(), last + 1e-12);
    last = e.total();
  }
  // Backward Euler's drop after n steps is g dt^2 n (n + 1) / 2.
  const double drop = 9.81 * 0.004 * 0.004 * 25 * 26 / 2;
  EXPECT_NEAR(start.gravitational - w.energy(w.bodies()[0]).gravitational, mass * 9.81 * drop,
              1e-9);
}

// Pieces must not drive themselves (the climbing pieces of the soak): with no gravity and
// nothing to touch, a blade cuts the bunny in two and its pieces touch only each other (self
// collision), so the body's momentum must stay zero. Each self contact is one spring of the
// body's step, equal and opposite (docs/algorithms.md, "Self contact in one solve"); what is
// left is the topology changes' remapping of velocities (a few 1e-6 kg m/s), where a law with
// a share per side gave 2e-3.
TEST(ContactEnergy, SelfContactCreatesNoMomentum) {
  World w = worldOf(R"({"time_step": 0.004, "gravity": [0, 0, 0], 
    "contact": {"self_collision": true},
    "bodies": [{"model": "bunny", "resolution": 64, "element_level": 3, "finest_level": 1,
      "offset": [0, 0.0005, 0],
      "materials": {"default": {"young_modulus": 1e6, "poisson_ratio": 0.3, "density": 1000,
                                "damping": [20, 0.005]}}}],
    "tools": [{"type": "blade", "keys": [
      {"t": 0.0, "a": [-0.15, 0.06, 0.12], "b": [0.15, 0.06, 0.12]},
      {"t": 0.2, "a": [-0.15, 0.06, -0.12], "b": [0.15, 0.06, -0.12]}]}]})");
  const double mass = totalMass(w, 0);
  double most = 0.0;
  for (int f = 0; f < 45; ++f) {
    (void)w.step();
    most = std::max(most, momentum(w, 0).norm());
  }
  EXPECT_EQ(w.pieces(w.bodies()[0]), 2);
  EXPECT_LT(most, 1e-5 * mass);  // 10 um/s
}

// Cut pieces stacked under self collision stay where they rest: the bunny standing on a table
// is sliced by two horizontal blades into three slabs that rest on each other (the cuts end
// at 0.8 s, frame 200). From frame 250 on nothing touches the body: nothing may rise (the
// gravitational energy stays within 1e-4 J, 13 um of the bunny's height, of frame 250's), the
// mechanical energy stays in a band of 1e-4 J and the kinetic energy averages under 1e-5 J.
// It is a band, not a fall to round-off: contacts coming and going between voxel-sized
// surface vertices keep about 1e-6 J of kinetic energy and move the energy by up to a few
// 1e-5 J a frame (docs/algorithms.md, "Self contact in one solve", Limits). With a law that
// gave each side of a contact its share of the gap, the slabs rose by 5.6e-4 J within 200
// frames.
TEST(ContactEnergy, StackedCutPiecesStayAtRest) {
  World w = worldOf(R"({"time_step": 0.004, "gravity": [0, -9.81, 0],
    "solver": {"tolerance": 0.001, "max_iterations": 100},
    "contact": {"self_collision": true, "friction": 0.3},
    "bodies": [{"model": "bunny", "resolution": 64, "element_level": 3, "offset": [0, 0.0005, 0],
      "materials": {"default": {"young_modulus": 1e6, "poisson_ratio": 0.4, "density": 1000,
                                "damping": [20, 0.005]}}}],
    "tools": [
      {"type": "blade", "keys": [{"t": 0.1, "a": [-0.15, 0.05, 0.12], "b": [0.15, 0.05, 0.12]},
                                 {"t": 0.4, "a": [-0.15, 0.05, -0.12], "b": [0.15, 0.05, -0.12]}]},
      {"type": "blade", "keys": [{"t": 0.5, "a": [-0.15, 0.095, 0.12], "b": [0.15, 0.095, 0.12]},
                                 {"t": 0.8, "a": [-0.15, 0.095, -0.12], "b": [0.15, 0.095, -0.12]}]}],
    "obstacles": [{"type": "box", "lo": [-0.25, -0.03, -0.25], "hi": [0.25, 0, 0.25]}]})");
  for (int f = 0; f < 250; ++f) (void)w.step();
  EXPECT_GE(w.pieces(w.bodies()[0]), 3);  // the three slabs (and a speck of the bunny's base, maybe)
  const BodyEnergy start = w.energy(w.bodies()[0]);
  double highest = 0.0, risen = 0.0, kinetic = 0.0;
  for (int f = 250; f < 450; ++f) {
    const FrameReport r = w.step();
    EXPECT_EQ(r.cutLinks, 0u);
    const BodyEnergy e = w.energy(w.bodies()[0]);
    highest = std::max(highest, e.total() - start.total());
    risen = std::max(risen, e.gravitational - start.gravitational);
    if (f >= 350) kinetic += e.kinetic / 100.0;
  }
  EXPECT_LT(risen, 1e-4);    // 13 um for the 0.8 kg bunny
  EXPECT_LT(highest, 1e-4);  // a jitter band, not a climb
  EXPECT_LT(kinetic, 1e-5);  // the last 100 frames' mean
}

}  // namespace
}  // namespace voxcut
