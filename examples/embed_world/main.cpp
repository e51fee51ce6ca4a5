// Embedding voxcut: a soft box held at its base 5 mm above a floor, a blade that cuts a slab off
// its side, which falls onto the floor, and a probe that presses on its top, moved frame by frame
// the way an interactive application moves them, with the surface read the way a renderer reads it.
// Everything goes through the world API (voxcut/sim/World.h); io turns a model into the voxel grid
// a body is made of.
//
// Prints a summary and exits 0, or prints what went wrong and exits 1.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <string>
#include <utility>
#include <vector>

#include "voxcut/io/SceneBodies.h"
#include "voxcut/sim/World.h"

namespace {

using voxcut::BladePose;
using voxcut::Vec3d;

// What a renderer keeps of a body's surface: its own copy of the triangle slots (an index
// buffer on the GPU, say), brought up to date from the slots that changed since the revision
// it last read. Positions and normals change every frame and would be uploaded whole.
struct RenderedSurface {
  std::vector<std::array<int, 3>> triangles;
  std::uint64_t revision = 0;
  bool empty = true;                // nothing read yet
  std::size_t copiedTriangles = 0;  // triangle slots copied over all frames
};

void updateRendered(RenderedSurface& rendered, voxcut::World& world, voxcut::BodyId body) {
  // The view reads the world in place; it stays valid until the next step().
  const voxcut::SurfaceView view = world.surface(body);
  const voxcut::SurfaceChanges changes = world.surfaceChanges(body, rendered.revision);
  rendered.triangles.resize(view.triangles.size(), {-1, -1, -1});
  if (rendered.empty || changes.full) {
    // The first read, or the reader fell too far behind: copy everything.
    std::copy(view.triangles.begin(), view.triangles.end(), rendered.triangles.begin());
    rendered.copiedTriangles += view.triangles.size();
  } else {
    // Dead slots read {-1, -1, -1}; a slot both removed and added holds its new triangle.
    for (const auto* slots : {&changes.removedTriangles, &changes.addedTriangles}) {
      for (const std::int32_t t : *slots) {
        rendered.triangles[static_cast<std::size_t>(t)] =
            view.triangles[static_cast<std::size_t>(t)];
        ++rendered.copiedTriangles;
      }
    }
  }
  rendered.revision = view.revision;
  rendered.empty = false;
}

// The voxel grid of a 10 x 6 x 8 cm box with its base at y = 0, in the world frame. The model is
// any spec of io/ModelSource.h: a built-in model ("bunny", "liver"), a primitive, or the path of
// a mesh file (OBJ, STL, PLY, OFF, or any format assimp reads).
voxcut::VoxelGrid boxGrid() {
  voxcut::Scene scene;
  scene.source = "embed_world";  // names the model in error messages
  voxcut::SceneBody box;
  box.model = "box:0.1,0.06,0.08";  // centred at the origin
  box.resolution = 24;              // voxels along the longest side: about 4.5 mm each
  box.offset = Vec3d(0.0, 0.03, 0.0);
  scene.bodies.push_back(box);
  return std::move(voxcut::voxelizeSceneBodies(scene).front());
}

// The blade's edge spans the box along z. Frames 0-39 it goes down through the side of the
// box at x = -0.035 from above to 1 cm over the floor, frames 40-64 it comes out sideways at
// that height: the slab x < -0.035 is cut off and falls onto the floor.
BladePose bladePoseAt(int frame) {
  const double down = std::clamp(frame / 40.0, 0.0, 1.0);
  const double out = std::clamp((frame - 40) / 25.0, 0.0, 1.0);
  const double x = -0.035 - 0.035 * out, y = 0.07 - 0.06 * down;
  return {Vec3d(x, y, -0.06), Vec3d(x, y, 0.06)};
}

// A probe, a sphere of 1 cm radius, starts 5 mm above the top (y = 0.06) and presses 5 mm
// into it over the first 50 frames, then holds.
constexpr double kProbeRadius = 0.01;
BladePose probePoseAt(int frame) {
  const Vec3d centre(0.025, 0.075 - 0.01 * std::min(frame / 50.0, 1.0), 0.0);
  return {centre, centre};  // a == b: a sphere; a != b: a capsule
}

int fail(const std::string& message) {
  std::fprintf(stderr, "embed_world: %s\n", message.c_str());
  return 1;
}

}  // namespace

int main() {
  try {
    voxcut::WorldSettings settings;  // 4 ms frames, gravity 9.81 m/s^2 along -y
    voxcut::World world(settings);

    // The body: coarse elements (level 2: 4 voxels a side) for speed, a soft material, and
    // its base held in place (as if glued onto a stand).
    voxcut::BodySettings bodySettings;
    bodySettings.elementLevel = 2;
    voxcut::SceneMaterial soft;
    soft.name = "default";  // a primitive's one material
    soft.youngModulus = 1e5;
    soft.poissonRatio = 0.3;
    bodySettings.materials.push_back(soft);
    bodySettings.fixed.push_back({Vec3d(-1, -1, -1), Vec3d(1, 0.002, 1)});
    // Every body, tool and obstacle is named by a typed handle: passing a tool's handle where
    // a body's is asked does not compile, and a removed one's handle is refused.
    const voxcut::BodyId body = world.addBody(boxGrid(), bodySettings);

    // The floor: the half-space below the plane y = -5 mm, which the bodies' surfaces cannot
    // enter (nor can they enter each other, or, with self collision on, themselves).
    voxcut::Obstacle floor;
    floor.type = voxcut::ObstacleType::Plane;
    floor.point = Vec3d(0.0, -0.005, 0.0);
    floor.normal = Vec3d::UnitY();
    world.addObstacle(floor);

    const voxcut::ToolId blade = world.addBlade(bladePoseAt(0));
    const voxcut::ToolId probe = world.addProbe(kProbeRadius, probePoseAt(0));

    constexpr int kFrames = 100;
    RenderedSurface rendered;
    updateRendered(rendered, world, body);
    voxcut::FrameReport report;
    double frameMs = 0.0;
    int unconverged = 0;
    for (int f = 0; f < kFrames; ++f) {
      // Where each tool should be at the end of this frame (from the user's hand, a haptic
      // device...); during the frame it moves there in a straight line.
      world.setToolPose(blade, bladePoseAt(f + 1));
      world.setToolPose(probe, probePoseAt(f + 1));
      report = world.step();
      frameMs += report.totalMs;
      if (!report.converged) ++unconverged;  // a status, not an error: the frame still ran
      updateRendered(rendered, world, body);
    }

    const voxcut::BodyInfo info = world.bodyInfo(body);
    const int pieces = world.pieces(body);
    const voxcut::ToolReaction push = world.toolReaction(probe);
    // Per obstacle in the order of world.obstacles(): the floor is the only one.
    const Vec3d floorForce = report.obstacleForces.front();
    // The contacts of the last frame, each with what touched what and its force.
    std::size_t onFloor = 0;
    for (const voxcut::Contact& c : world.contacts())
      onFloor += c.with == voxcut::Contact::With::Obstacle;
    std::printf("frames          %d (%.3f s simulated, %.2f ms a frame)\n", world.frame(),
                world.time(), frameMs / kFrames);
    std::printf("cut links       %zu\n", info.cutLinks);
    std::printf("pieces          %d\n", pieces);
    std::printf("surface         %zu triangles; %zu triangle slots copied over %d reads\n",
                info.surfaceTriangles, rendered.copiedTriangles, kFrames + 1);
    std::printf("probe force     (%.4f, %.4f, %.4f) N\n", push.force.x(), push.force.y(),
                push.force.z());
    std::printf("floor force     (%.4f, %.4f, %.4f) N (the slab's weight), %zu contacts\n",
                floorForce.x(), floorForce.y(), floorForce.z(), onFloor);
    std::printf("unconverged     %d frames\n", unconverged);

    if (info.cutLinks == 0) return fail("the blade cut no link");
    if (pieces < 2) return fail("the blade did not cut the slab off");
    if (!(push.force.y() > 0.0)) return fail("the body does not push the probe up");
    if (!(floorForce.y() < 0.0) || onFloor == 0)
      return fail("the slab does not rest on the floor");
    // A bad argument, such as a NaN pose from a device, is an InputError that changes nothing.
    try {
      world.setToolPose(probe, {Vec3d::Constant(std::nan("")), Vec3d::Zero()});
      return fail("a NaN pose was accepted");
    } catch (const voxcut::InputError&) {
    }
    const voxcut::SurfaceView view = world.surface(body);
    if (!std::equal(view.triangles.begin(), view.triangles.end(), rendered.triangles.begin(),
                    rendered.triangles.end()))
      return fail("the rendered triangles differ from the world's");
    return 0;
  } catch (const std::exception& e) {
    // Bad input (a model that cannot be read, an invalid material) is a voxcut::InputError.
    return fail(std::string("error: ") + e.what());
  }
}
