// Where fault injection reaches into a trial (implemented in faults/, so the task layer does not
// depend on it): the perceptions the robot gets, the planner calls and plans made, and every
// control period.
#pragma once
#include <string>

#include "core/camera.h"
#include "perception/perception.h"

namespace mm {

class TrialContext;
struct Plan;

class FaultHooks {
 public:
  virtual ~FaultHooks() = default;
  /// A perception's result before the robot sees it (may drop, shift or add objects).
  virtual void onPerception(TrialContext& ctx, PerceptionResult& result) = 0;
  /// Camera mode: before the camera `camera` takes a frame (may knock it off its mount).
  virtual void beforeCapture(TrialContext& ctx, const std::string& camera) = 0;
  /// Camera mode: the camera's frame before perception reads it (may black it out or lose depth;
  /// a frame taken to register the camera against the cell is not offered).
  virtual void onFrame(TrialContext& ctx, Frame& frame) = 0;
  /// Before a joint-space planning call of `stage`: true makes it fail.
  virtual bool failPlanning(TrialContext& ctx, const std::string& stage) = 0;
  /// A plan was made (may change the world it was made for).
  virtual void onPlanned(TrialContext& ctx, const Plan& plan) = 0;
  /// Before every control period (may disturb the world or the hardware).
  virtual void beforeStep(TrialContext& ctx) = 0;
};

}  // namespace mm
