// Fault injection, after the source's fault scenarios and more: each kind has a per-trial
// probability and parameters, and draws from its own random stream (changing one kind's rate
// reshuffles no other). A fault is injected at a drawn moment of the stage it targets, through
// the hooks the task layer offers (perception, planning, every control period), the hardware it
// wraps, or the simulated world; each is recorded in the trial with when and where it struck,
// whether and when it was detected, the recovery the tree took and its outcome (see docs/faults.md's
// fault catalogue for what a correct recovery is for each kind).
#pragma once
#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/config.h"
#include "core/rng.h"
#include "sim/hardware.h"
#include "task/fault_hooks.h"
#include "task/trial_outcome.h"

namespace mm {

class SimWorld;
class TrialContext;

enum class FaultKind {
  kPerceptionDropout,    ///< the first perception sees nothing
  kPerceptionPoseError,  ///< the first perception reports the target shifted and turned
  kFalseDetection,       ///< the first perception reports a phantom object, the one the robot goes for first
  kPlanningFailure,      ///< the first joint-space planning call fails
  kObstacleAdded,        ///< an obstacle appears in the way of the place's transit just planned
  kObjectRemoved,        ///< the target leaves the bin while the arm moves to it
  kObjectMoved,          ///< the target is pushed aside while the arm moves to it
  kGraspSlip,            ///< the held object slips out of the fingers as it is lifted (falls back into the bin)
  kGripperNoClose,       ///< the gripper does not close (once)
  kJointStall,           ///< the fastest joint stalls for a moment during a move
  kCameraBlackout,       ///< camera mode: the first frame is black, no depth (the source's camera_blackout)
  kDepthDropout,         ///< camera mode: the first frame has no depth over a region of the bin
  kExtrinsicsDrift,      ///< camera mode: the camera is knocked off its mount before its first frame
  kCount
};
const char* faultKindName(FaultKind k);
/// Whether a correct recovery exists (kObjectRemoved: noticing and moving on is the correct end).
bool faultRecoverable(FaultKind k);
/// Whether kind `k` strikes the camera (it needs perception.mode camera).
bool faultNeedsCamera(FaultKind k);
/// The kind of a name faultKindName gives; kCount for an unknown name.
FaultKind faultKindFromName(const std::string& name);

struct FaultOptions {
  std::array<double, static_cast<int>(FaultKind::kCount)> rate{};  ///< probability per trial of each kind
  double pose_error = 0.035;      ///< [m] lateral error of a perceived pose
  double pose_error_yaw = 0.4;    ///< [rad] its yaw error (either sign)
  double move_distance = 0.05;    ///< [m] how far a moved object goes
  double stall_time = 0.6;        ///< [s] a stalled joint holds still this long
  double obstacle_margin = 0.05;  ///< [m] least room between an added obstacle and the robot at the motion's ends
  /// Keys faults.<kind> (rates) and the parameters above (section "faults").
  void declare(ConfigArchive& a);
  bool any() const;
};

/// One trial's faults: drawn when constructed, applied through the hooks and the wrapped
/// hardware, judged by report() once the trial is over.
class FaultInjector final : public FaultHooks {
 public:
  FaultInjector(const FaultOptions& options, SimWorld& world, uint64_t campaign_seed, uint64_t trial);
  ~FaultInjector() override;

  /// Whether kind `k` was drawn to strike in this trial (it fires when its moment comes).
  bool drawn(FaultKind k) const { return armed_[static_cast<int>(k)].drawn; }

  /// The hardware the trial must use: `inner` with the gripper and joint faults applied.
  Hardware& wrap(Hardware& inner);

  void onPerception(TrialContext& ctx, PerceptionResult& result) override;
  void onFrame(TrialContext& ctx, Frame& frame) override;
  void beforeCapture(TrialContext& ctx, const std::string& camera) override;
  bool failPlanning(TrialContext& ctx, const std::string& stage) override;
  void onPlanned(TrialContext& ctx, const Plan& plan) override;
  void beforeStep(TrialContext& ctx) override;

  /// Every fault injected, with its detection, the recovery taken, its outcome and MTTR, from the
  /// trial's failures, stages and milestones.
  std::vector<FaultRecord> report(const TrialContext& ctx) const;

 private:
  struct Armed {
    bool drawn = false;    // this kind strikes in this trial
    bool fired = false;
    double onset = 0, onset_compute = 0;
    std::string stage;
    double delay = 0;      // [s] into its stage
    double angle = 0;      // direction of a shift
    double sign = 1;
    double fraction = 0;               // a dropout's size, in [0, 1) of its range
    std::array<double, 2> where{0, 0};  // a dropout's place, in [0, 1) of the room left
    int object = -1;
    Pose knock = Pose::Identity();     // a knocked camera's pose from its mount
    std::string milestone; // what recovering from it means
  };
  void fire(FaultKind k, TrialContext& ctx, const std::string& stage);
  Armed& at(FaultKind k) { return armed_[static_cast<int>(k)]; }

  const FaultOptions& o_;
  SimWorld& world_;
  std::array<Armed, static_cast<int>(FaultKind::kCount)> armed_;
  class Faulty;
  std::unique_ptr<Faulty> hw_;
  std::string stage_;      // the stage seen at the last step
  size_t stage_index_ = 0;
  double stage_start_ = 0;
};

}  // namespace mm
