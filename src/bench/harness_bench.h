// Harness throughput benchmark: full trials of an experiment, then pure MuJoCo stepping of the
// same scenes with the same control sequences, so the harness overhead is a ratio from one run.
#pragma once
#include <string>

#include "campaign/experiment.h"

namespace mm {

/// Runs `experiment.trials` trials (MuJoCo hardware) and their replays; returns a printable report.
std::string benchmarkHarness(const Experiment& experiment, const std::string& command_line);

}  // namespace mm
