// The camera registered against the cell's known geometry: a fixed camera that was bumped (its
// mount knocked by millimetres and a degree or two) no longer sits where its extrinsics put it, and
// every point it sees lands off by up to centimetres. The cell's static parts (table, bins, tray:
// boxes the planner knows) are where the cell's description puts them, so the depth image itself
// says where the camera is: a point-to-plane ICP of the image's points against those boxes'
// surfaces, over the camera's six degrees of freedom. The table's top pins height and tilt; the
// walls' faces and top edges pin x, y and the turn about the vertical.
//   points (spread evenly, and every pixel at a depth jump on a finer grid) -> world through the
//   current estimate -> those over the bin above its floor dropped (objects, not the cell) -> each
//   matched to a box's surface: the nearest one while the gate is wide (5 cm, 2.5 cm), the one its
//   pixel's ray meets first at the last gate (1.25 cm), a point just outside a box that its ray
//   does not explain to that box's nearest point -> a Gauss-Newton step of the small rotation about
//   the camera's centre and translation, Huber-weighted -> at each gate until a step moves the
//   bin's corners less than the tolerance (matches that keep cycling: 15 iterations, and the last
//   step within ten times the tolerance).
// The same fit, started from the extrinsics held with the last gate and fewer points, checks each
// frame: a correction moving the bin by more than a few millimetres means the camera has moved.
// The fit is refused when too few points match, their residual is large, it does not settle, or
// the cell's geometry leaves a direction of motion unconstrained (the normal equations' smallest
// eigenvalue against their largest).
#pragma once
#include <string>
#include <vector>

#include "core/camera.h"
#include "core/geometry.h"

namespace mm {

struct CellRegistrationOptions {
  Pose T_world_bin = Pose::Identity();  ///< the bin: frame on its floor (what is inside, above it, is not the cell)
  Vec3 bin_half = Vec3::Zero();         ///< its footprint half sizes (x, y) [m]
  double bin_height = 0.1;              ///< [m] how high what is seen in it reaches (the crop's height)
  int points = 20000;                   ///< about this many of the image's points, spread evenly
  double first_gate = 0.05;             ///< [m] points farther from the cell's surfaces are not matched, at first
  double last_gate = 0.0125;            ///< [m] the gate halves down to this, each time the fit has settled
  int max_iterations = 100;
  double tolerance = 2e-5;              ///< [m] a fit has settled at a gate when a step moves the bin's corners less
  int min_points = 1000;                ///< matched points needed
  double depth_sigma_k = 0.0015;        ///< the sensor's depth noise, sigma = k z^2 [1/m]: the residual allowed is 1.5 sigma + 1 mm
  double huber = 0.002;                 ///< [m]
};

struct CellRegistration {
  bool ok = false;
  bool blind = false;  ///< less than a tenth of the image has depth: nothing to tell by (a blackout)
  std::string reason;
  Pose T_world_camera = Pose::Identity();  ///< the camera where the cell's geometry puts it
  double rotation = 0;     ///< [rad] the correction's angle, from the extrinsics it started from
  double translation = 0;  ///< [m] how far the camera's centre moved from where they put it
  double bin_shift = 0;    ///< [m] the farthest the correction moves a corner of the bin (floor and crop height; without a bin, the points' centroid)
  int points = 0;          ///< matched at the end
  double rms = 0;          ///< [m] their point-to-plane residual
  int iterations = 0;
  double max_rms = 0;      ///< [m] the residual allowed, from the sensor's noise at the points' depths
};

/// The same options for the check of a frame: started near the extrinsics (matched along the
/// rays from the first iteration), 3000 points and the pixels at depth jumps, settled at 0.1 mm.
CellRegistrationOptions checkOptions(CellRegistrationOptions options);

/// Registers frame's camera (its depth; frame.camera.T_world_camera the starting extrinsics)
/// against the static boxes of the cell (other shapes are not used).
CellRegistration registerCameraToCell(const Frame& frame, const std::vector<Obstacle>& statics,
                                      const CellRegistrationOptions& options);

}  // namespace mm
