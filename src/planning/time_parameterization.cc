#include "planning/time_parameterization.h"

#include "core/error.h"
#include "planning/jerk.h"
#include "planning/totg.h"

namespace mm {

const std::vector<std::string>& timeParameterizationNames() {
  static const std::vector<std::string> names = {"trapezoidal", "jerk_limited_stop", "jerk_limited", "totg"};
  return names;
}

TimedPath timeParameterize(const std::string& method, const std::vector<VecX>& path, const RobotModel& robot,
                           const LimitScaling& scale, double dt, const std::function<bool(const VecX&)>& valid) {
  TimedPath out;
  out.interior_waypoints = std::max(0, static_cast<int>(path.size()) - 2);
  out.stops = out.interior_waypoints;
  if (method == "trapezoidal") {
    out.trajectory = trapezoidalTrajectory(path, robot.vmax(), robot.amax(), scale, dt);
  } else if (method == "jerk_limited_stop") {
    out.trajectory = jerkLimitedTrajectory(path, robot.vmax(), robot.amax(), robot.jmax(), scale, dt);
  } else if (method == "jerk_limited") {
    JerkWaypointResult r = jerkLimitedThroughWaypoints(path, robot.vmax(), robot.amax(), robot.jmax(), scale, dt, valid);
    out.trajectory = std::move(r.trajectory);
    out.interior_waypoints = r.interior_waypoints;
    out.stops = r.stops;
    out.backoffs = r.shrinks;
  } else if (method == "totg") {
    for (double deviation : {0.05, 0.01, 0.0}) {
      TotgOptions o;
      o.max_deviation = deviation;
      JointTrajectory t = totgTrajectory(path, robot, scale, dt, o);
      bool ok = !t.empty();
      for (int k = 0; ok && valid && deviation > 0 && k < t.size(); ++k) ok = valid(t.q.col(k));
      if (ok) {
        out.trajectory = std::move(t);
        out.stops = deviation > 0 ? 0 : out.interior_waypoints;
        break;
      }
      ++out.backoffs;
    }
  } else {
    throw InputError("time parameterization " + method, "expected trapezoidal, jerk_limited_stop, jerk_limited or totg");
  }
  if (out.trajectory.empty()) {
    out.failure = method + ": no trajectory within the limits";
    return out;
  }
  out.limits = checkLimits(out.trajectory, robot, 1e-6);
  const bool jerk_bounded = method == "jerk_limited" || method == "jerk_limited_stop";
  if (!out.limits.ok || (jerk_bounded && out.limits.max_jerk_ratio > 1 + 1e-6)) {
    out.failure = method + ": output oversteps the limits (" +
                  (out.limits.worst.empty() ? "jerk ratio " + std::to_string(out.limits.max_jerk_ratio) : out.limits.worst) + ")";
    out.trajectory = JointTrajectory{};
  }
  return out;
}

}  // namespace mm
