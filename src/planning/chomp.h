// An optimizing post-processor for any planner's path, after CHOMP (N. Ratliff, M. Zucker,
// J. A. Bagnell, S. Srinivasa, "CHOMP: Gradient Optimization Techniques for Efficient Motion
// Planning", ICRA 2009; Zucker et al., IJRR 2013): the path resampled to dense waypoints (ends
// fixed) is improved by covariant gradient descent on smoothness (squared finite-difference
// velocities and accelerations) plus an obstacle cost that pushes the robot's spheres beyond a
// desired clearance.
// The result is returned only if every edge passes the collision checker; otherwise the input.
#pragma once
#include <string>
#include <vector>

#include "planning/collision.h"
#include "robot/robot_model.h"

namespace mm {

/// Post-processors after a planner, by name: "none", "chomp".
const std::vector<std::string>& optimizerNames();

struct ChompOptions {
  int waypoints = 40;         ///< interior waypoints after resampling
  int iterations = 60;
  double clearance = 0.05;    ///< [m] desired distance of the (unpadded) spheres to obstacles
  double obstacle_weight = 10.0;
  double acceleration_weight = 1.0;  ///< squared second differences: spreads corners into curves
  double step = 0.05;         ///< 1 / eta: the covariant step size
  double resolution = 0.02;   ///< [rad] edge validation step of the result
  /// The optimized waypoints are reduced (Douglas-Peucker in joint space) to those that deviate
  /// more than this [rad] from straight segments, keeping every shortened segment collision-free:
  /// a time parameterization then blends a few gentle corners instead of many tiny ones.
  double reduce_tolerance = 0.03;
};

struct ChompResult {
  bool improved = false;           ///< false: the input path is returned
  std::vector<VecX> path;
  double cost_before = 0, cost_after = 0;
  double min_clearance_before = 0, min_clearance_after = 0;  ///< [m], spheres' signed distance
  std::string reason;
  double seconds = 0;
};

ChompResult chompSmooth(const RobotModel& robot, const PlanningScene& scene, CollisionChecker& checker,
                        const std::vector<VecX>& path, const ChompOptions& options = {});

}  // namespace mm
