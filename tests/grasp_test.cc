#include "grasp/grasp.h"

#include <gmock/gmock.h>
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
  const auto c = graspCandidates(cube(0.3), 0.0, Vec3::Zero(), {}, GraspOptions{});
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
  const auto grasps = graspCandidates(leaning, 0.0, Vec3::Zero(), {}, GraspOptions{});
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
  EXPECT_TRUE(graspCandidates(tilted, 0.0, Vec3::Zero(), {}, GraspOptions{}).empty());
  ObjectState wide = cube(0.0);
  wide.half_size = Vec3(0.05, 0.05, 0.02);  // 10 cm across: wider than the 8 cm stroke
  EXPECT_TRUE(graspCandidates(wide, 0.0, Vec3::Zero(), {}, GraspOptions{}).empty());
}


// ---- force closure: textbook cases ----------------------------------------------------------

// Antipodal contacts on parallel faces: the line between them is along both normals, so any
// friction closes the grasp (and none does not: the margin is zero, not positive).
TEST(ForceClosure, AntipodalContactsCloseWithAnyFriction) {
  const Vec3 p1(-0.02, 0, 0), p2(0.02, 0, 0), n1(1, 0, 0), n2(-1, 0, 0);
  for (double mu : {0.05, 0.5, 1.5}) EXPECT_NEAR(forceClosureMargin(p1, n1, p2, n2, mu), std::atan(mu), 1e-12) << mu;
  EXPECT_LE(forceClosureMargin(p1, n1, p2, n2, 0.0), 0.0);
}

// A wedge of half angle alpha squeezed by a parallel jaw: each contact normal is alpha off the
// line between the contacts, so the grasp holds iff mu > tan(alpha).
TEST(ForceClosure, AWedgeHoldsIffFrictionExceedsTanAlpha) {
  const double alpha = 20.0 * M_PI / 180;
  const Vec3 p1(-0.02, 0, 0), p2(0.02, 0, 0);
  const Vec3 n1(std::cos(alpha), std::sin(alpha), 0), n2(-std::cos(alpha), std::sin(alpha), 0);
  EXPECT_LT(forceClosureMargin(p1, n1, p2, n2, 0.9 * std::tan(alpha)), 0.0);
  EXPECT_GT(forceClosureMargin(p1, n1, p2, n2, 1.1 * std::tan(alpha)), 0.0);
}

// Off-axis contacts on parallel faces: the line between them leans atan(offset / distance) from
// the normals.
TEST(ForceClosure, OffAxisContactsNeedFrictionAboveTheirLean) {
  const Vec3 p1(-0.02, 0, 0), p2(0.02, 0.01, 0), n1(1, 0, 0), n2(-1, 0, 0);
  const double lean = std::atan(0.01 / 0.04);  // 14 degrees
  EXPECT_LT(forceClosureMargin(p1, n1, p2, n2, 0.9 * std::tan(lean)), 0.0);
  EXPECT_GT(forceClosureMargin(p1, n1, p2, n2, 1.1 * std::tan(lean)), 0.0);
}

// A jaw closing on a cylinder off its axis by e meets the surface where the normal leans
// asin(e / r) from the closing line.
TEST(ForceClosure, AJawOffACylindersAxisLeansByAsinOfTheOffset) {
  ObjectState can;
  can.shape = ObjectShape::kCylinder;
  can.half_size = Vec3(0.03, 0.03, 0.05);
  can.T_world_object = makePose(Vec3(0.5, 0, 0.06), Mat3::Identity());
  double t1, t2;
  Vec3 n1, n2;
  const double e = 0.6 * 0.03;
  ASSERT_TRUE(lineThroughObject(can, Vec3(0.5 + e, -0.1, 0.06), Vec3::UnitY(), t1, t2, n1, n2));
  const Vec3 p1 = Vec3(0.5 + e, -0.1 + t1, 0.06), p2 = Vec3(0.5 + e, -0.1 + t2, 0.06);
  EXPECT_NEAR((p1 - can.T_world_object.translation()).head<2>().norm(), 0.03, 1e-12);
  const double lean = std::asin(0.6);
  EXPECT_NEAR(forceClosureMargin(p1, -n1, p2, -n2, 1.0), std::atan(1.0) - lean, 1e-9);
  EXPECT_LT(forceClosureMargin(p1, -n1, p2, -n2, 0.7), 0.0);  // tan(36.9 deg) = 0.75
  // Past the side: the line misses.
  EXPECT_FALSE(lineThroughObject(can, Vec3(0.5 + 0.031, -0.1, 0.06), Vec3::UnitY(), t1, t2, n1, n2));
}

// ---- candidates per shape --------------------------------------------------------------------

ObjectState upright(ObjectShape shape, const Vec3& half) {
  ObjectState o;
  o.shape = shape;
  o.half_size = half;
  o.T_world_object = makePose(Vec3(0.5, -0.25, 0.01 + half.z()), Mat3(rotZ(0.2)));
  return o;
}

// A bottle (5 cm wide, 15 cm tall): top-down at twelve yaws, no deeper than the hand body allows,
// and side grasps nearer its centre of mass, the hand horizontal and the fingers closing through
// its axis; all in force closure, the side ones with the shorter torque arm.
TEST(GraspCandidates, ABottleGetsTopDownAtAnyYawAndSideGraspsNearItsCentreOfMass) {
  const ObjectState bottle = upright(ObjectShape::kCylinder, Vec3(0.025, 0.025, 0.075));
  const GraspOptions o;
  const auto c = graspCandidates(bottle, 0.0, Vec3::Zero(), {}, o);
  int top = 0, side = 0;
  double top_arm = 0, side_arm = 1;
  const Vec3 centre = bottle.T_world_object.translation();
  for (const GraspCandidate& g : c) {
    EXPECT_TRUE(g.rejected.empty()) << g.rejected;
    EXPECT_NEAR(g.closure_margin, std::atan(o.friction), 1e-9);
    EXPECT_NEAR(g.width, 0.05, 1e-12);
    EXPECT_GT(g.contact_area, 0.0);
    const Mat3 R = g.T_world_tcp.linear();
    EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
    // The fingers close through the axis.
    const Vec3 d = centre - g.T_world_tcp.translation();
    EXPECT_NEAR((d - d.dot(R.col(1)) * R.col(1)).head<2>().norm(), 0.0, 1e-12);
    if (g.type == GraspType::kTopDown) {
      ++top;
      EXPECT_NEAR(R.col(2).z(), -1.0, 1e-12);
      // The hand body (hand_back behind the TCP) stays 1 cm above the top.
      EXPECT_NEAR(g.T_world_tcp.translation().z(), centre.z() + 0.075 - (o.hand_back - 0.01), 1e-12);
      top_arm = g.torque_arm;
    } else {
      ++side;
      EXPECT_NEAR(R.col(2).z(), 0.0, 1e-12);
      EXPECT_NEAR(R.col(1).z(), 0.0, 1e-12);
      EXPECT_NEAR(g.approach.z(), 0.0, 1e-12);
      EXPECT_GE(g.T_world_tcp.translation().z(), centre.z() - 1e-12);
      side_arm = std::min(side_arm, g.torque_arm);
    }
  }
  EXPECT_EQ(top, 12);
  EXPECT_EQ(side, 2 * o.side_azimuths);
  EXPECT_LT(side_arm, top_arm);
  // With no neighbours the side grasp sits at the centre of mass and ranks first.
  EXPECT_EQ(c.front().type, GraspType::kSide);
  EXPECT_NEAR(c.front().torque_arm, 0.0, 1e-12);
}

// Side grasps rise until the hand's underside clears the tops it sweeps over (here a 6 cm wall
// across the approach), and there are none where the pads would no longer sit on the object.
TEST(GraspCandidates, SideGraspsRiseOverWhatTheHandSweepsAndStopAtTheTop) {
  const ObjectState bottle = upright(ObjectShape::kCylinder, Vec3(0.025, 0.025, 0.075));
  GraspOptions o;
  Obstacle wall;
  wall.size = Vec3(0.005, 0.5, 0.03);
  wall.T_world = makePose(Vec3(0.3, -0.25, 0.03), Mat3::Identity());  // top at 6 cm, between the bottle and the robot
  const auto c = graspCandidates(bottle, 0.0, Vec3::Zero(), {wall}, o);
  for (const GraspCandidate& g : c) {
    if (g.type != GraspType::kSide) continue;
    if (g.approach.x() < -0.5) {  // towards the wall
      EXPECT_NEAR(g.T_world_tcp.translation().z(), 0.06 + o.hand_half_thickness + 0.005, 1e-12);
    }
  }
  const ObjectState short_can = upright(ObjectShape::kCylinder, Vec3(0.03, 0.03, 0.03));
  for (const GraspCandidate& g : graspCandidates(short_can, 0.0, Vec3::Zero(), {}, o)) EXPECT_EQ(g.type, GraspType::kTopDown);
}

// A flat box (8 x 5 x 2.5 cm) fits the 8 cm stroke only across its 5 cm side, top-down, the
// fingertips above the floor it rests on.
TEST(GraspCandidates, AFlatBoxIsGraspedTopDownAcrossItsNarrowSide) {
  const ObjectState flat = upright(ObjectShape::kBox, Vec3(0.04, 0.025, 0.0125));
  const GraspOptions o;
  const auto c = graspCandidates(flat, 0.0, Vec3::Zero(), {}, o);
  ASSERT_FALSE(c.empty());
  for (const GraspCandidate& g : c) {
    EXPECT_EQ(g.type, GraspType::kTopDown);
    EXPECT_NEAR(g.width, 0.05, 1e-12);
    EXPECT_GE(g.T_world_tcp.translation().z() + o.pad_z_max, 0.01 + 0.002 - 1e-12);
  }
}

// A cube turned 0.3 rad off a finger orientation it is grasped with: the pads meet its faces 0.3
// rad off their normals, out of force closure below tan(0.3) and kept, last, with the reason.
TEST(GraspCandidates, CandidatesOutOfForceClosureAreKeptLastWithTheReason) {
  GraspOptions o;
  o.friction = 0.2;  // atan(0.2) = 0.197 rad: the 0.3 rad offsets fail, the 0.15 ones hold
  const auto c = graspCandidates(cube(0.0), 0.0, Vec3::Zero(), {}, o);
  size_t rejected = 0;
  bool seen_rejected = false;
  for (const GraspCandidate& g : c) {
    if (!g.rejected.empty()) {
      ++rejected;
      seen_rejected = true;
      EXPECT_THAT(g.rejected, ::testing::HasSubstr("force closure"));
      EXPECT_LT(g.closure_margin, 0.0);
    } else {
      EXPECT_FALSE(seen_rejected) << "a kept candidate after a rejected one";
    }
  }
  EXPECT_EQ(rejected, 2u * 2u * 2u);  // the +-0.3 offsets of both face pairs and orientations
}

}  // namespace
}  // namespace mm
