// `minimanip check EXPERIMENT`: every check a run makes before its first trial, then a dry run of
// the cell without simulated time — what a robotics engineer asks of a robot brought to a new cell:
// how its files were read (joints, flange, TCP, the IK solver and why), whether home is clear of
// the scene, how much of the bin and of the place target the gripper reaches pointing down, and
// whether the perception camera sees the bin.
#pragma once
#include <string>

#include "campaign/experiment.h"

namespace mm {

struct CellCheck {
  std::string text;      ///< the report, for people
  int warnings = 0;      ///< weak figures (reach below half, a camera that misses part of the bin)
};

/// Throws InputError for anything `minimanip run` would refuse (exit 2); weak figures are warnings.
CellCheck checkCell(const Experiment& e);

}  // namespace mm
