// A campaign's summary from its trials' records, in constant memory and independent of their order
// (the statistics of summary.json).
#include <algorithm>
#include <cmath>

#include "campaign/record.h"
#include "campaign/stats.h"
#include "faults/faults.h"
#include "sim/object_generator.h"

namespace mm {

void Rate::finish() {
  if (n <= 0) return;
  value = double(k) / n;
  const auto [lo, hi] = wilson95(k, n);
  ci95 = {lo, hi};
}

void SummaryBuilder::add(const TrialRecord& r) {
  const TrialOutcome& o = r.o;
  CampaignSummary& s = s_;
  ++s.trials;
  // One solver for the whole campaign; a died worker's trial has none (the least name: any order).
  if (!o.ik_solver.empty() && (s.ik_solver.empty() || o.ik_solver < s.ik_solver)) s.ik_solver = o.ik_solver;
  s.collision_events += o.collision_count;
  const long placed = std::count_if(o.picks.begin(), o.picks.end(), [](const PickRecord& p) { return p.placed; });
  s.objects_placed += placed;
  s.objects_spawned += r.objects_in_bin;
  objects_first_pass_ += std::count_if(o.picks.begin(), o.picks.end(), [](const PickRecord& p) { return p.placed && p.first_pass; });
  if (std::isfinite(o.total_time)) all_time_ += static_cast<SummaryBuilder::Int128>(std::llround(o.total_time * 1e9));
  if (std::isfinite(o.sim_time)) sim_total_ += static_cast<SummaryBuilder::Int128>(std::llround(o.sim_time * 1e9));
  s.objects_left_in_bin += o.objects_left_in_bin;
  for (const DetectionRecord& d : o.detections) {
    ++s.detections;
    if (d.object < 0) {
      ++s.false_detections;
      continue;
    }
    det_centre_mm_.add(1000.0 * d.centre_error);
    if (d.rotation_error >= 0) det_rotation_deg_.add(180.0 / M_PI * d.rotation_error);  // -1: no model, no orientation
    if (d.mssd >= 0) det_mssd_mm_.add(1000.0 * d.mssd);
  }
  s.missed_detections += o.missed_detections;
  for (const PoseViewRecord& v : o.pose_views) {
    ++s.pose_recall.views;
    pose_seconds_.add(v.seconds);
    const double px = v.width > 0 ? 640.0 / v.width : 1.0;
    for (const PoseTargetRecord& t : v.targets) {
      ++s.pose_recall.targets;
      const bool half = t.visible_fraction >= 0.5;
      s.pose_recall.mssd_10.n += half;
      if (!t.posed) continue;
      ++s.pose_recall.posed;
      s.pose_recall.mssd_10.k += half && t.mssd < 0.1 * t.diameter;
      for (int i = 1; i <= 10; ++i) {  // BOP's thresholds: 0.05, 0.10, ..., 0.50
        const double th = i / 20.0;
        mssd_hits_ += t.mssd < th * t.diameter;
        mspd_hits_ += t.mspd * px < 100.0 * th;
        for (double e : t.vsd) vsd_hits_ += e < th;
      }
    }
  }
  // A crashed trial's bin is unknown; a trial whose spawn failed never had a bin to clear.
  const bool harness_failure =
      o.failure_kind == FailureKind::kCrash || o.failure_kind == FailureKind::kHang || o.failure_kind == FailureKind::kSpawn;
  s.bins_cleared += o.objects_left_in_bin == 0 && !harness_failure;
  s.spawn_failures += o.failure_kind == FailureKind::kSpawn;
  s.timeouts += o.tree_status == "TIMEOUT";
  s.crashes += o.failure_kind == FailureKind::kCrash;
  s.hangs += o.failure_kind == FailureKind::kHang;
  s.sim_unstable += o.sim_unstable;
  s.dropped += o.dropped;
  s.max_tracking_error = std::max(s.max_tracking_error, o.max_tracking_error);
  if (o.recovery_needed) ++s.recoveries_needed, s.recovered += o.recovery_success;
  unrecovered_failures_ += !o.success;
  for (const RecordedFailure& f : o.failures) {
    s.protective_stops += f.failure.kind == FailureKind::kTracking || f.failure.kind == FailureKind::kContactForce;
    s.protective_stops_contact += f.failure.kind == FailureKind::kContactForce;
  }
  s.max_external_force = std::max(s.max_external_force, o.max_external_force);
  non_target_contacts_ += o.non_target_contacts;
  s.neighbours_moved_mm_max = std::max(s.neighbours_moved_mm_max, 1000 * o.neighbours_moved);
  for (const FaultRecord& f : o.faults) {
    FaultStats& k = kinds_[f.kind];
    k.kind = f.kind;
    const FaultKind kind = faultKindFromName(f.kind);
    k.recoverable = kind == FaultKind::kCount || faultRecoverable(kind);
    ++k.injected;
    if (f.outcome == "no_effect") ++k.no_effect;
    else ++k.detected;
    if (f.outcome == "recovered") ++k.recovered, mttr_[f.kind].add(f.mttr);
    if (f.outcome == "given_up") ++k.given_up;
    if (f.outcome == "superseded") ++k.superseded;
    if (f.outcome == "unrecovered") ++k.unrecovered;
  }
  // The clutter-removal protocol: attempts and their successes, objects and those released in
  // the tray, over all objects and per shape grade.
  auto gradeOf = [&](int object) -> const std::string* {
    return object >= 0 && object < static_cast<int>(r.object_grades.size()) ? &r.object_grades[static_cast<size_t>(object)] : nullptr;
  };
  s.clutter.declutter.n += r.objects_in_bin;
  for (const std::string& g : r.object_grades) ++grades_[g].declutter.n;
  std::vector<int> in_tray;
  for (const PickRecord& p : o.picks)
    if (p.at_target && std::find(in_tray.begin(), in_tray.end(), p.object) == in_tray.end()) in_tray.push_back(p.object);
  s.clutter.declutter.k += static_cast<long>(in_tray.size());
  for (int object : in_tray)
    if (const std::string* g = gradeOf(object)) ++grades_[*g].declutter.k;
  for (const GraspAttempt& a : o.grasp_attempts) {
    ++s.clutter.grasp_success.n, s.clutter.grasp_success.k += a.success();
    ++s.attempt_results[a.result];
    if (const std::string* g = gradeOf(a.object)) ++grades_[*g].grasp_success.n, grades_[*g].grasp_success.k += a.success();
  }
  for (const PickRecord& p : o.picks) {
    if (p.grasp_type.empty()) continue;
    (p.grasp_type == "side" ? s.side_grasps : s.top_down_grasps)++;
    grasp_dev_mm_.add(1000.0 * p.grasp_deviation);
  }
  if (!o.success) {
    s.failure_stages[o.failure_stage.empty() ? "unknown" : o.failure_stage]++;
    return;
  }
  ++s.successes;
  if (!o.recovery_needed) ++s.first_pass;
  cycle_.add(o.total_time);
  sim_.add(o.sim_time);
  place_mm_.add(1000.0 * o.place_position_error);
  slip_mm_.add(1000.0 * o.in_hand_slip);
  if (o.place_orientation_error >= 0) orient_deg_.add(180.0 / M_PI * o.place_orientation_error);  // -1: no target
  parts_["perception_time"].add(o.perception_time);
  parts_["plan_pick_time"].add(o.plan_pick_time);
  parts_["execute_pick_time"].add(o.execute_pick_time);
  parts_["plan_place_time"].add(o.plan_place_time);
  parts_["execute_place_time"].add(o.execute_place_time);
  parts_["return_home_time"].add(o.return_home_time);
}

CampaignSummary SummaryBuilder::get() const {
  CampaignSummary s = s_;
  for (const auto& [name, k0] : kinds_) {
    FaultStats k = k0;
    const long good = k.recoverable ? k.recovered : k.given_up, judged = good + k.unrecovered;
    if (judged > 0) {
      k.recovery = double(good) / judged;
      const auto [lo, hi] = wilson95(good, judged);
      k.ci95 = {lo, hi};
    }
    if (const auto it = mttr_.find(name); it != mttr_.end() && it->second.get().n > 0) {
      const Moments m = it->second.get();
      k.mttr_mean = m.mean, k.mttr_max = m.max;
    }
    s.faults.push_back(k);
  }
  const double all_time = static_cast<double>(all_time_) / 1e9, sim_total = static_cast<double>(sim_total_) / 1e9;
  s.mtbf = unrecovered_failures_ > 0 ? sim_total / unrecovered_failures_ : -1;
  s.non_target_contacts_per_trial = s.trials > 0 ? static_cast<double>(non_target_contacts_) / s.trials : 0;

  const long n = s.trials;
  const auto [fl, fh] = wilson95(s.first_pass, n);
  const auto [ol, oh] = wilson95(s.successes, n);
  s.first_pass_yield = n ? double(s.first_pass) / n : 0.0;
  s.overall_yield = n ? double(s.successes) / n : 0.0;
  s.first_pass_ci95 = {fl, fh};
  s.overall_ci95 = {ol, oh};
  {
    const long m = s.objects_spawned, placed = std::min(s.objects_placed, m), first = std::min(objects_first_pass_, m);
    const auto [pl, ph] = wilson95(placed, m);
    const auto [ql, qh] = wilson95(first, m);
    s.object_yield = m ? double(placed) / m : 0.0;
    s.object_first_pass_yield = m ? double(first) / m : 0.0;
    s.object_yield_ci95 = {pl, ph};
    s.object_first_pass_ci95 = {ql, qh};
  }
  s.clutter.grasp_success.finish();
  s.clutter.declutter.finish();
  for (const auto& [grade, g0] : grades_) {
    ClutterStats g = g0;
    g.grade = grade;
    g.grasp_success.finish();
    g.declutter.finish();
    s.clutter_by_grade.push_back(g);
  }
  auto rank = [](const std::string& grade) {  // the grades simplest first, as the generator has them
    const auto& all = shapeGrades();
    return std::find(all.begin(), all.end(), grade) - all.begin();
  };
  std::stable_sort(s.clutter_by_grade.begin(), s.clutter_by_grade.end(),
                   [&](const ClutterStats& a, const ClutterStats& b) { return rank(a.grade) < rank(b.grade); });
  s.recovery_rate = s.recoveries_needed ? double(s.recovered) / s.recoveries_needed : -1;
  const Moments c = cycle_.get(), m = sim_.get(), pm = place_mm_.get(), od = orient_deg_.get(), sl = slip_mm_.get();
  s.cycle_mean = c.mean, s.cycle_std = c.std, s.cycle_max = c.max;
  s.sim_mean = m.mean, s.sim_std = m.std, s.sim_max = m.max;
  s.throughput_per_hour = all_time > 0 ? 3600.0 * s.objects_placed / all_time : 0.0;
  s.time_per_pick = s.objects_placed > 0 ? all_time / s.objects_placed : 0.0;
  for (const char* k : {"perception_time", "plan_pick_time", "execute_pick_time", "plan_place_time", "execute_place_time",
                        "return_home_time"}) {
    const auto it = parts_.find(k);
    s.breakdown[k] = it == parts_.end() ? 0.0 : it->second.get().mean;
  }
  s.place_mm_mean = pm.mean, s.place_mm_max = pm.max;
  s.slip_mm_mean = sl.mean, s.slip_mm_max = sl.max;
  const Moments gd = grasp_dev_mm_.get();
  s.grasp_dev_mm_mean = gd.mean, s.grasp_dev_mm_max = gd.max;
  {
    const Moments dc = det_centre_mm_.get(), dr = det_rotation_deg_.get(), dm = det_mssd_mm_.get();
    s.det_centre_mm_mean = dc.mean, s.det_centre_mm_max = dc.max;
    s.det_rotation_deg_mean = dr.mean, s.det_rotation_deg_max = dr.max;
    s.det_mssd_mm_mean = dm.mean, s.det_mssd_mm_max = dm.max;
  }
  {
    PoseRecall& p = s.pose_recall;
    if (p.targets > 0) {
      const double targets = static_cast<double>(p.targets);
      p.ar_vsd = vsd_hits_ / (100 * targets), p.ar_mssd = mssd_hits_ / (10 * targets), p.ar_mspd = mspd_hits_ / (10 * targets);
      p.ar = (p.ar_vsd + p.ar_mssd + p.ar_mspd) / 3;
    }
    p.mssd_10.finish();
    const Moments ps = pose_seconds_.get();
    p.seconds_per_view_mean = ps.mean, p.seconds_per_view_max = ps.max;
  }
  s.orient_deg_mean = od.mean, s.orient_deg_max = od.max;
  s.collisions_per_100 = n ? 100.0 * s.collision_events / n : 0.0;
  return s;
}

CampaignSummary summarizeTrials(const std::vector<TrialRecord>& trials) {
  SummaryBuilder b;
  for (const TrialRecord& r : trials) b.add(r);
  return b.get();
}

}  // namespace mm
