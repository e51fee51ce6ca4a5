// The contact law (fem/ContactLaw.h): a point contact's step terms are the linearisation of
// its force (the matrix is dt times minus the force's derivative in the velocity), the two
// forms of the friction force agree, a pair's halves give the pair's force on each side and
// its matrix is the point contact's.

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <random>
#include <vector>

#include "voxcut/fem/ContactLaw.h"

namespace voxcut {
namespace {

constexpr double kDt = 0.004;

Vec3d randomUnit(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  return Vec3d(u(rng), u(rng), u(rng)).normalized();
}

Vec3d randomVelocity(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  return Vec3d(u(rng), u(rng), u(rng));
}

PointContact randomContact(std::mt19937& rng) {
  PointContact pc;
  pc.normal = randomUnit(rng);
  pc.gap = -1e-3;
  pc.stiffness = 2e4;
  pc.friction = 30.0;
  pc.surfaceVelocity = randomVelocity(rng);
  return pc;
}

/// The force on a point contact's point at velocity v, normal and friction together.
Vec3d totalForce(const PointContact& pc, const Vec3d& v) {
  return contactNormalForce(pc.stiffness, pc.gap, kDt, pc.normal, v) * pc.normal +
         contactFrictionForce(pc.friction, pc.normal, v - pc.surfaceVelocity);
}

TEST(ContactLaw, StepTermsAreTheForceAndItsLinearisation) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 20; ++trial) {
    const PointContact pc = randomContact(rng);
    const Vec3d v = randomVelocity(rng), dv = randomVelocity(rng);
    const ContactStepTerms t = contactStepTerms(pc, v, kDt);
    ASSERT_TRUE(t.hasFriction);
    const Vec3d f = t.normalForce * pc.normal + t.frictionForce;
    EXPECT_LT((f - totalForce(pc, v)).norm(), 1e-9 * (1.0 + f.norm()));
    // The law is linear in v: dt (f(v) - f(v + dv)) = matrix dv.
    const Vec3d change = kDt * (totalForce(pc, v) - totalForce(pc, v + dv));
    EXPECT_LT((t.matrix * dv - change).norm(), 1e-9 * (1.0 + change.norm()));
  }
  PointContact frictionless = randomContact(rng);
  frictionless.friction = 0.0;
  const ContactStepTerms t = contactStepTerms(frictionless, randomVelocity(rng), kDt);
  EXPECT_FALSE(t.hasFriction);
  EXPECT_EQ(t.frictionForce, Vec3d::Zero());
}

TEST(ContactLaw, PairHalvesGiveThePairForceOnEachSide) {
  std::mt19937 rng(7);
  const std::array<std::uint32_t, 8> nodesA{0, 1, 2, 3, 4, 5, 6, 7};
  const std::array<std::uint32_t, 8> nodesB{8, 9, 10, 11, 12, 13, 14, 15};
  for (int trial = 0; trial < 20; ++trial) {
    PairContact p;
    p.element = 0;
    p.other = 1;
    p.weight = {0.3, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1};
    p.otherWeight = {0.125, 0.125, 0.125, 0.125, 0.125, 0.125, 0.125, 0.125};
    p.normal = randomUnit(rng);
    p.gap = -2e-3;
    p.stiffness = 5e3;
    p.friction = 12.0;
    std::vector<Vec3d> velocity(16);
    for (Vec3d& v : velocity) v = randomVelocity(rng);
    const Vec3d va = contactPointVelocity(p.weight, nodesA, velocity);
    const Vec3d vb = contactPointVelocity(p.otherWeight, nodesB, velocity);
    const Vec3d rel = pairRelativeVelocity(p, nodesA, nodesB, velocity);
    EXPECT_LT((rel - (va - vb)).norm(), 1e-12);
    const std::array<PointContact, 2> halves = pairHalves(p, va, vb, kDt);
    EXPECT_EQ(halves[0].element, p.element);
    EXPECT_EQ(halves[1].element, p.other);
    // At these velocities, each half's force is the pair's on its side: +f on a, -f on b.
    const Vec3d onA = contactNormalForce(p.stiffness, p.gap, kDt, p.normal, rel) * p.normal +
                      contactFrictionForce(p.friction, p.normal, rel);
    EXPECT_LT((totalForce(halves[0], va) - onA).norm(), 1e-9 * (1.0 + onA.norm()));
    EXPECT_LT((totalForce(halves[1], vb) + onA).norm(), 1e-9 * (1.0 + onA.norm()));
    // The cross terms' matrix is each half's own.
    const Eigen::Matrix3d c = pairCouplingMatrix(p, kDt);
    for (const PointContact& h : halves)
      EXPECT_LT((contactStepTerms(h, va, kDt).matrix - c).norm(), 1e-12 * (1.0 + c.norm()));
  }
}

TEST(ContactLaw, PointVelocityInterpolatesWithTheWeights) {
  const std::array<std::uint32_t, 8> nodes{7, 6, 5, 4, 3, 2, 1, 0};
  std::vector<Vec3d> velocity(8, Vec3d(0.25, -1.0, 0.5));
  const std::array<double, 8> weight{0.5, 0.25, 0.125, 0.125, 0.0, 0.0, 0.0, 0.0};
  EXPECT_EQ(contactPointVelocity(weight, nodes, velocity), Vec3d(0.25, -1.0, 0.5));
  velocity[7] = Vec3d(1.0, 0.0, 0.0);  // node 7 is corner 0, weight 0.5
  EXPECT_EQ(contactPointVelocity(weight, nodes, velocity), Vec3d(0.625, -0.5, 0.25));
}

}  // namespace
}  // namespace voxcut
