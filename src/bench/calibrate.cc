#include "bench/calibrate.h"

#include <tinyxml2.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "campaign/trial.h"
#include "core/error.h"
#include "core/file_io.h"
#include "kinematics/ik.h"
#include "perception/calibration.h"
#include "render/renderer.h"
#include "sim/sim_world.h"

namespace mm {
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

constexpr const char* kBoardBody = "calibration_board";
constexpr double kBoardThickness = 0.004;  // [m]

// The experiment's scene with a ChArUco board added as a mocap body (its box's +z face printed),
// written beside the board's image in `dir`.
std::string calibrationScene(const Experiment& e, const CharucoBoardSpec& board, const fs::path& dir) {
  const fs::path image = dir / "charuco_board.png";
  writeBoardImage(board, image.string(), 128);
  tinyxml2::XMLDocument doc;
  if (doc.LoadFile(e.scene_path.c_str()) != tinyxml2::XML_SUCCESS) throw InputError(e.scene_path, "cannot read the scene");
  tinyxml2::XMLElement* root = doc.FirstChildElement("mujoco");
  tinyxml2::XMLElement* world = root ? root->FirstChildElement("worldbody") : nullptr;
  if (!world) throw InputError(e.scene_path, "no <worldbody>");
  // Written elsewhere, the scene names its files absolutely: its includes (URDF cell parts, MJCF),
  // its asset folders, and each asset file no folder of the compiler's applies to.
  const fs::path scene_dir = fs::absolute(fs::path(e.scene_path).parent_path());
  auto absolute = [&](tinyxml2::XMLElement* x, const char* attribute) {
    const char* f = x->Attribute(attribute);
    if (f && fs::path(f).is_relative()) x->SetAttribute(attribute, (scene_dir / f).lexically_normal().string().c_str());
  };
  std::set<std::string> has_dir;
  for (tinyxml2::XMLElement* c = root->FirstChildElement("compiler"); c; c = c->NextSiblingElement("compiler"))
    for (const char* folder : {"meshdir", "texturedir", "assetdir"})
      if (c->Attribute(folder)) {
        has_dir.insert(folder);
        absolute(c, folder);
      }
  std::function<void(tinyxml2::XMLElement*)> files = [&](tinyxml2::XMLElement* x) {
    for (tinyxml2::XMLElement* c = x->FirstChildElement(); c; c = c->NextSiblingElement()) {
      const std::string tag = c->Name();
      const bool in_dir = tag != "include" && (has_dir.count("assetdir") || has_dir.count(tag == "texture" ? "texturedir" : "meshdir"));
      if (!in_dir) absolute(c, "file");
      files(c);
    }
  };
  files(root);
  tinyxml2::XMLElement* asset = root->FirstChildElement("asset");
  if (!asset) asset = root->InsertNewChildElement("asset");
  tinyxml2::XMLElement* tex = asset->InsertNewChildElement("texture");
  tex->SetAttribute("name", "calibration_board");
  tex->SetAttribute("type", "2d");
  tex->SetAttribute("file", fs::absolute(image).string().c_str());
  tinyxml2::XMLElement* mat = asset->InsertNewChildElement("material");
  mat->SetAttribute("name", "calibration_board");
  mat->SetAttribute("texture", "calibration_board");
  mat->SetAttribute("specular", "0");
  mat->SetAttribute("shininess", "0");
  tinyxml2::XMLElement* body = world->InsertNewChildElement("body");
  body->SetAttribute("name", kBoardBody);
  body->SetAttribute("mocap", "true");
  body->SetAttribute("pos", "0 0 -5");
  tinyxml2::XMLElement* geom = body->InsertNewChildElement("geom");
  std::ostringstream size;
  size << 0.5 * board.faceSide() << " " << 0.5 * board.faceSide() << " " << 0.5 * kBoardThickness;
  geom->SetAttribute("type", "box");
  geom->SetAttribute("size", size.str().c_str());
  geom->SetAttribute("material", "calibration_board");
  geom->SetAttribute("contype", 0);
  geom->SetAttribute("conaffinity", 0);
  const fs::path out = dir / "calibration_scene.xml";
  if (doc.SaveFile(out.c_str()) != tinyxml2::XML_SUCCESS) throw std::runtime_error("cannot write " + out.string());
  return out.string();
}

Mat3 rotXYZ(double a, double b, double c) {
  return Mat3(Eigen::AngleAxisd(c, Vec3::UnitZ()) * Eigen::AngleAxisd(b, Vec3::UnitY()) * Eigen::AngleAxisd(a, Vec3::UnitX()));
}

double angleOf(const Mat3& R) { return Eigen::AngleAxisd(R).angle(); }

struct View {
  Pose T_base_gripper;
  Pose T_world_face;        // the board's printed face
  BoardObservation clean, noisy;
  double truth_px_max = 0, truth_px_rms = 0;  // clean detection vs the true projection
};

struct MethodResult {
  std::string method;
  bool noisy = false;
  Pose X;
  double rotation_error = 0, translation_error = 0;  // vs the truth [rad, m]
  AxxbResidual residual;
  double floor_mean = 0, floor_max = 0;  // bin-floor points moved [m]
};

struct MountingReport {
  std::string mounting, camera, skipped;
  int views = 0, attempts = 0;
  int rejected[4] = {0, 0, 0, 0};  // no IK solution, board turned too far from the camera, not all in view, not all found
  double coverage = 0;  // [rad] the largest rotation between two views' boards
  double max_tilt = 0;  // [rad] the largest angle between the board's normal and the optical axis
  double truth_px_max = 0, truth_px_rms = 0;
  int noisy_views = 0;
  std::vector<MethodResult> results;
};

}  // namespace

std::string runCalibration(const Experiment& e, const CalibrateOptions& o) {
  if (o.views < 15) throw InputError("--views", "expected at least 15 poses (the source's rule), got " + std::to_string(o.views));
  std::string why;
  auto renderer = Renderer::create(e.render.egl, &why);
  if (!renderer) throw InputError(e.file, "calibration needs an offscreen OpenGL context, and none can be made here: " + why);
  const CharucoBoardSpec board;
  const fs::path tmp = fs::temp_directory_path() / ("minimanip_calibrate_" + std::to_string(getpid()));
  fs::create_directories(tmp);
  const RobotModel robot = loadExperimentRobot(e);
  std::unique_ptr<SimWorld> world;
  try {
    world = SimWorld::load(calibrationScene(e, board, tmp), robot);
  } catch (...) {
    fs::remove_all(tmp);
    throw;
  }
  fs::remove_all(tmp);
  const auto ik = makeIkSolver("auto", robot);
  const auto [T_bin, bin_half] = world->site("bin_region");
  const int W = e.perception.camera_width, H = e.perception.camera_height;
  const std::vector<Vec3> corners = boardCorners(board);
  // The printed face is the board box's +z face, half its thickness above the body's frame.
  const Pose T_face_board = makePose(Vec3(0, 0, 0.5 * kBoardThickness), Mat3::Identity()) * board.T_face_board();
  // The board carried on the gripper: 0.25 m out along the TCP's x, 2 cm below it, its face turned
  // to look back up the TCP's z (at a camera above when the gripper points down).
  const Pose T_tcp_face = makePose(Vec3(0.25, 0, 0.02), Mat3(Eigen::AngleAxisd(M_PI, Vec3::UnitX())));

  std::vector<MountingReport> reports;
  for (const bool eye_in_hand : {false, true}) {
    MountingReport rep;
    rep.mounting = eye_in_hand ? "eye-in-hand" : "eye-to-hand";
    rep.camera = eye_in_hand ? "wrist_camera" : e.perception.camera;
    world->reset(robot.home());
    CameraModel cam;
    try {
      cam = renderer->camera(*world, rep.camera, W, H, e.file, eye_in_hand ? "the robot's wrist camera" : "perception.camera");
    } catch (const InputError& ex) {
      if (!eye_in_hand) throw;
      rep.skipped = std::string("no wrist camera on this robot (") + ex.what() + ")";
      reports.push_back(rep);
      continue;
    }
    const Pose T_tcp_camera = world->tcpPose().inverse() * cam.T_world_camera;  // the truth, eye-in-hand
    // Eye-in-hand: the board lies on the table beside the bin, face up.
    Vec3 rest = T_bin.translation();
    rest.y() = 0.0;
    rest.z() = world->surfaceBelow(rest + Vec3(0, 0, 0.5), -1) + 0.5 * kBoardThickness;
    const Pose T_world_rest = makePose(rest, Mat3::Identity());
    Rng rng = Rng::stream(o.seed, eye_in_hand ? 1 : 0, Purpose::kMisc);
    Rng noise_rng = Rng::stream(o.seed, eye_in_hand ? 1 : 0, Purpose::kCamera);
    std::vector<View> views;
    while (static_cast<int>(views.size()) < o.views && rep.attempts < 60 * o.views) {
      ++rep.attempts;
      View v;
      Pose T_world_tcp;
      const double yaw = rng.uniform(-0.7, 0.7), roll = rng.uniform(-0.45, 0.45), pitch = rng.uniform(-0.45, 0.45);
      const Vec3 shift(rng.uniform(-0.06, 0.06), rng.uniform(-0.06, 0.06), rng.uniform(-0.05, 0.05));
      if (!eye_in_hand) {
        // The board over the bin, 0.3 m up, turned about all three axes.
        v.T_world_face = makePose(T_bin.translation() + Vec3(0, 0, 0.3) + shift, rotXYZ(roll, pitch, yaw));
        T_world_tcp = v.T_world_face * T_tcp_face.inverse();
      } else {
        // The camera 0.35 m from the board's centre, looking at it from directions within 26 degrees of
        // straight above, turned about its axis.
        v.T_world_face = T_world_rest;
        const Mat3 tilt = rotXYZ(roll, pitch, 0);
        const Vec3 eye = rest + tilt * Vec3(0, 0, 0.35 + shift.z()) + Vec3(shift.x(), shift.y(), 0);
        const Vec3 z = (rest - eye).normalized();
        Vec3 x = (tilt * Vec3(std::cos(yaw), std::sin(yaw), 0));
        x = (x - z * z.dot(x)).normalized();
        Mat3 R;
        R.col(0) = x, R.col(1) = z.cross(x), R.col(2) = z;
        T_world_tcp = makePose(eye, R) * T_tcp_camera.inverse();
      }
      IkRequest req;
      req.target = T_world_tcp;  // the model's world frame is the robot's base frame
      req.seed = robot.home();
      req.nearest = true;
      const IkResult r = ik->solve(req, rng);
      if (!r.ok()) { ++rep.rejected[0]; continue; }
      world->setArm(r.q());
      world->updateKinematics();
      if (!eye_in_hand) world->setMocapPose(kBoardBody, v.T_world_face);
      else if (views.empty()) world->setMocapPose(kBoardBody, T_world_rest);
      world->updateKinematics();
      const CameraModel now = renderer->camera(*world, rep.camera, W, H, e.file);
      // The source's data rules: the whole board in view, its normal within 45 degrees of the axis.
      const Vec3 normal = v.T_world_face.linear().col(2);
      const Vec3 axis = now.T_world_camera.linear().col(2);
      const double tilt_angle = std::acos(std::clamp(-normal.dot(axis), -1.0, 1.0));
      if (tilt_angle > 45 * M_PI / 180) { ++rep.rejected[1]; continue; }
      bool inside = true;
      std::vector<Eigen::Vector2d> truth;
      for (const Vec3& c : corners) {
        const Vec3 p = now.project(v.T_world_face * T_face_board * c);
        inside = inside && p.z() > 0 && p.x() > 20 && p.y() > 20 && p.x() < W - 21 && p.y() < H - 21;
        truth.emplace_back(p.x(), p.y());
      }
      if (!inside) {
        ++rep.rejected[2];
        continue;
      }
      Frame f = renderer->render(*world, now, kRgb);
      v.clean = detectBoard(f, board);
      // A ChArUco board is found in part: half its corners are enough (the hand hides some of it from
      // the wrist camera).
      if (!v.clean.ok || 2 * v.clean.ids.size() < corners.size()) { ++rep.rejected[3]; continue; }
      double sum = 0;
      for (size_t i = 0; i < v.clean.ids.size(); ++i) {
        const double d = (v.clean.pixels[i] - truth[static_cast<size_t>(v.clean.ids[i])]).norm();
        v.truth_px_max = std::max(v.truth_px_max, d);
        sum += d * d;
      }
      v.truth_px_rms = std::sqrt(sum / static_cast<double>(v.clean.ids.size()));
      for (uint8_t& px : f.rgb) px = static_cast<uint8_t>(std::clamp(std::lround(px + noise_rng.normal(0, o.pixel_noise)), 0L, 255L));
      v.noisy = detectBoard(f, board);
      v.T_base_gripper = world->tcpPose();
      rep.max_tilt = std::max(rep.max_tilt, tilt_angle);
      views.push_back(v);
    }
    rep.views = static_cast<int>(views.size());
    if (rep.views < 15) {
      rep.skipped = "only " + std::to_string(rep.views) + " usable poses in " + std::to_string(rep.attempts) + " tries (no IK solution " +
                    std::to_string(rep.rejected[0]) + ", board turned away " + std::to_string(rep.rejected[1]) + ", not all in view " +
                    std::to_string(rep.rejected[2]) + ", not all corners found " + std::to_string(rep.rejected[3]) + ")";
      reports.push_back(rep);
      continue;
    }
    double rms = 0;
    for (size_t i = 0; i < views.size(); ++i) {
      rep.truth_px_max = std::max(rep.truth_px_max, views[i].truth_px_max);
      rms += views[i].truth_px_rms * views[i].truth_px_rms;
      for (size_t j = i + 1; j < views.size(); ++j)
        rep.coverage = std::max(rep.coverage, angleOf(views[i].clean.T_camera_board.linear().transpose() * views[j].clean.T_camera_board.linear()));
    }
    rep.truth_px_rms = std::sqrt(rms / static_cast<double>(views.size()));
    // The truth, and the bin floor's points it maps.
    const Pose X_true = eye_in_hand ? T_tcp_camera : cam.T_world_camera;
    std::vector<Vec3> floor;
    for (int i = -2; i <= 2; ++i)
      for (int j = -2; j <= 2; ++j) floor.push_back(T_bin * Vec3(0.5 * i * bin_half.x(), 0.5 * j * bin_half.y(), 0));
    // Eye-in-hand: the camera looking at the bin from 0.45 m above its centre.
    const Pose G_look = makePose(T_bin.translation() + Vec3(0, 0, 0.45), Mat3(Eigen::AngleAxisd(M_PI, Vec3::UnitX()))) * T_tcp_camera.inverse();
    for (const bool noisy : {false, true}) {
      std::vector<Pose> G, C;
      for (const View& v : views) {
        const BoardObservation& ob = noisy ? v.noisy : v.clean;
        if (!ob.ok) continue;
        G.push_back(v.T_base_gripper);
        C.push_back(ob.T_camera_board);
      }
      if (noisy) rep.noisy_views = static_cast<int>(G.size());
      if (G.size() < 3) continue;
      for (const std::string& m : handEyeMethods()) {
        MethodResult res;
        res.method = m;
        res.noisy = noisy;
        res.X = solveHandEye(m, G, C, eye_in_hand);
        res.rotation_error = angleOf(X_true.linear().transpose() * res.X.linear());
        res.translation_error = (res.X.translation() - X_true.translation()).norm();
        res.residual = axxbResidual(G, C, res.X, eye_in_hand);
        for (const Vec3& p : floor) {
          const Pose T_true = eye_in_hand ? Pose(G_look * X_true) : X_true;
          const Pose T_est = eye_in_hand ? Pose(G_look * res.X) : res.X;
          const double d = (T_est * (T_true.inverse() * p) - p).norm();
          res.floor_mean += d / static_cast<double>(floor.size());
          res.floor_max = std::max(res.floor_max, d);
        }
        rep.results.push_back(res);
      }
    }
    reports.push_back(rep);
  }

  // The report.
  createDirectories(o.out_dir);
  std::ostringstream md;
  md << std::fixed;
  md << "# Hand-eye calibration\n\n`" << o.command_line << "` (seed " << o.seed << ", " << o.views << " poses a mounting, "
     << W << "x" << H << " images, " << renderer->description() << ")\n\n";
  md << std::setprecision(0) << "ChArUco board " << board.squares_x << "x" << board.squares_y << " squares of " << 1000 * board.square << " mm (markers "
     << 1000 * board.marker << " mm, DICT_5X5_100), printed on a " << 1000 * board.faceSide() << " mm square; image noise: Gaussian, sigma "
     << std::setprecision(1) << o.pixel_noise << " grey levels.\n\n";
  json j;
  j["command"] = o.command_line;
  j["seed"] = o.seed;
  j["renderer"] = renderer->description();
  const MethodResult* chosen = nullptr;
  for (const MountingReport& rep : reports) {
    md << "## " << rep.mounting << " (" << rep.camera << ")\n\n";
    json jm;
    jm["camera"] = rep.camera;
    if (!rep.skipped.empty()) {
      md << "Skipped: " << rep.skipped << ".\n\n";
      jm["skipped"] = rep.skipped;
      j[rep.mounting] = jm;
      continue;
    }
    md << std::setprecision(1) << rep.views << " poses (of " << rep.attempts << " drawn), rotation coverage "
       << rep.coverage * 180 / M_PI << " deg, board normal at most " << rep.max_tilt * 180 / M_PI
       << " deg off the optical axis; detected corners vs the true projection: max " << std::setprecision(3)
       << rep.truth_px_max << " px, RMS " << rep.truth_px_rms << " px (no noise); " << rep.noisy_views
       << " poses with the board found under noise.\n\n";
    md << "| noise | method | rotation error | translation error | AX=XB residual (rot / trans) | bin floor moved mean / max |\n";
    md << "|---|---|---|---|---|---|\n";
    jm["views"] = rep.views;
    jm["coverage_deg"] = rep.coverage * 180 / M_PI;
    jm["corner_error_px_max"] = rep.truth_px_max;
    jm["corner_error_px_rms"] = rep.truth_px_rms;
    const MethodResult* best = nullptr;
    for (const MethodResult& r : rep.results) {
      md << "| " << (r.noisy ? "yes" : "no") << " | " << r.method << " | " << std::setprecision(3) << r.rotation_error * 180 / M_PI
         << " deg | " << std::setprecision(2) << 1000 * r.translation_error << " mm | " << std::setprecision(3)
         << r.residual.rotation * 180 / M_PI << " deg / " << std::setprecision(2) << 1000 * r.residual.translation << " mm | "
         << 1000 * r.floor_mean << " / " << 1000 * r.floor_max << " mm |\n";
      json jr = {{"method", r.method}, {"noise", r.noisy}, {"rotation_error_deg", r.rotation_error * 180 / M_PI},
                 {"translation_error_mm", 1000 * r.translation_error}, {"axxb_rotation_deg", r.residual.rotation * 180 / M_PI},
                 {"axxb_translation_mm", 1000 * r.residual.translation}, {"bin_floor_mean_mm", 1000 * r.floor_mean},
                 {"bin_floor_max_mm", 1000 * r.floor_max}};
      jm["results"].push_back(jr);
      // The choice a user can make: the smallest AX=XB residual, among the noisy runs.
      if (r.noisy && (!best || r.residual.translation + 0.5 * r.residual.rotation < best->residual.translation + 0.5 * best->residual.rotation))
        best = &r;
    }
    if (best) {
      md << "\nChosen (smallest AX=XB residual with noise, no truth used): " << best->method << ", bin floor moved "
         << std::setprecision(2) << 1000 * best->floor_mean << " mm mean, " << 1000 * best->floor_max << " mm max.\n";
      jm["chosen"] = best->method;
      if (!rep.mounting.empty() && rep.mounting == "eye-to-hand") chosen = best;
    }
    md << "\n";
    j[rep.mounting] = jm;
  }
  if (chosen) {
    const fs::path path = fs::path(o.out_dir) / (e.perception.camera + "_extrinsics.yaml");
    const Quat q(chosen->X.linear());
    std::ostringstream f;
    f << std::setprecision(10) << "# minimanip calibrate: eye-to-hand, method " << chosen->method << ", with image noise\n"
      << "camera: " << e.perception.camera << "\n"
      << "position: [" << chosen->X.translation().x() << ", " << chosen->X.translation().y() << ", " << chosen->X.translation().z() << "]\n"
      << "quaternion_wxyz: [" << q.w() << ", " << q.x() << ", " << q.y() << ", " << q.z() << "]\n";
    writeFileAtomically(path, f.str());
    md << "Written for camera perception (`perception.extrinsics`): `" << path.string() << "`.\n";
    j["extrinsics_file"] = path.string();
  }
  writeFileAtomically(fs::path(o.out_dir) / "calibration.json", j.dump(2) + "\n");
  writeFileAtomically(fs::path(o.out_dir) / "calibration.md", md.str());
  return md.str();
}


}  // namespace mm
