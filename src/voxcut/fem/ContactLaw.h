#pragma once
/// @file ContactLaw.h
/// The contact law of the implicit step, in one place for every user: the penalty spring
/// along a normal with its friction damper, for a point pressed against something
/// (PointContact) and for two points of the body pressed together (PairContact); what the
/// step's assembly adds for each (StepAssembly.h), how a pair splits into those terms
/// (StepContacts.h), and the forces read back at the step's end velocities (docs/algorithms.md,
/// "Contact", "Friction" and "Self contact in one solve").
///
/// Weights are a point's 8 trilinear weights in its element (corner order of HexElement.h),
/// velocities are per node (m/s), dt the step (s).
///
/// Thread-safety: every function here is pure (no shared state).

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

#include "voxcut/core/Types.h"

namespace voxcut {

/// A point of the body pressed against something by a penalty spring along a fixed normal
/// for one step (docs/algorithms.md, "Contact"): the force on the point is
/// f = -stiffness (gap + n . (u - u0)) n, u - u0 its displacement during the step, taken into
/// the implicit step with its stiffness (so contact is as stable as the elastic forces), and
/// spread to the element's corners with the point's trilinear weights. Friction, where given,
/// is a tangential damper toward the velocity of what is pressed on, also implicit:
/// f_t = -friction (I - n n^T) (v_p - surfaceVelocity) at the step's end velocity (the caller
/// sets friction = mu f_n / max(|v_t|, eps), a regularised Coulomb law; docs/algorithms.md,
/// "Friction").
struct PointContact {
  std::uint32_t element = 0;              ///< element (copy) holding the point
  std::array<double, 8> weight{};         ///< the point's trilinear weights in it, summing to 1
  Vec3d normal = Vec3d::UnitY();          ///< unit, pointing out of what is pressed on
  double gap = 0.0;                       ///< signed distance along normal at the step's start (m)
  double stiffness = 0.0;                 ///< penalty stiffness (N/m), >= 0
  double friction = 0.0;                  ///< tangential damping (N s/m), >= 0
  Vec3d surfaceVelocity = Vec3d::Zero();  ///< of what is pressed on (m/s; its tangential part)
};

/// A spring between two points of the body (self contact: a surface vertex pressed into
/// another part of the same body, docs/algorithms.md, "Self contact in one solve"), taken
/// into the implicit step whole: the force on point a is
/// f = -stiffness (gap + dt n . (v_a - v_b)) n at the step's end velocities, and -f on point
/// b, with friction -friction (I - n n^T)(v_a - v_b) on a and its opposite on b. Equal and
/// opposite by construction, so the pair moves no momentum into the body.
struct PairContact {
  std::uint32_t element = 0;          ///< element (copy) holding point a
  std::array<double, 8> weight{};     ///< a's trilinear weights in it
  std::uint32_t other = 0;            ///< element (copy) holding point b
  std::array<double, 8> otherWeight{};  ///< b's trilinear weights in it
  Vec3d normal = Vec3d::UnitY();      ///< unit, the direction a is pushed (out of b's material)
  double gap = 0.0;                   ///< signed distance along normal at the step's start (m)
  double stiffness = 0.0;             ///< penalty stiffness (N/m), >= 0
  double friction = 0.0;              ///< tangential damping (N s/m), >= 0
};

/// The velocity of the point with weights `weight` in the element with corner nodes `nodes`:
/// v_p = sum_c w_c velocity[nodes_c] (m/s), summed over the corners in order.
[[nodiscard]] inline Vec3d contactPointVelocity(const std::array<double, 8>& weight,
                                                const std::array<std::uint32_t, 8>& nodes,
                                                const std::vector<Vec3d>& velocity) {
  Vec3d v = Vec3d::Zero();
  for (std::size_t c = 0; c < 8; ++c) v += weight[c] * velocity[nodes[c]];
  return v;
}

/// The velocity of a pair's point a relative to its point b, v_a - v_b (m/s), `nodes` and
/// `otherNodes` the corner nodes of the pair's element and other element: one sum over the
/// corners of w_c v_a,c - w'_c v_b,c.
[[nodiscard]] inline Vec3d pairRelativeVelocity(const PairContact& p,
                                                const std::array<std::uint32_t, 8>& nodes,
                                                const std::array<std::uint32_t, 8>& otherNodes,
                                                const std::vector<Vec3d>& velocity) {
  Vec3d rel = Vec3d::Zero();
  for (std::size_t c = 0; c < 8; ++c)
    rel += p.weight[c] * velocity[nodes[c]] - p.otherWeight[c] * velocity[otherNodes[c]];
  return rel;
}

/// The spring's normal force along n at velocity v (a point's own, or a pair's relative
/// velocity): -stiffness (gap + dt n . v) (N; negative when it pulls).
[[nodiscard]] inline double contactNormalForce(double stiffness, double gap, double dt,
                                               const Vec3d& normal, const Vec3d& v) {
  return -stiffness * (gap + dt * normal.dot(v));
}

/// The friction damper's force at relative tangential velocity: -friction (rel - (n . rel) n)
/// (N), rel the point's velocity less the surface's (or a pair's relative velocity). The
/// forces read back after a step; the step's own right-hand side applies the projector as a
/// matrix instead (contactStepTerms), which rounds differently.
[[nodiscard]] inline Vec3d contactFrictionForce(double friction, const Vec3d& normal,
                                                const Vec3d& rel) {
  return -friction * (rel - normal.dot(rel) * normal);
}

/// What a point contact adds to the implicit step, linearised at the point's start velocity
/// v_p: the force at v_p (times dt in the right-hand side, like the elastic force) and the
/// matrix dt^2 k n n^T + dt c (I - n n^T) (its stiffness and damping times dt^2 and dt), both
/// spread to the element's corners with the point's weights (w_a w_c for the block of corners
/// a and c).
struct ContactStepTerms {
  double normalForce = 0.0;             ///< -k (gap + dt n . v_p), along n (N)
  bool hasFriction = false;             ///< friction > 0: frictionForce and its matrix part
  Vec3d frictionForce = Vec3d::Zero();  ///< -c (I - n n^T)(v_p - surfaceVelocity) (N)
  Eigen::Matrix3d matrix;               ///< dt^2 k n n^T + dt c (I - n n^T)
};

/// The step's terms of point contact `pc` at its start velocity `vp` (contactPointVelocity).
[[nodiscard]] inline ContactStepTerms contactStepTerms(const PointContact& pc, const Vec3d& vp,
                                                       double dt) {
  ContactStepTerms t;
  t.normalForce = contactNormalForce(pc.stiffness, pc.gap, dt, pc.normal, vp);
  Eigen::Matrix3d nn = (dt * dt * pc.stiffness) * pc.normal * pc.normal.transpose();
  if (pc.friction > 0.0) {
    // The tangential damper: force -c P (v_p - u), P = I - n n^T, matrix dt c P.
    const Eigen::Matrix3d tangent = Eigen::Matrix3d::Identity() - pc.normal * pc.normal.transpose();
    const Vec3d ft = -pc.friction * (tangent * (vp - pc.surfaceVelocity));
    t.frictionForce = ft;
    t.hasFriction = true;
    nn += (dt * pc.friction) * tangent;
  }
  t.matrix = nn;
  return t;
}

/// A pair contact as two point contacts, one on each side, each against the other side moving
/// at its start velocity (`va`, `vb`: contactPointVelocity of points a and b): point a's gap
/// less dt n . v_b and surface velocity v_b, point b's normal -n, gap plus dt n . v_a and
/// surface velocity v_a. Their terms are the pair's diagonal parts s_a C s_a^T and s_b C s_b^T;
/// the cross terms are pairCouplingMatrix's.
[[nodiscard]] inline std::array<PointContact, 2> pairHalves(const PairContact& p,
                                                            const Vec3d& va, const Vec3d& vb,
                                                            double dt) {
  PointContact a;
  a.element = p.element;
  a.weight = p.weight;
  a.normal = p.normal;
  a.gap = p.gap - dt * p.normal.dot(vb);
  a.stiffness = p.stiffness;
  a.friction = p.friction;
  a.surfaceVelocity = vb;
  PointContact b = a;
  b.element = p.other;
  b.weight = p.otherWeight;
  b.normal = -p.normal;
  b.gap = p.gap + dt * p.normal.dot(va);
  b.surfaceVelocity = va;
  return {a, b};
}

/// The matrix C = dt^2 k n n^T + dt c (I - n n^T) of a pair contact, between its two sides'
/// rows (linalg/RowCoupling.h). The same matrix as contactStepTerms's, its products grouped
/// as (dt^2 k) (n n^T) rather than (dt^2 k n) n^T, which rounds differently.
[[nodiscard]] inline Eigen::Matrix3d pairCouplingMatrix(const PairContact& p, double dt) {
  const Eigen::Matrix3d nn = p.normal * p.normal.transpose();
  return (dt * dt * p.stiffness) * nn + (dt * p.friction) * (Eigen::Matrix3d::Identity() - nn);
}

}  // namespace voxcut
