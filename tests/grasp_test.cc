#include "grasp/grasp.h"

#include <gtest/gtest.h>

#include <cmath>

namespace mm {
namespace {

ObjectState cube(double yaw) {
  ObjectState o;
  o.name = "cube";
  o.half_size = Vec3::Constant(0.025);
  o.T_world_object = makePose(Vec3(0.5, -0.25, 0.035), Mat3(rotZ(yaw)));
  return o;
}

// A 5 cm cube at yaw 0.3: the aligned candidates close across a pair of faces (the fingers' y axis
// along a face normal), both finger orientations, sampled yaw offsets ranked below the aligned
// ones; every TCP points straight down at the cube's center.
TEST(TopDownGrasps, FacesBothOrientationsAndSampledYaw) {
  const auto c = topDownGrasps(cube(0.3), 0.0, {}, GraspOptions{});
  ASSERT_EQ(c.size(), 2u * 2u * 5u);  // 2 face pairs x 2 orientations x 5 yaw samples
  for (const auto& g : c) {
    EXPECT_NEAR(g.T_world_tcp.linear().col(2).z(), -1.0, 1e-12);
    EXPECT_LT((g.T_world_tcp.translation() - Vec3(0.5, -0.25, 0.035)).norm(), 1e-12);
    EXPECT_NEAR(g.width, 0.05, 1e-12);
  }
  // The best four are face-aligned: the finger direction is along a cube face normal.
  for (int i = 0; i < 4; ++i) {
    const Vec3 fingers = c[i].T_world_tcp.linear().col(1);
    const double along = std::max(std::abs(fingers.dot(rotZ(0.3).col(0))), std::abs(fingers.dot(rotZ(0.3).col(1))));
    EXPECT_NEAR(along, 1.0, 1e-9) << i;
  }
  for (size_t i = 1; i < c.size(); ++i) EXPECT_GE(c[i - 1].score, c[i].score);
}

TEST(TopDownGrasps, ALeaningObjectIsGraspedAcrossItsUpperFaceAlongItsNormal) {
  ObjectState leaning = cube(0.0);
  leaning.T_world_object.linear() = rotX(0.6);  // 34 degrees
  const auto grasps = topDownGrasps(leaning, 0.0, {}, GraspOptions{});
  ASSERT_FALSE(grasps.empty());
  const Vec3 normal = leaning.T_world_object.linear().col(2);  // the upper face's
  for (const GraspCandidate& g : grasps) {
    EXPECT_NEAR((g.approach - normal).norm(), 0.0, 1e-12);
    EXPECT_NEAR((g.T_world_tcp.linear().col(2) + normal).norm(), 0.0, 1e-12);  // TCP z into the face
    EXPECT_NEAR(g.T_world_tcp.linear().determinant(), 1.0, 1e-12);
    // The fingers close along one of the cube's other axes (within the yaw offsets).
    const Vec3 y = g.T_world_tcp.linear().col(1);
    EXPECT_NEAR(y.dot(normal), 0.0, 1e-12);
    const double c = std::max(std::abs(y.dot(leaning.T_world_object.linear().col(0))), std::abs(y.dot(leaning.T_world_object.linear().col(1))));
    EXPECT_GE(c, std::cos(0.3) - 1e-9);
  }
}

TEST(TopDownGrasps, ObjectsTiltedOverFiftyDegreesOrTooWideGetNone) {
  ObjectState tilted = cube(0.0);
  // Standing on a corner: every axis 54.7 degrees from the vertical.
  tilted.T_world_object.linear() = Eigen::Quaterniond::FromTwoVectors(Vec3(1, 1, 1).normalized(), Vec3::UnitZ()).toRotationMatrix();
  double up = 0;
  for (int a = 0; a < 3; ++a) up = std::max(up, std::abs(tilted.T_world_object.linear().col(a).z()));
  ASSERT_LT(up, std::cos(50.0 * M_PI / 180));
  EXPECT_TRUE(topDownGrasps(tilted, 0.0, {}, GraspOptions{}).empty());
  ObjectState wide = cube(0.0);
  wide.half_size = Vec3(0.05, 0.05, 0.02);  // 10 cm across: wider than the 8 cm stroke
  EXPECT_TRUE(topDownGrasps(wide, 0.0, {}, GraspOptions{}).empty());
}

}  // namespace
}  // namespace mm
