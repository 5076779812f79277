// `minimanip calibrate`: hand-eye calibration in simulation, for both mountings.
//   eye-to-hand: the experiment's perception camera (overhead) and a ChArUco board carried on the
//                gripper (held 0.25 m beside the TCP, facing the camera);
//   eye-in-hand: the robot's wrist camera and the board lying on the table.
// The robot visits seeded poses (rotations about all three axes; the source's data rules: >= 15
// poses, >= 60 degrees of rotation coverage, the whole board in view, < 45 degrees between the
// board's normal and the optical axis), OpenCV finds the board in each rendered image (checked
// against the board's projection through the true camera), and cv::calibrateHandEye solves AX = XB
// with its five methods, without and with image noise. Each result is compared with the
// simulator's true extrinsics (rotation, translation, and how far it moves points of the bin
// floor), the AX = XB residuals are reported, and the eye-to-hand result with the smallest residual
// (chosen without the truth) is written where camera perception reads it (perception.extrinsics).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "campaign/experiment.h"

namespace mm {

struct CalibrateOptions {
  int views = 20;              ///< poses visited per mounting (at least 15)
  uint64_t seed = 1;
  double pixel_noise = 3.0;    ///< [grey levels] std of the Gaussian image noise of the noisy runs
  std::string out_dir = "results/calibration";
  std::string command_line;
};

/// Runs both mountings with and without noise; writes calibration.json, calibration.md and
/// <camera>_extrinsics.yaml into out_dir. Returns the report (Markdown).
std::string runCalibration(const Experiment& experiment, const CalibrateOptions& options);

}  // namespace mm
