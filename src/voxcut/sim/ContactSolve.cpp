/// @file ContactSolve.cpp
/// A body's step with its contacts (docs/algorithms.md, "Contact", the active set): solved,
/// corrected while the contact set it ends with differs from the one it was given, and its
/// contacts and forces recorded.

#include <algorithm>

#include "voxcut/sim/WorldImpl.h"

namespace voxcut {

void World::Impl::solvePhase(SimBody& b, BodyContactSet contactSet, Frame& f) {
  const Motion& motion = f.motion;
  ContactShapes& shapes = f.shapes;
  FrameReport& report = f.report;
  StageTimer time(f.ms(kObjectCollision));
  nearShapes(b, shapes);
  ActiveSetEdits edits;
  std::vector<PointContact> shapeContacts;
  std::vector<PointContact>& bodyContacts = contactSet.points;
  std::vector<PairContact>& pairs = contactSet.pairs;
  std::vector<ContactHit> hits = findContacts(b, shapes, edits, shapeContacts);
  auto setContacts = [&] {
    std::vector<PointContact> all = shapeContacts;
    all.insert(all.end(), bodyContacts.begin(), bodyContacts.end());
    b.solver.setContacts(std::move(all));
    b.solver.setPairContacts(pairs);
  };
  setContacts();

  // The step, solved again (from the same start) while the contact set it ends with differs
  // from the one it was given, a few times at most.
  constexpr int kContactPasses = 3;
  const bool touching = shapes.size() > 0 || !bodyContacts.empty() || !pairs.empty();
  const std::vector<Vec3d> startPositions =
      touching ? b.cut.deformation.positions() : std::vector<Vec3d>{};
  const std::vector<Vec3d> startVelocities =
      touching ? b.solver.velocities() : std::vector<Vec3d>{};
  // The deepest a vertex ends inside a shape, when the last active-set check measured it on the
  // step's final positions (negative: not measured).
  double deepestAtEnd = -1.0;
  for (int pass = 1;; ++pass) {
    time.next(f.ms(kDeformation));
    StepStatus status = b.solver.step(b.model, b.cut.deformation);
    time.next(f.ms(kObjectCollision));
    recordSolve(b, status, report);
    if (!touching || pass == kContactPasses) break;
    double deepest = 0.0;
    bool changed = shapes.size() > 0 && correctActiveSet(b, shapes, hits, edits, deepest);
    // Contacts with other bodies (and the body itself) that pulled: left out.
    const std::vector<double>& force = b.solver.contactForces();
    std::vector<std::uint8_t> keep(bodyContacts.size());
    for (std::size_t k = 0; k < bodyContacts.size(); ++k)
      keep[k] = !(force[hits.size() + k] < 0.0);
    const std::size_t points = bodyContacts.size();
    keepFlagged(bodyContacts, keep);
    keepFlagged(contactSet.pointOther, keep);
    keepFlagged(contactSet.pointDepth, keep);
    changed = changed || bodyContacts.size() != points;
    keep.assign(pairs.size(), 0);
    for (std::size_t k = 0; k < pairs.size(); ++k) keep[k] = !(b.solver.pairForces()[k] < 0.0);
    const std::size_t pairCount = pairs.size();
    keepFlagged(pairs, keep);
    keepFlagged(contactSet.pairDepth, keep);
    changed = changed || pairs.size() != pairCount;
    if (changed) {
      b.cut.deformation.positions() = startPositions;
      b.solver.setVelocities(startVelocities);
      hits = findContacts(b, shapes, edits, shapeContacts);
      setContacts();
    }
    if (!changed) {
      if (shapes.size() > 0) deepestAtEnd = deepest;
      break;
    }
  }
  const std::vector<double>& force = b.solver.contactForces();
  const std::vector<Vec3d>& friction = b.solver.contactFrictionForces();
  for (std::size_t k = 0; k < hits.size(); ++k) {
    const ContactHit& h = hits[k];
    // On the obstacle or probe: what the step applied, a spring that still pulls after the
    // last solve included (docs/algorithms.md, "Contact").
    const Vec3d push = -force[k] * h.normal - friction[k];
    if (h.source < obstacles.size()) {
      report.obstacleForces[h.source] += push;
    } else {
      const std::size_t ti = shapes.probeTool[h.source - obstacles.size()];
      const BladePose& p = motion.to[ti];
      report.toolReactions[ti].force += push;
      report.toolReactions[ti].torque += (h.point - 0.5 * (p.a + p.b)).cross(push);
    }
  }
  report.contacts += hits.size() + bodyContacts.size() + pairs.size();

  time.next(f.ms(kSurfaceVertices));
  updateVertexPositions(b);
  time.next(f.ms(kObjectCollision));
  recordContacts(b, shapes, hits, contactSet);
  report.maxPenetration = std::max(
      report.maxPenetration, deepestAtEnd >= 0.0 ? deepestAtEnd : deepestPenetration(b, shapes));
}

void World::Impl::recordContacts(const SimBody& b, const ContactShapes& shapes,
                                 const std::vector<ContactHit>& hits,
                                 const BodyContactSet& set) {
  const BodyId id = bodySlots.at(static_cast<std::size_t>(&b - bodies.data()));
  const std::vector<double>& force = b.solver.contactForces();
  const std::vector<Vec3d>& friction = b.solver.contactFrictionForces();
  for (std::size_t k = 0; k < hits.size(); ++k) {
    const ContactHit& h = hits[k];
    Contact c;
    c.body = id;
    if (h.source < obstacles.size()) {
      c.with = Contact::With::Obstacle;
      c.obstacle = obstacleSlots.at(h.source);
    } else {
      c.with = Contact::With::Probe;
      c.tool = toolSlots.at(shapes.probeTool[h.source - obstacles.size()]);
    }
    c.point = b.vertexPositions[h.vertex];
    c.normal = h.normal;
    c.depth = h.normal.dot(h.point - c.point);
    c.force = force[k] * h.normal + friction[k];
    contacts.push_back(c);
  }
  // A contact with another body or the body itself, at a point of one of its elements.
  auto between = [&](Contact::With with, BodyId other, std::uint32_t element,
                     const std::array<double, 8>& weight, const Vec3d& normal, double depth,
                     const Vec3d& f) {
    Contact c;
    c.body = id;
    c.with = with;
    c.other = other;
    c.point = pointAt(b, element, weight);
    c.normal = normal;
    c.depth = depth;
    c.force = f;
    contacts.push_back(c);
  };
  for (std::size_t k = 0; k < set.points.size(); ++k) {
    const PointContact& p = set.points[k];
    between(Contact::With::Body, bodySlots.at(set.pointOther[k]), p.element, p.weight, p.normal,
            set.pointDepth[k], force[hits.size() + k] * p.normal + friction[hits.size() + k]);
  }
  for (std::size_t k = 0; k < set.pairs.size(); ++k) {
    const PairContact& p = set.pairs[k];
    between(Contact::With::Self, id, p.element, p.weight, p.normal, set.pairDepth[k],
            b.solver.pairForces()[k] * p.normal + b.solver.pairFrictionForces()[k]);
  }
}

// The solve's counts in the frame's report; a diverged solve fails the step (StepError).
void World::Impl::recordSolve(const SimBody& b, StepStatus& status, FrameReport& report) const {
  const auto position = static_cast<std::size_t>(&b - bodies.data());
  const BodyId id = bodySlots.at(position);
  if (frame == failFrame && id == failBody) status.finite = false;  // sim/WorldTesting.h
  report.solverIterations += status.iterations;
  report.solverSolves += 1;
  report.solverFactorisations += status.factorised ? 1 : 0;
  report.converged = report.converged && status.converged;
  if (!status.finite)
    throw StepError(prefix() + "frame " + std::to_string(frame) + ": body " +
                        std::to_string(position) +
                        ": a node position became non-finite (the solve diverged); the world is "
                        "as before the frame; try a smaller time_step or stiffer solver settings",
                    id, frame);
}

}  // namespace voxcut
