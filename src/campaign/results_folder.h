// A campaign's results folder: what its results depend on (the configuration fingerprint a resume,
// a merge and a replay check), making it ready for a new or a resumed campaign, and the machine a
// campaign ran on. Internal to src/campaign/.
#pragma once
#include <cstdint>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "campaign/experiment.h"
#include "campaign/record.h"

namespace mm {

/// FNV-1a, 64 bits, as 16 hex digits: a change detector for input files (not a cryptographic hash).
std::string digest(const std::string& bytes);

/// Every outcome-relevant key's value as used; the robot, its gripper, the scene, the tree, the
/// object catalogue and the extrinsics by their files' contents.
nlohmann::json fingerprintOf(const Experiment& e);

/// What differs between two fingerprints, in words ("" when nothing does).
std::string differences(const nlohmann::json& there, const nlohmann::json& here, const std::string& there_name = "there",
                        const std::string& here_name = "here");

struct ResumeState {
  bool resumed = false;
  std::string date;               ///< the campaign's first start (the .db3 files' session date)
  std::string first_command;      ///< the command that started it
  long trials = 0;                ///< the campaign's trial count (the largest asked for)
  std::vector<char> done;         ///< by trial index
  long done_count = 0, ok_count = 0, dropped_lines = 0;
  std::string meta;               ///< campaign.json's text for this run (written when the run does anything)
};

/// Prepares `out` for the campaign: a new one, or the resumption of the same campaign (everything
/// but the run-only keys equal). Throws InputError before anything is written when the folder holds
/// another campaign's results. On resume, trials.jsonl keeps its complete records but those of
/// crashed or hung trials (run again) and loses a half-written last line.
ResumeState prepareResults(const Experiment& e, const std::filesystem::path& out, const nlohmann::json& fingerprint,
                           const std::string& command, const std::function<bool(uint64_t)>& will_run);

/// Empty but for a lock file a finished writer left.
bool isEmptyFolder(const std::filesystem::path& dir);
/// "YYYY-MM-DD HH:MM:SS", local time.
std::string localDateTime();
/// The versions and the machine, into the summary's environment.
void fillEnvironment(CampaignSummary& s);
/// `v` with `precision` digits after the point.
std::string fixedText(double v, int precision);

}  // namespace mm
