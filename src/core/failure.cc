#include "core/failure.h"

namespace mm {

const char* failureKindName(FailureKind kind) {
  switch (kind) {
    case FailureKind::kNone: return "none";
    case FailureKind::kPerception: return "perception";
    case FailureKind::kNoGrasp: return "no_grasp";
    case FailureKind::kIk: return "ik";
    case FailureKind::kCollision: return "collision";
    case FailureKind::kPlanning: return "planning";
    case FailureKind::kTimeParameterization: return "time_parameterization";
    case FailureKind::kGraspMissed: return "grasp_missed";
    case FailureKind::kDropped: return "dropped";
    case FailureKind::kSimUnstable: return "sim_unstable";
    case FailureKind::kPlacement: return "placement";
    case FailureKind::kHalted: return "halted";
    case FailureKind::kTimeout: return "timeout";
    case FailureKind::kTree: return "tree";
    case FailureKind::kPrecondition: return "precondition";
    case FailureKind::kTracking: return "tracking";
    case FailureKind::kPathBlocked: return "path_blocked";
    case FailureKind::kContactForce: return "contact_force";
    case FailureKind::kCrash: return "crash";
    case FailureKind::kHang: return "hang";
    case FailureKind::kSpawn: return "spawn";
  }
  return "unknown";
}

std::string failureKindList() {
  std::string s;
  const int last = static_cast<int>(kLastFailureKind);
  for (int k = 1; k <= last; ++k)
    s += std::string(k == 1 ? "" : k == last ? " or " : ", ") + failureKindName(static_cast<FailureKind>(k));
  return s;
}

FailureKind failureKindFromName(const std::string& name) {
  for (int k = 0; k <= static_cast<int>(kLastFailureKind); ++k)
    if (name == failureKindName(static_cast<FailureKind>(k))) return static_cast<FailureKind>(k);
  return FailureKind::kNone;
}

}  // namespace mm
