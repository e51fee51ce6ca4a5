#pragma once
/// @file StepContacts.h
/// The contacts of one implicit Euler step (ImplicitEuler.h; docs/algorithms.md, "Contact" and
/// "Self contact in one solve"): the point and pair contacts given for the step, each pair
/// split into a point contact on either side (its matrix's diagonal parts, assembled with the
/// elements) and cross terms between the two sides' free rows, every point contact found by
/// element for the assembly, and the forces read back at the step's end velocities. The law
/// itself is ContactLaw.h's.
///
/// Thread-safety: one step at a time per object; the const accessors may be read concurrently.

#include <cstdint>
#include <span>
#include <vector>

#include "voxcut/core/Types.h"
#include "voxcut/fem/ContactLaw.h"
#include "voxcut/fem/ElasticModel.h"
#include "voxcut/linalg/RowCoupling.h"
#include "voxcut/topology/DeformationOctree.h"

namespace voxcut {

/// The contact set of a step, from the contacts given to the forces read back.
class StepContacts {
 public:
  /// The point contacts of the next step, in any order.
  void setPoints(std::vector<PointContact> contacts) { contacts_ = std::move(contacts); }
  /// The pair contacts of the next step.
  void setPairs(std::vector<PairContact> pairs) { pairs_ = std::move(pairs); }

  /// Before the assembly, with the step's start velocities `velocity` (per node of `model`,
  /// which must match `octree`): appends each pair's halves (pairHalves) to the point
  /// contacts and adds its cross terms (pairCouplingMatrix) to coupling(), then orders the
  /// point contacts by element (stable).
  void prepare(const ElasticModel& model, const DeformationOctree& octree,
               const std::vector<Vec3d>& velocity, double dt);

  /// After prepare: the point contacts of element e (given ones and pairs' halves).
  [[nodiscard]] std::span<const PointContact> ofElement(std::size_t e) const {
    if (contacts_.empty()) return {};
    return {contacts_.data() + contactStart_[e], contacts_.data() + contactStart_[e + 1]};
  }
  /// After prepare: every point contact of the step, by element.
  [[nodiscard]] const std::vector<PointContact>& points() const { return contacts_; }
  /// Whether the next step has contacts (points or pairs).
  [[nodiscard]] bool any() const { return !contacts_.empty() || !pairs_.empty(); }
  /// After prepare: the pairs' cross terms, by free row (empty without pairs).
  [[nodiscard]] const RowCoupling& coupling() const { return coupling_; }

  /// After the step: when `finite`, reads the forces back at the end velocities `velocity`
  /// (per node), else sets them to zero; then forgets the step's contacts.
  void finish(const DeformationOctree& octree, const std::vector<Vec3d>& velocity, double dt,
              bool finite);

  /// Per point contact given for the last step, in the order given: the normal force at the
  /// step's end (contactNormalForce).
  [[nodiscard]] const std::vector<double>& normalForces() const { return contactForce_; }
  /// Per point contact given for the last step, in the order given: its friction force (N).
  [[nodiscard]] const std::vector<Vec3d>& frictionForces() const { return contactFriction_; }
  /// Per pair contact of the last step, in the order given: the normal force on point a.
  [[nodiscard]] const std::vector<double>& pairForces() const { return pairForce_; }
  /// Per pair contact of the last step, in the order given: its friction force on point a (N).
  [[nodiscard]] const std::vector<Vec3d>& pairFrictionForces() const { return pairFriction_; }

 private:
  /// The pairs' halves appended to the point contacts, their cross terms into coupling_.
  void splitPairs(const ElasticModel& model, const DeformationOctree& octree,
                  const std::vector<Vec3d>& velocity, double dt);

  std::vector<PointContact> contacts_;       ///< of the next step; by element after prepare
  std::size_t given_ = 0;                    ///< how many were given (the pairs' halves follow)
  std::vector<std::uint32_t> contactStart_;  ///< per element + 1: its contacts' range (when any)
  std::vector<std::size_t> contactOrder_;    ///< contacts_[k] was given at contactOrder_[k]
  std::vector<double> contactForce_;         ///< of the last step, in the order given
  std::vector<Vec3d> contactFriction_;       ///< of the last step, in the order given
  std::vector<PairContact> pairs_;           ///< of the next step, in the order given
  std::vector<double> pairForce_;            ///< of the last step, in the order given
  std::vector<Vec3d> pairFriction_;          ///< of the last step, in the order given
  RowCoupling coupling_;                     ///< the pairs' cross terms, by free row
};

}  // namespace voxcut
