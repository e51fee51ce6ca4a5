#pragma once
/// @file BodyContacts.h
/// Object collision between deformable bodies, and of a body with itself (docs/algorithms.md,
/// "Object collision"): surface vertices of one body found inside the material of another (or
/// of its own, away from the vertex's neighbourhood), through the spatial hash of the other
/// body's element boxes, the inverse trilinear map of the element holding the point, and the
/// other body's rest-frame distance field, so the depth stays right next to cuts. Internal to
/// World.

#include <array>
#include <cstdint>
#include <vector>

#include "voxcut/collision/LayeredHash.h"
#include "voxcut/sim/SimBody.h"

namespace voxcut {

/// A surface vertex of body A inside the material of body B (A == B for self collision).
struct BodyContactPoint {
  std::uint32_t vertex = 0;             ///< A's surface vertex slot
  std::uint32_t element = 0;            ///< A's element copy holding the vertex
  std::array<double, 8> weight{};       ///< the vertex's trilinear weights there
  std::uint32_t other = 0;              ///< B's element copy holding the point
  std::array<double, 8> otherWeight{};  ///< the point's trilinear weights there
  Vec3d normal = Vec3d::Zero();         ///< current frame, unit, out of B's material
  /// The velocity of B's element the vertex was moved against (its nodes' mean, m/s).
  Vec3d otherVelocity = Vec3d::Zero();
  double depth = 0.0;  ///< below B's boundary, in B's rest frame (m), > 0
  /// The same for the vertex where it is now, not moved on (0 when it is not inside there).
  double currentDepth = 0.0;
};

/// Brings `groups` up to date with the body's surface embedding (regrouped only after a cut).
void groupVerticesByElement(const SimBody& body, VerticesByElement& groups);

/// Boxes of every element copy of the body at its current node positions, in a spatial hash.
void buildElementHash(const SimBody& body, LayeredHash& hash, bool threaded);

/// The surface vertices of `a`, moved on by dt times their velocity relative to the element of
/// `b` they are tested against, that lie inside the
/// material of `b` (whose element boxes `bHash` holds): per vertex at most one point, the
/// deepest, within b's distance band. With self (a and b the same body) an element sharing a
/// node with the vertex's own, and a point whose voxel is joined to the vertex's voxel by at
/// most two connected links, are the vertex's own neighbourhood and skipped; the other side of
/// a cut is not. In vertex order, whatever the thread count.
/// For self, `cache` (a's own, may be null) keeps the broad phase's candidates between frames
/// and is used while still valid (SelfCandidateCache); the result is the same with or without.
/// `groups` (may be null: grouped here) are a's vertices by element, up to date.
[[nodiscard]] std::vector<BodyContactPoint> findBodyContacts(
    const SimBody& a, const SimBody& b, const LayeredHash& bHash, bool self, double dt,
    bool threaded, SelfCandidateCache* cache = nullptr, const VerticesByElement* groups = nullptr);

}  // namespace voxcut
