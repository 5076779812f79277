// Result records described once: a trial's line in trials.jsonl (TrialRecord) and a campaign's
// summary.json (CampaignSummary) each list their fields in one describe() — key, field, unit,
// meaning — from which come the JSON writer, the reader (trials.jsonl is read back to summarize,
// and later to resume and merge) and the field reference in docs/reference/results.md (`minimanip results-doc`).
#pragma once
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "campaign/stats.h"
#include "task/trial_outcome.h"

namespace mm {

/// Visits the fields of a record (writer, reader, documenter).
class RecordArchive {
 public:
  virtual ~RecordArchive() = default;
  virtual void field(const char* key, bool& v, const char* unit, const char* help) = 0;
  virtual void field(const char* key, int& v, const char* unit, const char* help) = 0;
  virtual void field(const char* key, long& v, const char* unit, const char* help) = 0;
  virtual void field(const char* key, unsigned long& v, const char* unit, const char* help) = 0;
  virtual void field(const char* key, double& v, const char* unit, const char* help) = 0;
  /// Text; empty is written as null.
  virtual void field(const char* key, std::string& v, const char* unit, const char* help) = 0;
  virtual void field(const char* key, std::vector<std::string>& v, const char* unit, const char* help) = 0;
  virtual void field(const char* key, std::vector<double>& v, const char* unit, const char* help) = 0;
  virtual void field(const char* key, std::map<std::string, long>& v, const char* unit, const char* help) = 0;
  /// A nested object.
  virtual void object(const char* key, const std::function<void(RecordArchive&)>& body, const char* help) = 0;
  /// A list of `n` objects (the reader sets n; item(i, a) describes element i).
  virtual void list(const char* key, size_t& n, const std::function<void(size_t, RecordArchive&)>& item, const char* help) = 0;
  /// True while reading (fields derived on writing are recomputed instead).
  virtual bool reading() const { return false; }
};

constexpr int kTrialSchema = 16;  // 3: attempts, failure kinds crash and hang; 4: picks' offset; 5: forces, contacts; 6: picks' first_pass; 7: detections; 8: grasp selections, picks' grasp type and deviation; 9: ik_solver; 10: grasp attempts, object grades; 11: picks' place_turn; 12: grasps' tried[].turned; 13: oracle; 14: external_calls; 15: external_calls' answer; 16: pose_views

/// One trial as trials.jsonl holds it.
struct TrialRecord {
  int schema = kTrialSchema;
  unsigned long trial = 0, seed = 0;
  std::string hardware;
  std::string oracle;      ///< what the trial was given that no real cell has (oracleOf); empty: nothing
  int objects_in_bin = 0;  ///< spawned
  int spawn_attempts = 0;
  std::vector<std::string> object_grades;  ///< generated objects: each one's shape grade, by index
  std::string bt_log;      ///< the .db3 relative to the results folder, if kept
  int attempts = 1;        ///< worker processes it took (2: the first died or hung)
  TrialOutcome o;
  void describe(RecordArchive& a);
};

/// One JSON line (no newline).
std::string toJsonLine(TrialRecord& r);
/// Parses a line of trials.jsonl; throws InputError naming `where` when it is not a trial record.
TrialRecord fromJsonLine(const std::string& line, const std::string& where);

/// Recovery from one fault kind over a campaign.
struct FaultStats {
  std::string kind;
  bool recoverable = true;          ///< some action of the robot can succeed after it
  long injected = 0, no_effect = 0, detected = 0, recovered = 0, given_up = 0, superseded = 0, unrecovered = 0;
  /// Recoverable kinds: recovered / (recovered + unrecovered); the others: given_up / (given_up +
  /// unrecovered). -1: none to judge.
  double recovery = -1;
  std::vector<double> ci95;         ///< Wilson 95% interval of it
  double mttr_mean = -1, mttr_max = -1;  ///< [s] over the recovered ones
};

/// A rate k / n with its Wilson 95% interval (value -1 and no interval when n is 0).
struct Rate {
  long k = 0, n = 0;
  double value = -1;
  std::vector<double> ci95;
  void finish();
};

/// Known models: pose recall as the BOP Challenge scores it (Hodaň et al., "BOP Challenge 2020 on 6D
/// Object Localization", ECCVW 2020), over every view's targets (visible fraction >= 0.1): a
/// target's pose is correct at a threshold when its matched detection's error is under it (no
/// detection: never); each average recall is the share correct over its thresholds and the targets.
struct PoseRecall {
  long views = 0, targets = 0, posed = 0;
  double ar = -1;       ///< the mean of the three below; -1: no targets
  double ar_vsd = -1;   ///< VSD < 0.05 ... 0.5, at each tau 0.05 d ... 0.5 d (100 pairs)
  double ar_mssd = -1;  ///< MSSD < 0.05 d ... 0.5 d
  double ar_mspd = -1;  ///< MSPD < 5 ... 50 px, scaled to a 640 px wide image
  Rate mssd_10;         ///< MSSD < 0.1 d, over the targets at least half visible
  double seconds_per_view_mean = 0, seconds_per_view_max = 0;
};

/// The clutter-removal protocol's figures for the objects of one shape grade (or all of them).
struct ClutterStats {
  std::string grade;  ///< "" for all objects
  Rate grasp_success; ///< attempts whose object was released in the tray / attempts
  Rate declutter;     ///< objects released in the tray / objects
};

/// A campaign's summary.json: yields with Wilson intervals, times, accuracy, counts, environment.
struct CampaignSummary {
  int schema = kTrialSchema;
  std::string experiment, experiment_file, command, hardware, tree;
  std::string ik_solver;  ///< kinematics.solver with auto resolved (the robot's closed form, or dls)
  std::string goal = "pick_one";  ///< task.goal: pick_one or clear_bin (what the report leads with)
  unsigned long seed = 0;
  long trials = 0, successes = 0, first_pass = 0, recoveries_needed = 0, recovered = 0;
  double first_pass_yield = 0, overall_yield = 0;
  std::vector<double> first_pass_ci95, overall_ci95;
  double recovery_rate = -1;  ///< -1: no recovery was needed
  double cycle_mean = 0, cycle_std = 0, cycle_max = 0;
  double sim_mean = 0, sim_std = 0, sim_max = 0;
  double throughput_per_hour = 0, time_per_pick = 0;
  std::map<std::string, double> breakdown;  ///< mean over successes [s]
  double place_mm_mean = 0, place_mm_max = 0, orient_deg_mean = 0, orient_deg_max = 0;
  double slip_mm_mean = 0, slip_mm_max = 0;
  double grasp_dev_mm_mean = 0, grasp_dev_mm_max = 0;  ///< the source's grasp-pose deviation, over every planned grasp let go of
  long side_grasps = 0, top_down_grasps = 0;            ///< picks let go of, by the grasp that took them
  long detections = 0, false_detections = 0, missed_detections = 0;  ///< camera perception
  double det_centre_mm_mean = 0, det_centre_mm_max = 0, det_rotation_deg_mean = 0, det_rotation_deg_max = 0;
  double det_mssd_mm_mean = 0, det_mssd_mm_max = 0;
  long collision_events = 0;
  double collisions_per_100 = 0, max_tracking_error = 0;
  long sim_unstable = 0, dropped = 0, objects_placed = 0, objects_left_in_bin = 0, bins_cleared = 0, timeouts = 0;
  long crashes = 0, hangs = 0;  ///< trials whose worker process died twice / was stopped by the watchdog
  long spawn_failures = 0;      ///< trials whose scene could not be set up (failure_kind spawn)
  std::map<std::string, long> failure_stages;
  std::vector<FaultStats> faults;  ///< per fault kind injected
  double mtbf = -1;                ///< [s] simulated time per trial failure the tree did not recover (-1: none)
  long protective_stops = 0;       ///< motions stopped by the path tolerance (tracking) or on contact force
  long protective_stops_contact = 0;  ///< of them, on contact force
  double max_external_force = 0;   ///< [N] over the trials
  double non_target_contacts_per_trial = 0;
  double neighbours_moved_mm_max = 0;
  long objects_spawned = 0;
  PoseRecall pose_recall;                  ///< known models' poses (perception.known_models)
  ClutterStats clutter;                    ///< grasp success and declutter rates over all objects
  std::vector<ClutterStats> clutter_by_grade;  ///< the same per shape grade (generated objects)
  std::map<std::string, long> attempt_results;  ///< grasp attempts by result
  double object_yield = 0, object_first_pass_yield = 0;
  std::vector<double> object_yield_ci95, object_first_pass_ci95;
  double wall_seconds = 0, trials_per_second = 0;
  std::string minimanip, mujoco, ompl, compiler, cpu, host;
  std::string renderer;  ///< when rendering: the OpenGL renderer (images differ between renderers)
  long cores = 0, jobs = 0;
  void describe(RecordArchive& a);
};

/// A campaign's statistics built one trial at a time in constant memory (a million-trial campaign
/// streams its trials.jsonl through it). The result does not depend on the order of the trials.
class SummaryBuilder {
 public:
  void add(const TrialRecord& r);
  /// Counts, yields with Wilson 95% intervals, means; the environment fields are left empty.
  CampaignSummary get() const;
  __extension__ typedef __int128 Int128;

 private:
  CampaignSummary s_;
  ExactMoments cycle_, sim_, place_mm_, orient_deg_, slip_mm_, grasp_dev_mm_, det_centre_mm_, det_rotation_deg_, det_mssd_mm_;
  std::map<std::string, ExactMoments> parts_, mttr_;
  std::map<std::string, FaultStats> kinds_;
  Int128 all_time_ = 0, sim_total_ = 0;
  long unrecovered_failures_ = 0, non_target_contacts_ = 0, objects_first_pass_ = 0;
  std::map<std::string, ClutterStats> grades_;
  ExactMoments pose_seconds_;
  long vsd_hits_ = 0, mssd_hits_ = 0, mspd_hits_ = 0;  // (target, threshold) pairs correct
};

/// The statistics of `trials` (a SummaryBuilder fed with each).
CampaignSummary summarizeTrials(const std::vector<TrialRecord>& trials);
std::string toJson(CampaignSummary& s);  ///< pretty-printed
/// Parses a summary.json; throws InputError naming `where` when it is not one of this schema.
CampaignSummary summaryFromJson(const std::string& text, const std::string& where);

/// The fields of trials.jsonl and summary.json as Markdown lists (docs/reference/results.md).
std::string recordsMarkdown();

}  // namespace mm
