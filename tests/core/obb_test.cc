#include "core/obb.h"

#include <fcl/fcl.h>
#include <gtest/gtest.h>

#include "core/rng.h"

namespace mm {

namespace {

Mat3 randomRotation(Rng& rng) {
  Eigen::Quaterniond q(rng.normal(), rng.normal(), rng.normal(), rng.normal());
  return q.normalized().toRotationMatrix();
}

fcl::Transform3d toFcl(const OrientedBox& b) {
  fcl::Transform3d T = fcl::Transform3d::Identity();
  T.linear() = b.axes;
  T.translation() = b.centre;
  return T;
}

}  // namespace

// Against FCL's own box-box test on random pairs, near touching and turned every way (pairs within
// a micrometre of touching are left out: there either answer is right).
TEST(OrientedBoxes, OverlapAgreesWithFcl) {
  Rng rng(5);
  int overlapping = 0, apart = 0;
  for (int k = 0; k < 4000; ++k) {
    OrientedBox a, b;
    a.half = Vec3(rng.uniform(0.001, 0.05), rng.uniform(0.001, 0.05), rng.uniform(0.001, 0.05));
    b.half = Vec3(rng.uniform(0.001, 0.05), rng.uniform(0.001, 0.05), rng.uniform(0.001, 0.05));
    a.axes = randomRotation(rng);
    // Every fourth pair shares its axes (parallel edges: the cross products vanish).
    b.axes = k % 4 == 0 ? a.axes : randomRotation(rng);
    a.centre = Vec3(rng.uniform(-0.01, 0.01), rng.uniform(-0.01, 0.01), rng.uniform(-0.01, 0.01));
    b.centre = Vec3(rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1));
    fcl::Boxd ga(2 * a.half.x(), 2 * a.half.y(), 2 * a.half.z()), gb(2 * b.half.x(), 2 * b.half.y(), 2 * b.half.z());
    fcl::DistanceRequestd dreq;
    fcl::DistanceResultd dres;
    fcl::distance(&ga, toFcl(a), &gb, toFcl(b), dreq, dres);
    if (std::abs(dres.min_distance) < 1e-6) continue;
    fcl::CollisionRequestd creq;
    fcl::CollisionResultd cres;
    fcl::collide(&ga, toFcl(a), &gb, toFcl(b), creq, cres);
    const bool fcl_says = cres.isCollision();
    EXPECT_EQ(boxesOverlap(a, b), fcl_says) << "pair " << k << ", FCL distance " << dres.min_distance;
    EXPECT_EQ(boxesOverlap(b, a), fcl_says) << "pair " << k << " swapped";
    (fcl_says ? overlapping : apart) += 1;
  }
  EXPECT_GT(overlapping, 400);
  EXPECT_GT(apart, 400);
}

// Two bars turned 45 degrees about their lengths and crossed, one above the other: their nearest
// parts are two edges, and only those edges' cross product (the vertical, no face's normal)
// separates them.
TEST(OrientedBoxes, CrossedEdgesAreSeparatedByTheirCrossProduct) {
  OrientedBox a, b;
  a.half = b.half = Vec3(0.05, 0.005, 0.005);
  a.axes = Eigen::AngleAxisd(M_PI / 4, Vec3::UnitX()).toRotationMatrix();  // along x; an edge on top
  b.axes = Eigen::AngleAxisd(M_PI / 4, Vec3::UnitY()).toRotationMatrix() * Eigen::AngleAxisd(M_PI / 2, Vec3::UnitZ()).toRotationMatrix();
  const double reach = 0.005 * std::sqrt(2.0);  // each bar's edge from its axis
  b.centre = Vec3(0, 0, 2 * reach + 0.0004);
  EXPECT_FALSE(boxesOverlap(a, b));
  b.centre.z() = 2 * reach - 0.0004;
  EXPECT_TRUE(boxesOverlap(a, b));
}

}  // namespace mm
