#include "SoakInteraction.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace voxcut::app {

namespace {

/// Episodes by name, in the order of the weights below.
enum Episode {
  kIdle,
  kThroughCut,
  kHorizontalCut,
  kSliver,
  kZigzag,
  kPartialCut,
  kCrossCut,
  kLowCut,
  kDoubleCut,
  kPoke,
  kDrag,
  kPressCutFace,
  kCutWhilePressing,
  kEpisodeCount
};

/// How often each episode is drawn, relative to the others (an episode that cannot run, such
/// as a double cut with one blade, is drawn again).
constexpr int kWeights[kEpisodeCount] = {6, 14, 8, 8, 8, 10, 8, 6, 6, 8, 8, 6, 6};

/// Frames the body settles on the floor before the first episode.
constexpr int kSettleFrames = 10;

/// Blades move 0.8 to 3 voxels a frame, probes 0.3 to 1.2: a hand's speeds (0.3 to 1 m/s for
/// a blade through the bunny at resolution 101 and 4 ms frames).
constexpr double kBladeSpeed[2] = {0.8, 3.0};
constexpr double kProbeSpeed[2] = {0.3, 1.2};
constexpr int kMaxLegFrames = 400;

double height(const Vec3d& x, const Vec3d& up) {
  return x.dot(up);
}

Vec3d flat(const Vec3d& x, const Vec3d& up) {
  return x - up * x.dot(up);
}

BladePose lerp(const BladePose& p, const BladePose& q, double s) {
  return {p.a + s * (q.a - p.a), p.b + s * (q.b - p.b)};
}

}  // namespace

struct SoakInteraction::Target {
  std::vector<Vec3d> points;        ///< live surface vertices, in slot order
  std::vector<Vec3d> normals;       ///< theirs, unit (up where a vertex has none)
  std::vector<std::size_t> onCuts;  ///< indices into points of vertices on cut faces
  double bottom = 0.0, top = 0.0;   ///< lowest and highest point, along up
  double size = 0.0;                ///< the longest side of the points' bounding box
  Vec3d centre = Vec3d::Zero();     ///< of the points' bounding box

  /// The range of `points` along `axis` (unit): {min, max}.
  [[nodiscard]] std::pair<double, double> range(const Vec3d& axis) const {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const Vec3d& p : points) {
      lo = std::min(lo, p.dot(axis));
      hi = std::max(hi, p.dot(axis));
    }
    return {lo, hi};
  }
};

const std::vector<std::string>& SoakInteraction::episodeNames() {
  static const std::vector<std::string> names{
      "idle",        "through-cut",    "horizontal-cut",    "sliver",     "zigzag",
      "partial-cut", "cross-cut",      "low-cut",           "double-cut", "poke",
      "drag",        "press-cut-face", "cut-while-pressing"};
  return names;
}

SoakInteraction::SoakInteraction(World& world, BodyId body,
                                 const SoakInteractionParams& params)
    : random_(params.seed), body_(body) {
  up_ = Vec3d::Unit(params.upAxis);
  side1_ = Vec3d::Unit((params.upAxis + 1) % 3);
  side2_ = Vec3d::Unit((params.upAxis + 2) % 3);
  voxel_ = world.bodyInfo(body).voxelSize;
  const Target t = target(world);
  probeRadius_ = std::max(0.06 * t.size, 1.5 * voxel_);
  // A sphere or a capsule up to twice as long as it is thick, drawn from the seed.
  probeHalfLength_ = random_.chance(0.5) ? 0.0 : random_.uniform(0.5, 2.0) * probeRadius_;
  const int blades = params.blades > 0 ? params.blades : random_.integer(1, 3);
  // Parked high above the body, apart from each other, where nothing reaches them.
  const Vec3d centre = flat(t.centre, up_);
  const auto park = [&](int k) {
    const Vec3d p = centre + up_ * (t.top + 3.0 * t.size) + side1_ * (k * 0.5 * t.size);
    return BladePose{p, p + side2_ * (0.25 * t.size)};
  };
  for (int k = 0; k < blades; ++k) {
    parked_.push_back(park(k));
    blades_.push_back(world.addBlade(parked_.back()));
  }
  const Vec3d p = park(blades).a;
  parked_.push_back({p, p + side2_ * (2.0 * probeHalfLength_)});
  probe_ = world.addProbe(probeRadius_, parked_.back());
  episodeName_ = episodeNames()[kIdle];
  episodeFrames_ = kSettleFrames;
}

SoakInteraction::Target SoakInteraction::target(World& world) const {
  const SurfaceView view = world.surface(body_);
  std::vector<char> live(view.positions.size(), 0), cut(view.positions.size(), 0);
  for (std::size_t f = 0; f < view.triangles.size(); ++f) {
    const std::array<int, 3>& tri = view.triangles[f];
    if (tri[0] < 0) continue;
    for (int v : tri) {
      live[static_cast<std::size_t>(v)] = 1;
      if (view.triangleTags[f].cut != 0) cut[static_cast<std::size_t>(v)] = 1;
    }
  }
  Target t;
  Eigen::AlignedBox3d box;
  for (std::size_t v = 0; v < live.size(); ++v) {
    if (live[v] == 0) continue;
    if (cut[v] != 0) t.onCuts.push_back(t.points.size());
    t.points.push_back(view.positions[v]);
    const Vec3d n = view.normals[v];
    t.normals.push_back(n.norm() > 0.5 ? n.normalized() : up_);
    box.extend(view.positions[v]);
  }
  if (t.points.empty()) {
    // A body with no surface left: aim at where it started.
    t.points.push_back(Vec3d::Zero());
    t.normals.push_back(up_);
    box.extend(Vec3d::Zero());
  }
  t.size = std::max(box.sizes().maxCoeff(), 4.0 * voxel_);
  t.centre = box.center();
  std::tie(t.bottom, t.top) = t.range(up_);
  return t;
}

Vec3d SoakInteraction::horizontal(double angle) const {
  return std::cos(angle) * side1_ + std::sin(angle) * side2_;
}

ToolId SoakInteraction::pickBlade() {
  return blades_[static_cast<std::size_t>(random_.integer(0, blades() - 1))];
}

int SoakInteraction::framesFor(double distance, double speedVoxels) const {
  const double frames = std::ceil(distance / (speedVoxels * voxel_));
  return static_cast<int>(std::clamp(frames, 1.0, static_cast<double>(kMaxLegFrames)));
}

SoakInteraction::Motion SoakInteraction::verticalCut(const Target& t, ToolId blade,
                                                     const Vec3d& through, const Vec3d& edge,
                                                     double lengthScale, double depthFraction,
                                                     bool withdraw) {
  const Vec3d across = up_.cross(edge);
  const double margin = 2.0 * voxel_;
  // Half the edge: long enough to reach across everything at lengthScale 1.
  const double half = lengthScale * t.size + margin;
  const double slant = random_.uniform(-0.25, 0.25) * std::min(half, t.size);
  // The material under the edge: the points within its reach and a few voxels of its plane.
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const Vec3d& p : t.points) {
    const Vec3d d = flat(p - through, up_);
    if (std::abs(d.dot(edge)) <= half && std::abs(d.dot(across)) <= 4.0 * voxel_) {
      lo = std::min(lo, height(p, up_));
      hi = std::max(hi, height(p, up_));
    }
  }
  if (lo > hi) std::tie(lo, hi) = std::pair(t.bottom, t.top);
  const double above = hi + std::abs(slant) + margin;
  const double drop = depthFraction >= 1.0 ? above - (lo - std::abs(slant) - margin)
                                           : std::abs(slant) + margin + depthFraction * (hi - lo);
  const double lean = random_.uniform(-0.3, 0.3) * drop;
  const Vec3d c0 = flat(through, up_) + up_ * above;
  const Vec3d c1 = c0 - up_ * drop + across * lean;
  const auto pose = [&](const Vec3d& c) {
    return BladePose{c - edge * half + up_ * slant, c + edge * half - up_ * slant};
  };
  const double speed = random_.uniform(kBladeSpeed[0], kBladeSpeed[1]);
  Motion m{blade, pose(c0), {{pose(c1), framesFor((c1 - c0).norm(), speed)}}};
  if (withdraw) {
    m.legs.push_back({pose(c1), random_.integer(1, 15)});
    m.legs.push_back({pose(c0), framesFor((c1 - c0).norm(), speed)});
  }
  lastCutEdge_ = edge;
  return m;
}

SoakInteraction::Motion SoakInteraction::horizontalCut(const Target& t, ToolId blade,
                                                       double level) {
  const Vec3d edge = horizontal(random_.uniform(0.0, 2.0 * std::numbers::pi));
  const Vec3d across = up_.cross(edge);
  const double margin = 2.0 * voxel_;
  const auto [e0, e1] = t.range(edge);
  const auto [n0, n1] = t.range(across);
  const double half = 0.5 * (e1 - e0) + margin;
  const double slant = random_.uniform(-1.5, 1.5) * voxel_;
  const double rise = random_.uniform(-0.1, 0.1) * (t.top - t.bottom);
  const Vec3d mid = edge * (0.5 * (e0 + e1)) + up_ * level;
  const Vec3d c0 = mid + across * (n1 + margin), c1 = mid + across * (n0 - margin) + up_ * rise;
  const auto pose = [&](const Vec3d& c) {
    return BladePose{c - edge * half + up_ * slant, c + edge * half - up_ * slant};
  };
  const double speed = random_.uniform(kBladeSpeed[0], kBladeSpeed[1]);
  return {blade, pose(c0), {{pose(c1), framesFor((c1 - c0).norm(), speed)}}};
}

SoakInteraction::Motion SoakInteraction::zigzagCut(const Target& t, ToolId blade) {
  const Vec3d through =
      t.points[static_cast<std::size_t>(random_.integer(0, static_cast<int>(t.points.size()) - 1))];
  const Vec3d edge = horizontal(random_.uniform(0.0, 2.0 * std::numbers::pi));
  const Vec3d across = up_.cross(edge);
  // A straight cut's start and end, then the way between in legs that swing to either side.
  Motion m = verticalCut(t, blade, through, edge, 1.0, 1.0, false);
  const BladePose end = m.legs.front().to;
  const int legs = random_.integer(4, 10);
  const double amplitude = random_.uniform(1.0, 4.0) * voxel_;
  const double speed = random_.uniform(kBladeSpeed[0], kBladeSpeed[1]);
  m.legs.clear();
  BladePose from = m.start;
  for (int k = 1; k <= legs; ++k) {
    BladePose to = lerp(m.start, end, static_cast<double>(k) / legs);
    if (k < legs) {
      const Vec3d swing = across * (k % 2 == 1 ? amplitude : -amplitude);
      to = {to.a + swing, to.b + swing};
    }
    m.legs.push_back({to, framesFor(((to.a + to.b) - (from.a + from.b)).norm() / 2, speed)});
    from = to;
  }
  return m;
}

SoakInteraction::Motion SoakInteraction::sliverCut(const Target& t, ToolId blade) {
  const Vec3d edge = horizontal(random_.uniform(0.0, 2.0 * std::numbers::pi));
  const Vec3d across = up_.cross(edge);
  const auto [n0, n1] = t.range(across);
  const auto [e0, e1] = t.range(edge);
  // One to three voxels in from the outermost point on one side.
  const double depth = random_.uniform(1.0, 3.0) * voxel_;
  const double offset = random_.chance(0.5) ? n1 - depth : n0 + depth;
  const Vec3d through = across * offset + edge * (0.5 * (e0 + e1));
  return verticalCut(t, blade, through, edge, 1.0, 1.0, false);
}

SoakInteraction::Motion SoakInteraction::probeMotion(const Target& t, bool drag, bool cutFace) {
  const int count = static_cast<int>(t.points.size());
  std::size_t v = static_cast<std::size_t>(random_.integer(0, count - 1));
  if (cutFace && !t.onCuts.empty()) {
    v = t.onCuts[static_cast<std::size_t>(
        random_.integer(0, static_cast<int>(t.onCuts.size()) - 1))];
  } else {
    // Not from under the floor: a few draws for a point that does not face down.
    for (int k = 0; k < 16 && t.normals[v].dot(up_) < -0.3; ++k)
      v = static_cast<std::size_t>(random_.integer(0, count - 1));
  }
  const Vec3d x = t.points[v];
  const Vec3d n = t.normals[v].dot(up_) < -0.3 ? up_ : t.normals[v];
  Vec3d axis = n.cross(up_);
  axis = axis.norm() > 1e-6 ? axis.normalized() : side1_;
  const auto pose = [&](const Vec3d& c) {
    return BladePose{c - axis * probeHalfLength_, c + axis * probeHalfLength_};
  };
  const double r = probeRadius_;
  const double deepest = std::max(2.0 * voxel_, (cutFace ? 0.2 : 0.12) * t.size);
  const double depth = random_.uniform(1.0 * voxel_, deepest);
  const Vec3d out = x + n * (r + 3.0 * voxel_), in = x + n * (r - depth);
  const double speed = random_.uniform(kProbeSpeed[0], kProbeSpeed[1]);
  Motion m{probe_, pose(out), {{pose(in), framesFor((in - out).norm(), speed)}}};
  m.legs.push_back({pose(in), random_.integer(0, 40)});
  Vec3d last = in;
  if (drag) {
    Vec3d along = horizontal(random_.uniform(0.0, 2.0 * std::numbers::pi));
    along -= n * along.dot(n);
    along = along.norm() > 1e-6 ? along.normalized() : axis;
    last = in + along * (random_.uniform(0.1, 0.35) * t.size);
    m.legs.push_back({pose(last), framesFor((last - in).norm(), speed)});
  }
  const Vec3d away = last + n * (depth + 3.0 * voxel_);
  m.legs.push_back({pose(away), framesFor((away - last).norm(), speed)});
  return m;
}

void SoakInteraction::startEpisode(World& world) {
  const Target t = target(world);
  const int count = static_cast<int>(t.points.size());
  const auto point = [&] {
    return t.points[static_cast<std::size_t>(random_.integer(0, count - 1))];
  };
  const auto direction = [&] { return horizontal(random_.uniform(0.0, 2.0 * std::numbers::pi)); };
  int total = 0;
  for (int w : kWeights) total += w;
  Episode e = kIdle;
  for (;;) {
    int draw = random_.integer(0, total - 1);
    int k = 0;
    while (draw >= kWeights[k]) draw -= kWeights[k++];
    e = static_cast<Episode>(k);
    if (e == kDoubleCut && blades() < 2) continue;
    if (e == kCrossCut && lastCutEdge_.isZero()) continue;
    break;
  }
  motions_.clear();
  episodeFrames_ = 0;
  switch (e) {
    case kIdle:
      episodeFrames_ = random_.integer(20, 80);
      break;
    case kThroughCut:
      motions_.push_back(verticalCut(t, pickBlade(), point(), direction(), 1.0, 1.0, false));
      break;
    case kHorizontalCut:
      motions_.push_back(horizontalCut(t, pickBlade(), height(point(), up_)));
      break;
    case kSliver:
      motions_.push_back(sliverCut(t, pickBlade()));
      break;
    case kZigzag:
      motions_.push_back(zigzagCut(t, pickBlade()));
      break;
    case kPartialCut: {
      const ToolId blade = pickBlade();
      const Vec3d through = point();
      const Vec3d edge = direction();
      const double length = random_.uniform(0.15, 0.35);
      const double depth = random_.uniform(0.3, 0.7);
      motions_.push_back(verticalCut(t, blade, through, edge, length, depth, true));
      break;
    }
    case kCrossCut: {
      // Across the last vertical cut, through a point on a cut face where there is one.
      const Vec3d last = lastCutEdge_;
      const ToolId blade = pickBlade();
      const Vec3d through = t.onCuts.empty()
                                ? point()
                                : t.points[t.onCuts[static_cast<std::size_t>(
                                      random_.integer(0, static_cast<int>(t.onCuts.size()) - 1))]];
      const double turn = 0.5 * std::numbers::pi + random_.uniform(-0.35, 0.35);
      const Vec3d edge = std::cos(turn) * last + std::sin(turn) * up_.cross(last);
      motions_.push_back(verticalCut(t, blade, through, edge, 1.0, 1.0, false));
      break;
    }
    case kLowCut:
      // Near the floor, where fallen pieces lie.
      motions_.push_back(
          horizontalCut(t, pickBlade(), t.bottom + random_.uniform(1.5, 4.0) * voxel_));
      break;
    case kDoubleCut: {
      const ToolId first = pickBlade();
      ToolId second = pickBlade();
      while (second == first) second = pickBlade();
      const Vec3d edge = direction();
      const Vec3d p = point(), q = point();
      motions_.push_back(verticalCut(t, first, p, edge, 1.0, 1.0, false));
      motions_.push_back(verticalCut(t, second, q, up_.cross(edge), 1.0, 1.0, false));
      break;
    }
    case kPoke:
      motions_.push_back(probeMotion(t, false, false));
      break;
    case kDrag:
      motions_.push_back(probeMotion(t, true, false));
      break;
    case kPressCutFace:
      motions_.push_back(probeMotion(t, false, true));
      break;
    case kCutWhilePressing: {
      Motion press = probeMotion(t, false, false);
      Motion cut = verticalCut(t, pickBlade(), point(), direction(), 1.0, 1.0, false);
      // The probe holds while the blade cuts.
      int cutFrames = 0;
      for (const Leg& l : cut.legs) cutFrames += l.frames;
      press.legs[1].frames = std::max(press.legs[1].frames, cutFrames);
      motions_.push_back(std::move(press));
      motions_.push_back(std::move(cut));
      break;
    }
    case kEpisodeCount:
      break;
  }
  episodeName_ = episodeNames()[e];
  for (const Motion& m : motions_) {
    int frames = 0;
    for (const Leg& l : m.legs) frames += l.frames;
    episodeFrames_ = std::max(episodeFrames_, frames);
    world.placeTool(m.tool, m.start);
  }
  episodeFrame_ = 0;
}

void SoakInteraction::beforeStep(World& world) {
  if (episodeFrame_ >= episodeFrames_) {
    for (const Motion& m : motions_) {
      // parked_ holds the blades' places in order, then the probe's.
      const auto blade = std::find(blades_.begin(), blades_.end(), m.tool);
      world.placeTool(m.tool, parked_[static_cast<std::size_t>(blade - blades_.begin())]);
    }
    startEpisode(world);
  }
  ++episodeFrame_;
  // Each moving tool's pose at the end of this frame: along the leg the frame ends in.
  for (const Motion& m : motions_) {
    BladePose from = m.start, pose = m.start;
    int begin = 0;
    for (const Leg& l : m.legs) {
      pose = l.to;
      if (episodeFrame_ <= begin + l.frames) {
        pose = lerp(from, l.to, static_cast<double>(episodeFrame_ - begin) / l.frames);
        break;
      }
      begin += l.frames;
      from = l.to;
    }
    world.setToolPose(m.tool, pose);
  }
}

}  // namespace voxcut::app
