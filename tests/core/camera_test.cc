#include "core/camera.h"

#include <gtest/gtest.h>

#include "core/rng.h"

namespace mm {

// A camera 1.2 m above a box, looking down (OpenCV's frame: z down the optical axis).
CameraModel overhead() {
  CameraModel cam;
  cam.width = 640, cam.height = 480;
  cam.fx = cam.fy = 554;
  cam.cx = 319.5, cam.cy = 239.5;
  Mat3 R;
  R << 1, 0, 0, 0, -1, 0, 0, 0, -1;
  cam.T_world_camera = makePose(Vec3(0.05, -0.02, 1.2), R);
  return cam;
}

TEST(Camera, EveryPointOfABoxProjectsInsideItsPixelRectangle) {
  const CameraModel cam = overhead();
  const Pose T_world_box = makePose(Vec3(0.1, 0.05, 0.2), Mat3(Eigen::AngleAxisd(0.3, Vec3::UnitZ())));
  const Vec3 lo(-0.2, -0.15, 0.0), hi(0.2, 0.15, 0.12);
  const PixelRect r = boxPixels(cam, T_world_box, lo, hi);
  ASSERT_LE(r.u0, r.u1);
  ASSERT_LE(r.v0, r.v1);
  EXPECT_GT(r.u0, 0) << "the box is well inside the image: a rectangle, not all of it";
  EXPECT_LT(r.u1, cam.width - 1);
  Rng rng(1);
  for (int i = 0; i < 10000; ++i) {
    const Vec3 p(rng.uniform(lo.x(), hi.x()), rng.uniform(lo.y(), hi.y()), rng.uniform(lo.z(), hi.z()));
    const Vec3 uvz = cam.project(T_world_box * p);
    ASSERT_GE(uvz.x(), r.u0);
    ASSERT_LE(uvz.x(), r.u1);
    ASSERT_GE(uvz.y(), r.v0);
    ASSERT_LE(uvz.y(), r.v1);
  }
}

TEST(Camera, ABoxReachingBehindTheCameraIsSeenThroughTheWholeImage) {
  const CameraModel cam = overhead();
  const PixelRect r = boxPixels(cam, Pose::Identity(), Vec3(-0.1, -0.1, 0.0), Vec3(0.1, 0.1, 1.5));
  EXPECT_EQ(r.u0, 0);
  EXPECT_EQ(r.v0, 0);
  EXPECT_EQ(r.u1, cam.width - 1);
  EXPECT_EQ(r.v1, cam.height - 1);
}

}  // namespace mm
