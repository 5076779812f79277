// The node library on the task layer, with the source's names and ports (its BT XML in
// M15.2 phase 3 and M15.4): perception, grasp selection, MTC-style planning and execution, the
// gripper, moves home and to safety, and the conditions and counters of a bin-clearing loop.
// Actions that move the arm are asynchronous (RUNNING while the executor moves it on simulated
// time; halting one brings the arm to a controlled stop); planning and perception take no
// simulated time. Every node's meaning is in docs/reference/nodes.md (`minimanip nodes-doc`).
#pragma once
#include <string>
#include <vector>

#include "bt/basic.h"
#include "core/pose.h"
#include "planning/collision.h"
#include "task/trial_context.h"

namespace mm {

/// A grasp candidate together with the object it grasps (WaitForGraspCandidates' list).
struct GraspOption {
  ObjectState object;
  GraspCandidate candidate;
};
using GraspList = std::vector<GraspOption>;

namespace bt {

class Factory;

template <> TypeInfo typeInfo<Pose>();  ///< "x;y;z" or "x;y;z;qw;qx;qy;qz" [m]
template <> TypeInfo typeInfo<GraspList>();
template <> TypeInfo typeInfo<GraspSolution>();
template <> TypeInfo typeInfo<PlanningScene>();

/// What the nodes of one worker act on: the current trial (set before each trial).
struct TaskNodeEnv {
  TrialContext* ctx = nullptr;
  Pose T_world_place_target = Pose::Identity();  ///< where a placed object rests (the scene's place_target)
};

/// Registers the node library; the nodes act on `env.ctx` (which must outlive the factory's trees).
void registerTaskNodes(Factory& factory, TaskNodeEnv& env);

}  // namespace bt
}  // namespace mm
