// Oriented boxes: whether two overlap.
#pragma once
#include "core/pose.h"

namespace mm {

/// A box in the world: its centre, its axes (the rotation's columns), its half sizes [m].
struct OrientedBox {
  Vec3 centre = Vec3::Zero();
  Mat3 axes = Mat3::Identity();
  Vec3 half = Vec3::Zero();
};

/// Whether two boxes overlap (touching counts): the separating axis test over their 15 candidate
/// axes (the 3 + 3 face normals, the 9 cross products of their edges), after Gottschalk, Lin and
/// Manocha, "OBBTree", SIGGRAPH 1996, as set out in Ericson, "Real-Time Collision Detection",
/// section 4.4.1. Exact, up to an epsilon that keeps near-parallel edges from separating falsely.
bool boxesOverlap(const OrientedBox& a, const OrientedBox& b);

}  // namespace mm
