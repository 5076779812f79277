// A sweep: one experiment run for every cell of a grid of a few keys' values (`sweep:` in the
// file, or --sweep key=a,b,c), each cell a full campaign on the same seed — the same trial indices,
// so the same scenes wherever the factor leaves them alone — in a results folder of its own:
//   <out>/sweep.json        the factors and cells (what a resume must match)
//   <out>/cell_<i>/         a campaign's results folder (resumable, reportable, gateable)
// `minimanip report <out>` plots yield, recovery and cycle time against each factor.
#pragma once
#include <string>

#include "campaign/campaign.h"

namespace mm {

/// Runs the cells one after the other (each with the experiment's worker processes). Every cell's
/// configuration is loaded before any runs (bad input: InputError); a folder holding another sweep
/// is refused naming what differs. Returns the printed table of cells.
std::string runSweep(const Experiment& experiment, const CampaignOptions& options);

}  // namespace mm
