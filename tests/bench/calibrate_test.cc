// Hand-eye calibration in simulation (`minimanip calibrate`): the board is found where the true
// camera projects it, every method of both mountings is reported, the best recovers the true
// extrinsics closely enough to move bin-floor points by < 1 mm without image noise and < 2 mm
// with it, and camera perception reads the extrinsics it writes.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "../campaign/cli_helpers.h"
#include "perception/calibration.h"
#include "core/error.h"

namespace mm {
namespace {

using ::testing::HasSubstr;
using json = nlohmann::json;

TEST(Calibration, BothMountingsRecoverTheTrueExtrinsicsAndPerceptionUsesThem) {
  testing_cli::TempDir tmp;
  const std::string out = (tmp.path() / "calib").string();
  const auto r = testing_cli::runMinimanip("calibrate experiments/camera.yaml --views 15 --out " + out);
  ASSERT_EQ(r.code, 0) << r.out;
  const json j = json::parse(std::ifstream(out + "/calibration.json"));
  for (const char* mounting : {"eye-to-hand", "eye-in-hand"}) {
    SCOPED_TRACE(mounting);
    const json& m = j.at(mounting);
    ASSERT_FALSE(m.contains("skipped")) << m.dump();
    EXPECT_GE(m["views"].get<int>(), 15);
    EXPECT_GE(m["coverage_deg"].get<double>(), 60.0) << "rotation about all three axes, the source's 60 degrees";
    EXPECT_EQ(m["results"].size(), 10u) << "five methods, without and with noise";
    double best_clean = 1e9, best_noisy = 1e9;
    for (const json& res : m["results"])
      (res["noise"].get<bool>() ? best_noisy : best_clean) = std::min(res["noise"].get<bool>() ? best_noisy : best_clean,
                                                                       res["bin_floor_max_mm"].get<double>());
    EXPECT_LT(best_clean, 1.0);
    EXPECT_LT(best_noisy, 2.0);
  }
  EXPECT_LT(j["eye-to-hand"]["corner_error_px_rms"].get<double>(), 0.2) << "detected corners where the true camera projects them";
  // The extrinsics file, read as camera perception reads it, and a campaign through it.
  std::string camera;
  const Pose T = readExtrinsics(out + "/overhead_camera_extrinsics.yaml", &camera);
  EXPECT_EQ(camera, "overhead_camera");
  EXPECT_NEAR(T.translation().z(), 1.3, 0.01) << "the scene's camera is 1.3 m up";
  const auto run = testing_cli::runMinimanip("run experiments/camera.yaml --trials 2 --jobs 2 --set progress=none --set perception.extrinsics=" +
                                             out + "/overhead_camera_extrinsics.yaml --out " + out + "/run");
  ASSERT_EQ(run.code, 0) << run.out;
  for (const auto& t : testing_cli::readTrials(out + "/run")) EXPECT_TRUE(t["success"].get<bool>());
  // A broken extrinsics file is bad input.
  std::ofstream(out + "/bad.yaml") << "camera: overhead_camera\nposition: [0, 0]\n";
  const auto bad = testing_cli::runMinimanip("run experiments/camera.yaml --trials 1 --set perception.extrinsics=" + out +
                                             "/bad.yaml --out " + out + "/bad");
  EXPECT_EQ(bad.code, 2) << bad.out;
  EXPECT_THAT(bad.out, HasSubstr("bad.yaml"));
}

}  // namespace
}  // namespace mm
