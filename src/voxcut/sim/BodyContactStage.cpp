/// @file BodyContactStage.cpp
/// Contacts between bodies and of a body with itself (docs/algorithms.md, "Object collision",
/// "Self contact in one solve"): found for every pair of bodies that may touch and turned into
/// each body's point contacts and self pairs.

#include <algorithm>

#include "voxcut/sim/BodyContacts.h"
#include "voxcut/sim/WorldImpl.h"

namespace voxcut {

std::vector<BodyContactSet> World::Impl::findBodyContactsAll(Frame& f) {
  FrameReport& report = f.report;
  std::vector<BodyContactSet> out(bodies.size());
  if (bodies.size() < 2 && !settings.contact.selfCollision) return out;
  const StageTimer time(f.ms(kObjectCollision));
  const double dt = settings.timeStep;
  // Which pairs can touch: bounding boxes of the current nodes, grown by a voxel.
  std::vector<Eigen::AlignedBox3d> bounds(bodies.size());
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    for (const Vec3d& x : bodies[i].cut.deformation.positions()) bounds[i].extend(x);
    const double pad = bodies[i].cut.grid.voxelSize();
    bounds[i].extend(bounds[i].min() - Vec3d::Constant(pad));
    bounds[i].extend(bounds[i].max() + Vec3d::Constant(pad));
  }
  std::vector<LayeredHash> hashes(bodies.size());
  std::vector<std::uint8_t> hashed(bodies.size(), 0);
  // Effective inverse mass of a point with trilinear weights w in element e: sum w_c^2 / m_c
  // over its free corners (0 where every corner is fixed).
  auto inverseMass = [](const SimBody& body, std::uint32_t e, const std::array<double, 8>& w) {
    const OctreeElement& el = body.cut.deformation.element(e);
    const std::vector<std::uint8_t>& fixed = body.model.fixed();
    double sum = 0.0;
    for (std::size_t c = 0; c < 8; ++c) {
      const std::uint32_t n = el.nodes[c];
      const double m = body.model.nodeMass()[n];
      if ((n < fixed.size() && fixed[n] != 0) || !(m > 0.0)) continue;
      sum += w[c] * w[c] / m;
    }
    return sum;
  };
  for (SimBody& body : bodies) groupVerticesByElement(body, body.verticesByElement);
  for (std::size_t ib_ = 0; ib_ < bodies.size(); ++ib_)
    for (std::size_t ia_ = 0; ia_ < bodies.size(); ++ia_) {
      const bool self = ia_ == ib_;
      if (self ? !settings.contact.selfCollision : !bounds[ia_].intersects(bounds[ib_])) continue;
      const SimBody& a = bodies[ia_];
      const SimBody& b = bodies[ib_];
      if (!hashed[ib_]) {
        buildElementHash(b, hashes[ib_], settings.threaded);
        hashed[ib_] = 1;
      }
      if (self && !settings.contact.keepSelfCandidates) bodies[ia_].selfCandidates.valid = false;
      for (const BodyContactPoint& c : findBodyContacts(
               a, b, hashes[ib_], self, dt, settings.threaded,
               self ? &bodies[ia_].selfCandidates : nullptr, &bodies[ia_].verticesByElement)) {
        // The depth is the vertex's moved on by dt times its velocity relative to B's element,
        // v_p - v_e: the gap now is -depth - dt n.(v_p - v_e).
        // Each body's step sees the other at its frame-start velocity, so each closes only
        // its share of g, by inverse effective mass (all of it against fixed nodes), against
        // a contact plane that moves with the pair's mass-weighted normal velocity
        // (docs/algorithms.md, "Object collision").
        const double ia = inverseMass(a, c.element, c.weight);
        const double ib = inverseMass(b, c.other, c.otherWeight);
        if (!(ia + ib > 0.0)) continue;
        const Vec3d va = pointVelocity(a, c.element, c.weight);
        const Vec3d vb = pointVelocity(b, c.other, c.otherWeight);
        // Both bodies' vertices find the same interface (each inside the other), so each
        // contact closes half of its gap: together they close it once.
        const double gNow = -c.depth - dt * c.normal.dot(va - c.otherVelocity);
        const double g = (gNow < 0.0 ? 0.5 * kPairClosing : 0.5) * gNow;
        report.maxPenetration = std::max(report.maxPenetration, c.currentDepth);
        if (self) {
          // Within one body the pair is one spring of the body's step (docs/algorithms.md,
          // "Self contact in one solve"): equal and opposite forces.
          PairContact pc;
          pc.element = c.element;
          pc.weight = c.weight;
          pc.other = c.other;
          pc.otherWeight = c.otherWeight;
          pc.normal = c.normal;
          pc.gap = g;
          // Per vertex, the stiffness of a voxel's area against the coarser element's edge
          // rather than against a voxel: stiffer than its elements, a pair's cross terms
          // (which the preconditioner does not see) cost iterations in proportion and stop
          // no more penetration than the elements can resolve (docs/algorithms.md, "Self
          // contact in one solve").
          const int coarser = std::max(a.cut.deformation.element(c.element).size(),
                                       a.cut.deformation.element(c.other).size());
          pc.stiffness = a.contactStiffness / coarser;
          const double normalForce = pc.stiffness * std::max(0.0, -g);
          const Vec3d rel = va - vb;
          const double slip = (rel - c.normal.dot(rel) * c.normal).norm();
          if (settings.contact.friction > 0.0 && normalForce > 0.0)
            pc.friction = settings.contact.friction * normalForce / std::max(slip, kStickSpeed);
          out[ia_].pairs.push_back(pc);
          out[ia_].pairDepth.push_back(c.currentDepth);
          continue;
        }
        const double sa = ia / (ia + ib), sb = ib / (ia + ib);
        const double vpn = c.normal.dot(va);
        const double vqn = c.normal.dot(vb);
        const double plane = sb * vpn + sa * vqn;
        // Friction drags each side toward the pair's mass-weighted common velocity.
        const Vec3d common = sb * va + sa * vb;
        PointContact pa;
        pa.element = c.element;
        pa.weight = c.weight;
        pa.normal = c.normal;
        pa.gap = sa * g - dt * plane;
        pa.stiffness = a.contactStiffness;
        setFriction(pa, settings.contact.friction, -sa * g, va, common);
        out[ia_].points.push_back(pa);
        out[ia_].pointOther.push_back(ib_);
        out[ia_].pointDepth.push_back(c.currentDepth);
        PointContact pb;
        pb.element = c.other;
        pb.weight = c.otherWeight;
        pb.normal = -c.normal;
        pb.gap = sb * g + dt * plane;
        pb.stiffness = b.contactStiffness;
        setFriction(pb, settings.contact.friction, -sb * g, vb, common);
        out[ib_].points.push_back(pb);
        out[ib_].pointOther.push_back(ia_);
        out[ib_].pointDepth.push_back(c.currentDepth);
      }
    }
  return out;
}

}  // namespace voxcut
