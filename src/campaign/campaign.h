// A campaign: N seeded trials of the bin-picking pipeline, results written as they happen.
//   <out>/config.resolved.yaml  every parameter as used
//   <out>/trials.jsonl          one JSON object per trial, appended and flushed as each ends
//   <out>/summary.json          yields with Wilson 95% intervals, cycle time, breakdown, accuracy,
//                               failures by stage, environment (written by temp file + rename)
#pragma once
#include <string>

#include "campaign/experiment.h"

namespace mm {

struct CampaignOptions {
  std::string out_dir;       ///< results folder
  std::string command_line;  ///< as typed, recorded in the summary
};

/// Loads the robot and scene (input errors throw InputError before anything is written), then
/// runs the trials. Returns the printed summary table.
std::string runCampaign(const Experiment& experiment, const CampaignOptions& options);

}  // namespace mm
