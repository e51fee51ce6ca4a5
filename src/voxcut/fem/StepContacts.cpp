#include "voxcut/fem/StepContacts.h"

#include "voxcut/core/Error.h"

namespace voxcut {

void StepContacts::splitPairs(const ElasticModel& model, const DeformationOctree& octree,
                              const std::vector<Vec3d>& velocity, double dt) {
  const WeightedRows& pr = model.prolongation();
  // A point's weights carried to the free rows through the prolongation.
  auto rowsOf = [&](std::uint32_t e, const std::array<double, 8>& w) {
    RowWeights out;
    for (std::size_t c = 0; c < 8; ++c) {
      const std::uint32_t n = octree.element(e).nodes[c];
      for (std::uint32_t k = pr.start[n]; k < pr.start[n + 1]; ++k)
        out.emplace_back(pr.index[k], w[c] * pr.weight[k]);
    }
    return out;
  };
  for (const PairContact& p : pairs_) {
    VOXCUT_ASSERT(p.element < model.elementCount() && p.other < model.elementCount(),
                  "a pair contact's element is not in the model");
    const Vec3d va = contactPointVelocity(p.weight, octree.element(p.element).nodes, velocity);
    const Vec3d vb = contactPointVelocity(p.otherWeight, octree.element(p.other).nodes, velocity);
    const std::array<PointContact, 2> halves = pairHalves(p, va, vb, dt);
    contacts_.push_back(halves[0]);
    contacts_.push_back(halves[1]);
    coupling_.add(rowsOf(p.element, p.weight), rowsOf(p.other, p.otherWeight),
                  pairCouplingMatrix(p, dt));
  }
}

void StepContacts::prepare(const ElasticModel& model, const DeformationOctree& octree,
                           const std::vector<Vec3d>& velocity, double dt) {
  given_ = contacts_.size();
  coupling_.clear();
  if (!pairs_.empty()) splitPairs(model, octree, velocity, dt);
  if (contacts_.empty()) return;
  // By element: a counting sort, stable.
  const std::size_t elements = model.elementCount();
  contactStart_.assign(elements + 1, 0);
  for (const PointContact& pc : contacts_) {
    VOXCUT_ASSERT(pc.element < elements, "a contact's element is not in the model");
    ++contactStart_[pc.element + 1];
  }
  for (std::size_t e = 0; e < elements; ++e) contactStart_[e + 1] += contactStart_[e];
  std::vector<std::uint32_t> next(contactStart_.begin(), contactStart_.end() - 1);
  std::vector<PointContact> sorted(contacts_.size());
  contactOrder_.resize(contacts_.size());
  for (std::size_t k = 0; k < contacts_.size(); ++k) {
    const std::uint32_t slot = next[contacts_[k].element]++;
    sorted[slot] = contacts_[k];
    contactOrder_[slot] = k;
  }
  contacts_.swap(sorted);
}

void StepContacts::finish(const DeformationOctree& octree, const std::vector<Vec3d>& velocity,
                          double dt, bool finite) {
  contactForce_.assign(contacts_.size(), 0.0);
  contactFriction_.assign(contacts_.size(), Vec3d::Zero());
  pairForce_.assign(pairs_.size(), 0.0);
  pairFriction_.assign(pairs_.size(), Vec3d::Zero());
  if (finite) {
    for (std::size_t k = 0; k < contacts_.size(); ++k) {
      const PointContact& pc = contacts_[k];
      const Vec3d vp = contactPointVelocity(pc.weight, octree.element(pc.element).nodes, velocity);
      contactForce_[contactOrder_[k]] = contactNormalForce(pc.stiffness, pc.gap, dt, pc.normal, vp);
      if (pc.friction > 0.0)
        contactFriction_[contactOrder_[k]] =
            contactFrictionForce(pc.friction, pc.normal, vp - pc.surfaceVelocity);
    }
    for (std::size_t k = 0; k < pairs_.size(); ++k) {
      const PairContact& p = pairs_[k];
      const Vec3d rel = pairRelativeVelocity(p, octree.element(p.element).nodes,
                                             octree.element(p.other).nodes, velocity);
      pairForce_[k] = contactNormalForce(p.stiffness, p.gap, dt, p.normal, rel);
      if (p.friction > 0.0) pairFriction_[k] = contactFrictionForce(p.friction, p.normal, rel);
    }
  }
  contactForce_.resize(given_);  // the pairs' halves came after the given contacts
  contactFriction_.resize(given_);
  contacts_.clear();
  pairs_.clear();
  coupling_.clear();
}

}  // namespace voxcut
