#include "campaign/record.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <sstream>

#include "campaign/stats.h"
#include "core/error.h"
#include "faults/faults.h"

namespace mm {

using json = nlohmann::json;

// ---- the descriptions ------------------------------------------------------------------------

void TrialRecord::describe(RecordArchive& a) {
  a.field("schema", schema, "", "record format version");
  a.field("trial", trial, "", "trial index (its random streams derive from (seed, trial, purpose))");
  a.field("seed", seed, "", "campaign seed");
  a.field("hardware", hardware, "", "mujoco or mock");
  a.field("oracle", oracle, "",
          "what the robot was given that no real cell has: poses (the simulator's poses of the objects, perception.mode: ground_truth); "
          "segmentation (camera mode's points cut into objects by the renderer's per-object labels, perception.segmentation: labels); "
          "null for nothing (camera mode from the depth alone, or perception.mode: hardcoded, a pose from the configuration)");
  a.field("attempts", attempts, "", "worker processes the trial took: 2 when the first died or hung and a fresh one ran it again");
  a.field("success", o.success, "", "the tree succeeded, every object let go of rests at its target, nothing is left in the hand");
  a.field("failure_stage", o.failure_stage, "", "the stage that failed (null on success)");
  a.field("failure_reason", o.failure_reason, "", "why, in words");
  std::string kind = o.success ? "" : failureKindName(o.failure_kind);
  static const std::string kinds = failureKindList() + " (null on success)";
  a.field("failure_kind", kind, "", kinds.c_str());
  o.failure_kind = failureKindFromName(kind);
  a.field("tree", o.tree, "", "the behavior tree's ID");
  a.field("tree_status", o.tree_status, "", "SUCCESS, FAILURE, TIMEOUT (simulated-time budget), ERROR (a script or port), CRASH or HANG (its worker process died or hung, twice)");
  a.field("ik_solver", o.ik_solver, "", "the IK solver of the grasp and place poses (kinematics.solver with auto resolved; null when the trial's worker died)");
  a.field("ticks", o.ticks, "", "root ticks, re-ticks after a wake-up included");
  a.field("sim_unstable", o.sim_unstable, "", "MuJoCo flagged a bad state");
  a.field("dropped", o.dropped, "", "a held object left the hand");
  a.field("objects_in_bin", objects_in_bin, "", "objects spawned in the bin (0 when the spawn failed: failure_kind spawn)");
  a.field("spawn_attempts", spawn_attempts, "", "spawns drawn until one settled cleanly");
  a.field("object_grades", object_grades, "",
          "generated objects (objects.generated): each object's shape grade, by its index k (object_<k>); empty for the catalogue's kinds");
  a.field("target_object", o.target_object, "", "the first object picked (its index k: object_<k> of the trial's model)");
  a.field("grasp_candidates_tried", o.grasp_candidates_tried, "", "grasp candidates filtered, all picks (a cloud candidate's turned second try is the same candidate)");
  a.field("pushes", o.pushes, "", "pushes planned to move an object no grasp fits (PushObject)");
  a.field("grasp_opening", o.grasp_opening, "m", "per finger after the last close");
  a.object("cycle", [&](RecordArchive& c) {
    c.field("perception_time", o.perception_time, "s", "compute wall time of perception");
    c.field("plan_pick_time", o.plan_pick_time, "s", "compute wall time of pick planning");
    c.field("execute_pick_time", o.execute_pick_time, "s", "simulated time of pick motions");
    c.field("plan_place_time", o.plan_place_time, "s", "compute wall time of place planning");
    c.field("execute_place_time", o.execute_place_time, "s", "simulated time of place motions");
    c.field("return_home_time", o.return_home_time, "s", "planning (wall) and motion (simulated) home");
    c.field("total_time", o.total_time, "s", "their sum: the cycle time, as the source's TrialResult");
  }, "the source's time breakdown");
  a.field("sim_time", o.sim_time, "s", "simulated time of the trial, evaluation rest included");
  a.field("compute_time", o.compute_time, "s", "wall time of the blocking computation");
  a.field("place_position_error", o.place_position_error, "m", "horizontal, the worst placed object");
  a.field("place_orientation_error", o.place_orientation_error, "rad", "about the object's symmetry, the worst placed object (-1: objects with no model, no orientation to place them at)");
  a.field("in_hand_slip", o.in_hand_slip, "m",
          "the most a placed object moved in the hand from the fingers closing to their opening (the simulator's truth, never used by the pipeline)");
  a.field("collision_count", o.collision_count, "", "episodes of robot contact with the table, bins or tray");
  a.field("collision_log", o.collision_log, "", "which geom hit what, when");
  a.field("max_tracking_error", o.max_tracking_error, "rad", "max over samples and joints of |commanded - measured|");
  a.field("collision_checks", o.collision_checks, "", "planning collision checks");
  a.field("max_external_force", o.max_external_force, "N",
          "the largest external contact force on an arm link or the hand sustained for two control periods, as the protective stop sees it (held object's weight included; 0 on mock)");
  a.field("non_target_contacts", o.non_target_contacts, "", "episodes of the robot touching an object it was not picking or holding");
  a.field("neighbours_moved", o.neighbours_moved, "m", "the farthest an object moved while another was picked (pushes aside)");
  a.object("recovery", [&](RecordArchive& r) {
    r.field("needed", o.recovery_needed, "", "a failure the tree went on after");
    r.field("success", o.recovery_success, "", "and the trial succeeded");
    r.field("attempts", o.recovery_attempts, "", "failures the tree went on after");
  }, "recovery (a halt is never one)");
  size_t n_picks = o.picks.size();
  a.list("picks", n_picks, [&](size_t i, RecordArchive& p) {
    if (p.reading() && o.picks.size() <= i) o.picks.resize(i + 1);
    PickRecord& k = o.picks[i];
    p.field("object", k.object, "", "object index (object_<k>)");
    p.field("at_target", k.at_target, "", "let go of over its target by a place");
    p.field("placed", k.placed, "", "evaluated within the tolerances (an object with no model set down at a slot of the place grid: in that slot, at rest)");
    p.field("position_error", k.position_error, "m", "horizontal");
    p.field("orientation_error", k.orientation_error, "rad", "about its symmetry (from the target as turned: place_turn; -1: no model, no target orientation)");
    p.field("place_turn", k.place_turn, "rad",
            "the target turned about the vertical from the one asked, when at that yaw the hand met a neighbour (place.any_yaw; 0: as asked)");
    std::vector<double> target{k.T_world_target.translation().x(), k.T_world_target.translation().y(),
                               k.T_world_target.translation().z()};
    p.field("target", target, "m", "where it should rest (world x, y, z)");
    if (target.size() == 3) k.T_world_target.translation() = Vec3(target[0], target[1], target[2]);
    std::vector<double> offset{k.offset.x(), k.offset.y(), k.offset.z()};
    p.field("offset", offset, "m", "where it rests minus where it should (world x, y, z; zero unless let go of over its target)");
    if (offset.size() == 3) k.offset = Vec3(offset[0], offset[1], offset[2]);
    p.field("grasp_candidates_tried", k.grasp_candidates_tried, "", "for this object");
    p.field("grasp_opening", k.grasp_opening, "m", "per finger when it was grasped");
    p.field("neighbours_moved", k.neighbours_moved, "m", "the farthest another object moved while this one was picked");
    p.field("in_hand_slip", k.in_hand_slip, "m", "how far it moved in the hand from the fingers closing to their opening (0: not let go of by a release)");
    p.field("grasp_type", k.grasp_type, "", "top_down, side, cloud (model-free, from the camera's points) or external (from the external component; empty: taken hold of without a planned grasp)");
    p.field("grasp_deviation", k.grasp_deviation, "m",
            "the source's grasp-pose deviation: the achieved in-hand position's offset from the planned one when the fingers closed (the simulator's truth)");
    p.field("grasp_deviation_angle", k.grasp_deviation_angle, "rad", "the same, rotation, up to the object's symmetries");
    p.field("first_pass", k.first_pass, "", "let go of at its target with no failure recorded since the previous object was");
    p.field("reason", k.reason, "", "why it is not placed");
  }, "every object let go of, in order");
  size_t n_attempts = o.grasp_attempts.size();
  a.list("grasp_attempts", n_attempts, [&](size_t i, RecordArchive& g) {
    if (g.reading() && o.grasp_attempts.size() <= i) o.grasp_attempts.resize(i + 1);
    GraspAttempt& k = o.grasp_attempts[i];
    g.field("object", k.object, "", "the object the fingers closed on, else the one nearest the grasp (-1: none within 3 cm); scored from the simulator's truth");
    g.field("result", k.result, "",
            "in_tray (that object released in the tray: a success), missed (nothing between the fingers, they did not close, or no object "
            "there), dropped, let_go_elsewhere (let go of away from its place target), halted (the closing stopped by the tree), held_at_end");
  }, "every closing of the fingers on a chosen grasp candidate (the clutter-removal protocol's attempt; pushes are not attempts), in order");
  long placed = std::count_if(o.picks.begin(), o.picks.end(), [](const PickRecord& p) { return p.placed; });
  a.field("objects_placed", placed, "", "picks placed within the tolerances (with no model, at a slot: in it)");
  a.field("objects_left_in_bin", o.objects_left_in_bin, "", "at the end, as the bin's sensor sees it");
  size_t n_left = o.left.size();
  a.list("objects_left", n_left, [&](size_t i, RecordArchive& l) {
    if (l.reading() && o.left.size() <= i) o.left.resize(i + 1);
    LeftRecord& k = o.left[i];
    l.field("object", k.object, "", "object index (object_<k>)");
    std::vector<double> p{k.position.x(), k.position.y(), k.position.z()};
    l.field("position", p, "m", "where it rests (world x, y, z)");
    if (p.size() == 3) k.position = Vec3(p[0], p[1], p[2]);
    l.field("tilt", k.tilt, "rad", "of its axis nearest the vertical");
    l.field("reason", k.reason, "", "why it was not picked: its last grasp's or push's failure, or not tried");
  }, "every object still in the bin at the end");
  size_t n_sel = o.grasp_selections.size();
  a.list("grasps", n_sel, [&](size_t i, RecordArchive& g) {
    if (g.reading() && o.grasp_selections.size() <= i) o.grasp_selections.resize(i + 1);
    GraspSelection& k = o.grasp_selections[i];
    g.field("object", k.object, "", "object index (object_<k>)");
    g.field("shape", k.shape, "", "box, cylinder or mesh (a solid from a mesh or URDF file), as perceived");
    g.field("candidates", k.candidates, "", "grasp candidates generated");
    size_t n_tried = k.tried.size();
    g.list("tried", n_tried, [&](size_t j, RecordArchive& t) {
      if (t.reading() && k.tried.size() <= j) k.tried.resize(j + 1);
      GraspTry& c = k.tried[j];
      t.field("type", c.type, "", "top_down, side, cloud (model-free, from the camera's points) or external (from the external component)");
      t.field("score", c.score, "", "higher first: wrist turn, clearance, force-closure margin, pad area, torque arm, hand tilt");
      t.field("closure_margin", c.closure_margin, "rad", "atan(pad friction) minus the larger angle between a contact normal and the line between the contacts (> 0: force closure)");
      t.field("contact_area", c.contact_area, "m^2", "pad area the object covers");
      t.field("torque_arm", c.torque_arm, "m", "the object's centre to the grasp axis: its centre of mass for a model's grasp; for one from the points or an external component, the middle of what the camera saw of the object its pads close on (not in its score)");
      t.field("clearance", c.clearance, "m", "open fingertips to the nearest neighbour (capped at 5 cm)");
      t.field("result", c.result, "", "chosen, or why filterGrasps dropped it (force closure, IK, collision, approach, lift)");
      t.field("turned", c.turned, "", "the hand turned half a turn about its approach: a cloud candidate that failed is tried so once more, as the next entry");
    }, "the candidates filtered, in order, up to the chosen one");
  }, "every grasp selection (filterGrasps), in order");
  size_t n_det = o.detections.size();
  a.list("detections", n_det, [&](size_t i, RecordArchive& d) {
    if (d.reading() && o.detections.size() <= i) o.detections.resize(i + 1);
    DetectionRecord& k = o.detections[i];
    d.field("object", k.object, "", "the true object it was matched to (nearest centre within 3 cm; a segment of objects with no model: within its footprint's half diagonal; -1: a false detection)");
    d.field("time", k.time, "s", "simulated, since the trial began");
    d.field("centre_error", k.centre_error, "m", "distance of the estimated centre from the true one (-1: false detection)");
    d.field("rotation_error", k.rotation_error, "rad", "the smallest angle between the estimated and the true orientation over the box's symmetries (-1: a false detection, or a segment of objects with no model)");
    d.field("mssd", k.mssd, "m", "BOP's maximum symmetry-aware surface distance (the farthest corner, best symmetry; -1 as rotation_error)");
  }, "camera perception: every object each perception found, against the simulator's truth (empty in the other modes)");
  a.field("missed_detections", o.missed_detections, "", "camera perception: objects in the bin a perception did not find, summed over perceptions");
  size_t n_views = o.pose_views.size();
  a.list("pose_views", n_views, [&](size_t i, RecordArchive& v) {
    if (v.reading() && o.pose_views.size() <= i) o.pose_views.resize(i + 1);
    PoseViewRecord& k = o.pose_views[i];
    v.field("time", k.time, "s", "simulated, since the trial began");
    v.field("width", k.width, "px", "the image's width (BOP scales MSPD by 640 / width before its thresholds)");
    v.field("segments", k.segments, "", "the depth's segments and their parts the models were tried on");
    v.field("posed", k.posed, "", "of them, posed by a model");
    v.field("seconds", k.seconds, "s", "wall: the view's pose estimation, every segment's (measured; decides nothing)");
    size_t n_targets = k.targets.size();
    v.list("targets", n_targets, [&](size_t j, RecordArchive& t) {
      if (t.reading() && k.targets.size() <= j) k.targets.resize(j + 1);
      PoseTargetRecord& g = k.targets[j];
      t.field("object", g.object, "", "the true object (the simulator's index)");
      t.field("visible_fraction", g.visible_fraction, "", "its pixels in the view (the renderer's labels) / its model's pixels drawn alone at its true pose");
      t.field("diameter", g.diameter, "m", "its model's");
      t.field("posed", g.posed, "", "a detection posed by its own model was matched to it, by the least MSSD, each detection once (else mssd and mspd are -1, vsd empty)");
      t.field("mssd", g.mssd, "m", "BOP's maximum symmetry-aware surface distance");
      t.field("mspd", g.mspd, "px", "BOP's maximum symmetry-aware projection distance, in this image");
      t.field("vsd", g.vsd, "", "BOP's visible surface discrepancy at tau = 0.05, 0.10, ..., 0.50 of the diameter (delta 15 mm, step cost)");
    }, "the objects of a mesh kind with a model whose visible fraction is at least 0.1 (BOP19's targets)");
  }, "known models (perception.known_models): every view's pose estimation and its targets' pose errors (empty otherwise)");
  size_t n_reg = o.camera_registrations.size();
  a.list("camera_registrations", n_reg, [&](size_t i, RecordArchive& d) {
    if (d.reading() && o.camera_registrations.size() <= i) o.camera_registrations.resize(i + 1);
    RegistrationRecord& k = o.camera_registrations[i];
    d.field("time", k.time, "s", "simulated, since the trial began");
    d.field("rotation", k.rotation, "rad", "the correction's angle, from the extrinsics held before");
    d.field("translation", k.translation, "m", "how far the correction moved the camera's centre");
    d.field("bin_shift", k.bin_shift, "m", "the farthest the correction moved a point of the bin (its floor's and crop's corners)");
    d.field("rms", k.rms, "m", "point-to-plane residual of the image's points against the cell's static boxes at the end");
    d.field("points", k.points, "", "image points matched to the cell's surfaces");
  }, "camera mode: every registration of the camera against the cell (RegisterCamera) that succeeded");
  size_t n_ext = o.external_calls.size();
  a.list("external_calls", n_ext, [&](size_t i, RecordArchive& d) {
    if (d.reading() && o.external_calls.size() <= i) o.external_calls.resize(i + 1);
    ExternalCallRecord& k = o.external_calls[i];
    d.field("time", k.time, "s", "simulated, since the trial began");
    d.field("result", k.result, "", "answer, error (the component's own: it found nothing), crash (its output ended), timeout (no answer within external.timeout), not_protocol (an answer that is not protocol version 1, or in another frame than external.frame), cannot_start, io_error (the harness could not write the images); in a replay also not_recorded (a call past the recorded ones)");
    d.field("reason", k.reason, "", "what happened, for all but answer (the perception's failure reason)");
    d.field("write_seconds", k.write_seconds, "s", "wall: the view's images written for the component");
    d.field("answer_seconds", k.answer_seconds, "s", "wall: the request sent until the answer read (the component's own time: not in the stage's compute_seconds nor in plan_pick_time)");
    d.field("grasps", k.grasps, "", "grasp candidates in the answer");
    d.field("grasps_on_objects", k.grasps_on_objects, "", "of them, those whose pads close on one perceived object (tried by the pick, grasp_type external)");
    d.field("answer", k.answer, "", "results answer and error: the component's answer line as it came (minimanip render replays the trial from it, without the component)");
  }, "every call of the external component (grasp.source external; docs/external-components.md), in order");
  a.field("reported_total", o.reported_total, "", "ReportCompletion's total (-1: never reported)");
  size_t n_failures = o.failures.size();
  a.list("failures", n_failures, [&](size_t i, RecordArchive& f) {
    if (f.reading() && o.failures.size() <= i) o.failures.resize(i + 1);
    RecordedFailure& r = o.failures[i];
    f.field("stage", r.failure.stage, "", "");
    std::string k = failureKindName(r.failure.kind);
    f.field("kind", k, "", "");
    r.failure.kind = failureKindFromName(k);
    f.field("reason", r.failure.reason, "", "");
    f.field("sim_time", r.sim_time, "s", "since the trial started");
    f.field("handled", r.handled, "", "the tree started another action after it");
  }, "every failure an action recorded");
  size_t n_faults = o.faults.size();
  a.list("faults", n_faults, [&](size_t i, RecordArchive& f) {
    if (f.reading() && o.faults.size() <= i) o.faults.resize(i + 1);
    FaultRecord& r = o.faults[i];
    f.field("kind", r.kind, "", "the fault catalogue's name");
    f.field("stage", r.stage, "", "where it struck");
    f.field("sim_time", r.sim_time, "s", "onset, since the trial started");
    f.field("detected", r.detected, "", "a failure was recorded after the onset");
    f.field("detected_time", r.detected_time, "s", "when (-1: never)");
    f.field("detected_by", r.detected_by, "", "that failure's stage and kind");
    f.field("recovery", r.recovery, "", "what the trial achieved after the detection (its milestones), until it recovered or ended");
    f.field("outcome", r.outcome, "", "recovered, given_up (correctly: no action could succeed), unrecovered, no_effect or superseded (its object taken away by another fault first)");
    f.field("mttr", r.mttr, "s", "onset until the interrupted stage next succeeded, compute included (-1: did not)");
  }, "every fault injected");
  a.field("bt_log", bt_log, "", "the trial's .db3, relative to the results folder (null unless kept)");
  size_t n_stages = o.stages.size();
  a.list("stages", n_stages, [&](size_t i, RecordArchive& s) {
    if (s.reading() && o.stages.size() <= i) o.stages.resize(i + 1);
    StageRecord& st = o.stages[i];
    s.field("name", st.name, "", "");
    s.field("ok", st.ok, "", "");
    s.field("sim_seconds", st.sim_seconds, "s", "simulated");
    s.field("compute_seconds", st.compute_seconds, "s", "wall");
  }, "each stage in order");
}

void CampaignSummary::describe(RecordArchive& a) {
  a.field("schema", schema, "", "record format version");
  a.field("experiment", experiment, "", "its name");
  a.field("experiment_file", experiment_file, "", "");
  a.field("goal", goal, "", "task.goal: pick_one (a trial places one object) or clear_bin (every object; object_yield is the headline)");
  a.field("command", command, "", "the command line");
  a.field("seed", seed, "", "");
  a.field("hardware", hardware, "", "");
  a.field("tree", tree, "", "the behavior tree file");
  a.field("ik_solver", ik_solver, "", "the IK solver of the grasp and place poses: kinematics.solver with auto resolved");
  a.field("trials", trials, "", "");
  a.field("successes", successes, "", "");
  a.object("first_pass_yield", [&](RecordArchive& y) {
    y.field("value", first_pass_yield, "", "successes without recovery / trials");
    y.field("ci95", first_pass_ci95, "", "Wilson 95% interval");
  }, "");
  a.object("overall_yield", [&](RecordArchive& y) {
    y.field("value", overall_yield, "", "successes / trials");
    y.field("ci95", overall_ci95, "", "Wilson 95% interval");
  }, "");
  a.field("recovery_rate", recovery_rate, "", "recovered / needed (-1 when no recovery was needed)");
  a.field("recoveries_needed", recoveries_needed, "", "");
  a.object("cycle_time", [&](RecordArchive& c) {
    c.field("mean", cycle_mean, "s", "over successes");
    c.field("std", cycle_std, "s", "");
    c.field("max", cycle_max, "s", "");
  }, "");
  a.object("sim_time", [&](RecordArchive& c) {
    c.field("mean", sim_mean, "s", "over successes");
    c.field("std", sim_std, "s", "");
    c.field("max", sim_max, "s", "");
  }, "");
  a.field("throughput_per_hour", throughput_per_hour, "1/h", "objects placed per hour of every trial's cycle time, failed ones included");
  a.field("time_per_pick", time_per_pick, "s", "every trial's cycle time / objects placed");
  a.object("mean_time_breakdown", [&](RecordArchive& b) {
    for (const char* k : {"perception_time", "plan_pick_time", "execute_pick_time", "plan_place_time", "execute_place_time",
                          "return_home_time"})
      b.field(k, breakdown[k], "s", "mean over successes");
  }, "the cycle's parts");
  a.object("place_position_error_mm", [&](RecordArchive& c) {
    c.field("mean", place_mm_mean, "mm", "over successes");
    c.field("max", place_mm_max, "mm", "");
  }, "");
  a.object("in_hand_slip_mm", [&](RecordArchive& c) {
    c.field("mean", slip_mm_mean, "mm", "over successes");
    c.field("max", slip_mm_max, "mm", "");
  }, "");
  a.object("grasps", [&](RecordArchive& c) {
    c.field("top_down", top_down_grasps, "", "picks let go of that were grasped top-down");
    c.field("side", side_grasps, "", "picks let go of that were grasped from the side");
    c.field("deviation_mm_mean", grasp_dev_mm_mean, "mm",
            "the source's grasp-pose deviation (achieved in-hand position against the planned one, at the fingers' closing), over those picks");
    c.field("deviation_mm_max", grasp_dev_mm_max, "mm", "");
  }, "");
  a.object("camera_pose_error", [&](RecordArchive& c) {
    c.field("detections", detections, "", "objects found by camera perceptions, every trial");
    c.field("false_detections", false_detections, "", "detections near no object");
    c.field("missed_detections", missed_detections, "", "objects in the bin a perception did not find");
    c.field("centre_mm_mean", det_centre_mm_mean, "mm", "over the matched detections");
    c.field("centre_mm_max", det_centre_mm_max, "mm", "");
    c.field("rotation_deg_mean", det_rotation_deg_mean, "deg", "up to the boxes' symmetries");
    c.field("rotation_deg_max", det_rotation_deg_max, "deg", "");
    c.field("mssd_mm_mean", det_mssd_mm_mean, "mm", "BOP's MSSD");
    c.field("mssd_mm_max", det_mssd_mm_max, "mm", "");
  }, "camera perception against the simulator's truth (zeros in the other modes)");
  a.object("place_orientation_error_deg", [&](RecordArchive& c) {
    c.field("mean", orient_deg_mean, "deg", "over successes");
    c.field("max", orient_deg_max, "deg", "");
  }, "");
  a.field("collision_events", collision_events, "", "");
  a.field("collisions_per_100_trials", collisions_per_100, "", "");
  a.field("max_tracking_error_rad", max_tracking_error, "rad", "");
  a.field("sim_unstable", sim_unstable, "", "trials");
  a.field("dropped", dropped, "", "trials");
  a.field("failure_stages", failure_stages, "", "failed trials by stage");
  size_t n_kinds = faults.size();
  a.list("faults", n_kinds, [&](size_t i, RecordArchive& f) {
    if (f.reading() && faults.size() <= i) faults.resize(i + 1);
    FaultStats& s = faults[i];
    f.field("kind", s.kind, "", "");
    f.field("recoverable", s.recoverable, "", "some action of the robot can succeed after it (docs/faults.md)");
    f.field("injected", s.injected, "", "");
    f.field("no_effect", s.no_effect, "", "nothing failed after it");
    f.field("detected", s.detected, "", "a failure followed it");
    f.field("recovered", s.recovered, "", "the interrupted stage succeeded later and the trial succeeded (or failed after a later fault)");
    f.field("given_up", s.given_up, "", "unrecoverable kinds: noticed and moved on from without harm (never counted as recovered)");
    f.field("superseded", s.superseded, "", "its object was then taken away by another fault (not judged)");
    f.field("unrecovered", s.unrecovered, "", "");
    f.field("recovery", s.recovery, "", "recoverable kinds: recovered / (recovered + unrecovered); others: given_up / (given_up + unrecovered); -1: none");
    f.field("ci95", s.ci95, "", "its Wilson 95% interval");
    f.field("mttr_mean", s.mttr_mean, "s", "onset until the interrupted stage succeeded, compute included");
    f.field("mttr_max", s.mttr_max, "s", "");
  }, "recovery per fault kind injected");
  a.field("mtbf", mtbf, "s", "simulated time per failure the tree did not recover (-1: none)");
  a.field("protective_stops", protective_stops, "", "motions stopped by the controller: path tolerance (tracking) or contact force");
  a.field("protective_stops_contact", protective_stops_contact, "", "of them, on contact force");
  a.field("max_external_force", max_external_force, "N", "the largest over the trials");
  a.field("non_target_contacts_per_trial", non_target_contacts_per_trial, "", "touches of objects other than the one picked or held");
  a.field("neighbours_moved_mm_max", neighbours_moved_mm_max, "mm", "the farthest an object moved while another was picked");
  a.field("objects_placed", objects_placed, "", "");
  a.field("objects_spawned", objects_spawned, "", "objects in the bins at the trials' starts");
  // The clutter-removal protocol (VGN / GIGA): grasp success rate and declutter rate.
  auto rate = [](RecordArchive& ar, const char* key, Rate& r, const char* help) {
    ar.object(key, [&](RecordArchive& y) {
      y.field("value", r.value, "", "k / n; -1 when n is 0");
      y.field("ci95", r.ci95, "", "Wilson 95% interval (empty when n is 0)");
      y.field("k", r.k, "", "");
      y.field("n", r.n, "", "");
    }, help);
  };
  rate(a, "grasp_success_rate", clutter.grasp_success, "grasp attempts (closings of the fingers on a chosen grasp) whose object was released in the tray / attempts");
  rate(a, "declutter_rate", clutter.declutter, "objects released in the tray / objects in the bins at the trials' starts");
  a.object("pose_recall", [&](RecordArchive& p) {
    PoseRecall& r = pose_recall;
    p.field("views", r.views, "", "views whose segments the models were tried on");
    p.field("targets", r.targets, "", "objects of a mesh kind at least 0.1 visible in those views, counted once per view (BOP19's targets)");
    p.field("posed", r.posed, "", "of them, matched to a detection posed by their own model");
    p.field("ar", r.ar, "", "BOP19's average recall: the mean of the three below (-1: no targets)");
    p.field("ar_vsd", r.ar_vsd, "", "the share of targets with VSD < theta, over theta = 0.05 ... 0.5 and tau = 0.05 d ... 0.5 d");
    p.field("ar_mssd", r.ar_mssd, "", "the share with MSSD < theta d, theta = 0.05 ... 0.5");
    p.field("ar_mspd", r.ar_mspd, "", "the share with MSPD (scaled to a 640 px wide image) < theta, theta = 5 ... 50 px");
    rate(p, "mssd_10", r.mssd_10, "targets at least half visible whose MSSD < 0.1 d / those targets");
    p.field("seconds_per_view_mean", r.seconds_per_view_mean, "s", "wall: a view's pose estimation, every segment's");
    p.field("seconds_per_view_max", r.seconds_per_view_max, "s", "");
  }, "known models (perception.known_models): their poses against the simulator's truth (no views: zeros and -1)");
  a.field("attempt_results", attempt_results, "", "grasp attempts by result (in_tray, missed, dropped, let_go_elsewhere, halted, held_at_end)");
  size_t n_grades = clutter_by_grade.size();
  a.list("clutter_by_grade", n_grades, [&](size_t i, RecordArchive& g) {
    if (g.reading() && clutter_by_grade.size() <= i) clutter_by_grade.resize(i + 1);
    ClutterStats& c = clutter_by_grade[i];
    g.field("grade", c.grade, "", "a generated object's shape grade (objects.generated.grades)");
    rate(g, "grasp_success_rate", c.grasp_success, "over the attempts on objects of this grade");
    rate(g, "declutter_rate", c.declutter, "over the objects of this grade");
  }, "the same per shape grade of generated objects (attempts that closed near no object count only in the totals)");
  a.object("object_yield", [&](RecordArchive& y) {
    y.field("value", object_yield, "", "objects placed / objects spawned (bin clearing's yield)");
    y.field("ci95", object_yield_ci95, "", "Wilson 95% interval");
  }, "");
  a.object("object_first_pass_yield", [&](RecordArchive& y) {
    y.field("value", object_first_pass_yield, "", "objects placed with no failure since the previous placement / objects spawned");
    y.field("ci95", object_first_pass_ci95, "", "Wilson 95% interval");
  }, "");
  a.field("objects_left_in_bin", objects_left_in_bin, "", "");
  a.field("bins_cleared", bins_cleared, "", "trials that ended with the bin empty (never a trial whose spawn failed, a crash or a hang)");
  a.field("spawn_failures", spawn_failures, "", "trials whose scene could not be set up (failure_kind spawn): no robot ran, no object counted");
  a.field("timeouts", timeouts, "", "trials past the simulated-time budget");
  a.field("crashes", crashes, "", "trials whose worker process died in both attempts (failure_kind crash)");
  a.field("hangs", hangs, "", "trials the wall-clock watchdog stopped in both attempts (failure_kind hang)");
  a.field("wall_seconds", wall_seconds, "s", "wall time of this run of the campaign (after a resume: of the resumed part), workers' start-up included");
  a.field("trials_per_second", trials_per_second, "1/s", "trials this run finished / wall_seconds");
  a.object("environment", [&](RecordArchive& e) {
    e.field("minimanip", minimanip, "", "");
    e.field("mujoco", mujoco, "", "");
    e.field("ompl", ompl, "", "");
    e.field("compiler", compiler, "", "");
    e.field("cpu", cpu, "", "");
    e.field("cores", cores, "", "");
    e.field("host", host, "", "");
    e.field("renderer", renderer, "", "the OpenGL renderer, its version and EGL platform when the campaign rendered images (null otherwise): images, and camera-mode outcomes, are the same per renderer");
    e.field("jobs", jobs, "", "worker processes");
  }, "the machine and versions");
}

// ---- writer, reader, documenter ---------------------------------------------------------------

namespace {

class Writer final : public RecordArchive {
 public:
  explicit Writer(json& j) : j_(j) {}
  void field(const char* k, bool& v, const char*, const char*) override { j_[k] = v; }
  void field(const char* k, int& v, const char*, const char*) override { j_[k] = v; }
  void field(const char* k, long& v, const char*, const char*) override { j_[k] = v; }
  void field(const char* k, unsigned long& v, const char*, const char*) override { j_[k] = v; }
  void field(const char* k, double& v, const char*, const char*) override { j_[k] = v; }
  void field(const char* k, std::string& v, const char*, const char*) override { j_[k] = v.empty() ? json(nullptr) : json(v); }
  void field(const char* k, std::vector<std::string>& v, const char*, const char*) override { j_[k] = v; }
  void field(const char* k, std::vector<double>& v, const char*, const char*) override { j_[k] = v; }
  void field(const char* k, std::map<std::string, long>& v, const char*, const char*) override { j_[k] = v; }
  void object(const char* k, const std::function<void(RecordArchive&)>& body, const char*) override {
    json sub = json::object();
    Writer w(sub);
    body(w);
    j_[k] = sub;
  }
  void list(const char* k, size_t& n, const std::function<void(size_t, RecordArchive&)>& item, const char*) override {
    json arr = json::array();
    for (size_t i = 0; i < n; ++i) {
      json sub = json::object();
      Writer w(sub);
      item(i, w);
      arr.push_back(sub);
    }
    j_[k] = arr;
  }

 private:
  json& j_;
};

class Reader final : public RecordArchive {
 public:
  explicit Reader(const json& j) : j_(j) {}
  bool reading() const override { return true; }
  void field(const char* k, bool& v, const char*, const char*) override { read(k, v); }
  void field(const char* k, int& v, const char*, const char*) override { read(k, v); }
  void field(const char* k, long& v, const char*, const char*) override { read(k, v); }
  void field(const char* k, unsigned long& v, const char*, const char*) override { read(k, v); }
  void field(const char* k, double& v, const char*, const char*) override { read(k, v); }
  void field(const char* k, std::string& v, const char*, const char*) override {
    if (j_.contains(k) && j_[k].is_null()) v.clear();
    else read(k, v);
  }
  void field(const char* k, std::vector<std::string>& v, const char*, const char*) override { read(k, v); }
  void field(const char* k, std::vector<double>& v, const char*, const char*) override { read(k, v); }
  void field(const char* k, std::map<std::string, long>& v, const char*, const char*) override { read(k, v); }
  void object(const char* k, const std::function<void(RecordArchive&)>& body, const char*) override {
    if (!j_.contains(k) || !j_[k].is_object()) throw std::runtime_error(std::string("'") + k + "' is not an object");
    Reader r(j_[k]);
    body(r);
  }
  void list(const char* k, size_t& n, const std::function<void(size_t, RecordArchive&)>& item, const char*) override {
    if (!j_.contains(k) || !j_[k].is_array()) throw std::runtime_error(std::string("'") + k + "' is not a list");
    n = j_[k].size();
    for (size_t i = 0; i < n; ++i) {
      Reader r(j_[k][i]);
      item(i, r);
    }
  }

 private:
  template <class T>
  void read(const char* k, T& v) {
    if (!j_.contains(k)) throw std::runtime_error(std::string("missing field '") + k + "'");
    v = j_[k].get<T>();
  }
  const json& j_;
};

class Documenter final : public RecordArchive {
 public:
  std::ostringstream out;
  int depth = 0;
  void field(const char* k, bool&, const char* u, const char* h) override { line(k, "bool", u, h); }
  void field(const char* k, int&, const char* u, const char* h) override { line(k, "integer", u, h); }
  void field(const char* k, long&, const char* u, const char* h) override { line(k, "integer", u, h); }
  void field(const char* k, unsigned long&, const char* u, const char* h) override { line(k, "integer", u, h); }
  void field(const char* k, double&, const char* u, const char* h) override { line(k, "number", u, h); }
  void field(const char* k, std::string&, const char* u, const char* h) override { line(k, "text or null", u, h); }
  void field(const char* k, std::vector<std::string>&, const char* u, const char* h) override { line(k, "list of text", u, h); }
  void field(const char* k, std::vector<double>&, const char* u, const char* h) override { line(k, "list of numbers", u, h); }
  void field(const char* k, std::map<std::string, long>&, const char* u, const char* h) override { line(k, "map", u, h); }
  void object(const char* k, const std::function<void(RecordArchive&)>& body, const char* h) override {
    line(k, "object", "", h);
    ++depth;
    body(*this);
    --depth;
  }
  void list(const char* k, size_t&, const std::function<void(size_t, RecordArchive&)>& item, const char* h) override {
    line(k, "list of objects", "", h);
    ++depth;
    item(0, *this);
    --depth;
  }

 private:
  void line(const char* k, const char* type, const char* unit, const char* help) {
    out << std::string(2 * depth, ' ') << "- `" << k << "` (" << type << (*unit ? std::string(", ") + unit : "") << ")"
        << (*help ? std::string(": ") + help : "") << "\n";
  }
};

}  // namespace

std::string toJsonLine(TrialRecord& r) {
  json j = json::object();
  Writer w(j);
  r.describe(w);
  // Text that is not UTF-8 (a name read from a user's file, say) must not lose a trial's record:
  // such bytes are written as U+FFFD. Input is checked for UTF-8 where it enters; this is the net.
  return j.dump(-1, ' ', false, json::error_handler_t::replace);
}

TrialRecord fromJsonLine(const std::string& line, const std::string& where) {
  TrialRecord r;
  json j;
  try {
    j = json::parse(line);
  } catch (const std::exception& e) {
    throw InputError(where, std::string("not a trial record: ") + e.what());
  }
  // The version first: a folder written by another build is told apart from a damaged one.
  if (j.is_object() && j.contains("schema") && j["schema"].is_number_integer() && j["schema"].get<int>() != kTrialSchema)
    throw InputError(where, "a trial record of schema " + std::to_string(j["schema"].get<int>()) + ", written by another build; this build reads schema " +
                                std::to_string(kTrialSchema) + " (run into a new --out, or remove this folder)");
  try {
    Reader reader(j);
    r.describe(reader);
  } catch (const std::exception& e) {
    throw InputError(where, std::string("not a trial record: ") + e.what());
  }
  return r;
}

CampaignSummary summaryFromJson(const std::string& text, const std::string& where) {
  CampaignSummary s;
  try {
    const json j = json::parse(text);
    Reader reader(j);
    s.describe(reader);
  } catch (const std::exception& e) {
    throw InputError(where, std::string("not a campaign summary: ") + e.what());
  }
  return s;
}

std::string toJson(CampaignSummary& s) {
  json j = json::object();
  Writer w(j);
  s.describe(w);
  return j.dump(2, ' ', false, json::error_handler_t::replace);
}

std::string recordsMarkdown() {
  Documenter t;
  TrialRecord r;
  r.o.picks.resize(1);
  r.o.failures.resize(1);
  r.o.stages.resize(1);
  r.o.faults.resize(1);
  r.o.left.resize(1);
  r.o.detections.resize(1);
  r.o.camera_registrations.resize(1);
  r.o.external_calls.resize(1);
  r.o.grasp_selections.resize(1);
  r.o.grasp_selections[0].tried.resize(1);
  r.o.grasp_attempts.resize(1);
  r.o.pose_views.resize(1);
  r.o.pose_views[0].targets.resize(1);
  r.describe(t);
  Documenter s;
  CampaignSummary c;
  c.faults.resize(1);  // the documenter describes a list by its first item
  c.clutter_by_grade.resize(1);
  c.describe(s);
  return "`trials.jsonl`, one object per trial:\n\n" + t.out.str() + "\n`summary.json`:\n\n" + s.out.str();
}

}  // namespace mm
