#include "render/bop_writer.h"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "core/file_io.h"
#include "core/pose.h"
#include "render/image_io.h"
#include "sim/sim_world.h"

namespace mm {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

constexpr double kMm = 1000.0;                 // [mm] per metre
constexpr double kDepthScale = kDepthPngScale * kMm;  // BOP's depth_scale: a depth PNG's unit [mm]

std::string sixDigits(uint64_t n) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%06llu", static_cast<unsigned long long>(n));
  return buf;
}

json rowMajor(const Mat3& R) {
  json out = json::array();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out.push_back(R(r, c));
  return out;
}

json millimetres(const Vec3& t) { return json::array({t.x() * kMm, t.y() * kMm, t.z() * kMm}); }

// BOP's bounding box [x, y, w, h] of a mask's pixels; [-1, -1, -1, -1] when it has none.
json bbox(const cv::Mat& mask) {
  std::vector<cv::Point> on;
  cv::findNonZero(mask, on);
  if (on.empty()) return json::array({-1, -1, -1, -1});
  const cv::Rect r = cv::boundingRect(on);
  return json::array({r.x, r.y, r.width, r.height});
}

void writeMask(const fs::path& path, const cv::Mat& mask) {
  if (!cv::imwrite(path.string(), mask)) throw std::runtime_error(path.string() + ": cannot write the mask");
}

// A stable digest of a surface (vertices to a micrometre): the same geometry, the same model.
uint64_t digest(const TriangleMesh& mesh) {
  uint64_t h = 1469598103934665603ull;  // FNV-1a
  auto mix = [&](int64_t v) {
    for (int b = 0; b < 8; ++b) {
      h ^= static_cast<uint64_t>(v >> (8 * b)) & 0xffu;
      h *= 1099511628211ull;
    }
  };
  for (const Vec3& p : mesh.vertices)
    for (int k = 0; k < 3; ++k) mix(std::llround(p[k] * 1e6));
  for (const auto& f : mesh.faces)
    for (int k : f) mix(k);
  return h;
}

}  // namespace

struct BopWriter::Model {
  uint64_t digest = 0;
  TriangleMesh surface;  ///< [m], the object's frame
  json symmetries;       ///< models_info's symmetry entries (empty: none declared)
};

struct BopWriter::Scene {
  uint64_t id = 0;
  fs::path dir;
  int images = 0;
  json camera = json::object(), gt = json::object(), gt_info = json::object();
};

BopWriter::BopWriter(fs::path root, std::string split) : root_(std::move(root)), split_(std::move(split)) {
  createDirectories(root_ / "models");
}

BopWriter::~BopWriter() = default;

int BopWriter::models() const { return static_cast<int>(models_.size()); }

void BopWriter::beginScene(uint64_t scene) {
  if (scene_) writeScene();
  scene_ = std::make_unique<Scene>();
  scene_->id = scene;
  scene_->dir = root_ / split_ / sixDigits(scene);
  for (const char* sub : {"rgb", "depth", "mask", "mask_visib"}) createDirectories(scene_->dir / sub);
}

void BopWriter::declareSymmetries(std::shared_ptr<const std::vector<ConvexPiece>> pieces, std::vector<Mat3> group) {
  declared_[std::move(pieces)] = std::move(group);
}

int BopWriter::modelId(const SimWorld& world, int object) {
  const auto key = std::make_pair(world.modelSerial(), object);
  if (const auto it = model_of_.find(key); it != model_of_.end()) return it->second;
  Model m;
  m.surface = world.objectSurface(object);
  m.digest = digest(m.surface);
  int id = 0;
  for (size_t i = 0; i < models_.size() && !id; ++i)
    if (models_[i].digest == m.digest) id = static_cast<int>(i) + 1;
  if (!id) {
    // Symmetries as the harness knows them: a box's rotations onto itself, a cylinder's turns about
    // its axis and end over end; a mesh object's, those its kind declares (declareSymmetries).
    const ObjectState o = world.object(object);
    json sym = json::object();
    auto flat = [](const Mat3& R) {
      json t = json::array();
      for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) t.push_back(r < 3 && c < 3 ? R(r, c) : r == c ? 1.0 : 0.0);
      return t;
    };
    if (o.shape == ObjectShape::kBox) {
      json d = json::array();
      const std::vector<Mat3> all = boxSymmetries(o.half_size);
      for (size_t k = 1; k < all.size(); ++k) d.push_back(flat(all[k]));
      sym["symmetries_discrete"] = d;
    } else if (o.shape == ObjectShape::kCylinder) {
      sym["symmetries_continuous"] = json::array({{{"axis", {0, 0, 1}}, {"offset", {0, 0, 0}}}});
      sym["symmetries_discrete"] = json::array({flat(Vec3(1, -1, -1).asDiagonal().toDenseMatrix())});
    } else if (const auto it = o.pieces ? declared_.find(o.pieces) : declared_.end(); it != declared_.end() && it->second.size() > 1) {
      json d = json::array();  // every element of the group but the identity (BOP lists them all)
      for (size_t k = 1; k < it->second.size(); ++k) d.push_back(flat(it->second[k]));
      sym["symmetries_discrete"] = d;
    }
    m.symmetries = sym;
    models_.push_back(std::move(m));
    id = static_cast<int>(models_.size());
  }
  model_of_[key] = id;
  return id;
}

void BopWriter::addView(Renderer& renderer, const SimWorld& world, const Frame& seen) {
  if (!scene_) throw std::logic_error("BopWriter::addView before beginScene");
  const CameraModel& cam = seen.camera;
  const int w = cam.width, h = cam.height;
  if (seen.depth.size() != static_cast<size_t>(w) * static_cast<size_t>(h)) throw std::logic_error("BopWriter::addView: a view without its depth");
  // Where the camera drew from: its mount's pose, and the offset of a knocked camera.
  Pose T_world_camera = cam.T_world_camera;
  const int cam_id = mj_name2id(world.mujocoModel(), mjOBJ_CAMERA, cam.name.c_str());
  if (cam_id >= 0) T_world_camera = T_world_camera * world.cameraOffset(cam_id);
  const Pose T_camera_world = T_world_camera.inverse();
  const Frame colour = renderer.render(world, cam, kRgb | kSegmentation);
  const int im = scene_->images++;
  const std::string name = sixDigits(static_cast<uint64_t>(im));
  writeRgbPng((scene_->dir / "rgb" / (name + ".png")).string(), colour);
  writeDepthPng((scene_->dir / "depth" / (name + ".png")).string(), seen);

  json gts = json::array(), infos = json::array();
  for (int k = 0; k < world.numObjects(); ++k) {
    // Objects whose bounding sphere is behind the camera or far out of the view (parked ones) are
    // not rendered alone (the sphere's image grows off the axis: twice its size on it is allowed).
    const ObjectState o = world.object(k);
    const Pose T_world_object = world.objectDrawnPose(k);
    const Vec3 c = T_camera_world * T_world_object.translation();
    const double radius = o.half_size.norm();
    if (c.z() + radius <= 0.01) continue;
    const double z = std::max(c.z(), 0.01);
    const double u = cam.fx * c.x() / z + cam.cx, v = cam.fy * c.y() / z + cam.cy, r_px = 2 * cam.fx * radius / z + 2;
    if (c.z() > radius && (u + r_px < 0 || u - r_px > w - 1 || v + r_px < 0 || v - r_px > h - 1)) continue;
    const uint8_t label = static_cast<uint8_t>(kSegmentObject0 + k);
    const Frame alone = renderer.render(world, cam, kDepth, label);
    cv::Mat mask(h, w, CV_8UC1), visib(h, w, CV_8UC1);
    int all = 0, valid = 0, seen_px = 0;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const size_t i = static_cast<size_t>(y) * static_cast<size_t>(w) + static_cast<size_t>(x);
        const bool on = alone.depth[i] > 0;
        const bool vis = colour.segmentation[i] == label;
        mask.at<uint8_t>(y, x) = on ? 255 : 0;
        visib.at<uint8_t>(y, x) = vis ? 255 : 0;
        all += on;
        valid += on && seen.depth[i] > 0;
        seen_px += vis;
      }
    if (all == 0) continue;
    const int gt = static_cast<int>(gts.size());
    const Pose T_camera_object = T_camera_world * T_world_object;
    gts.push_back({{"obj_id", modelId(world, k)},
                   {"cam_R_m2c", rowMajor(T_camera_object.linear())},
                   {"cam_t_m2c", millimetres(T_camera_object.translation())}});
    infos.push_back({{"bbox_obj", bbox(mask)},
                     {"bbox_visib", bbox(visib)},
                     {"px_count_all", all},
                     {"px_count_valid", valid},
                     {"px_count_visib", seen_px},
                     {"visib_fract", static_cast<double>(seen_px) / all}});
    const std::string file = name + "_" + sixDigits(static_cast<uint64_t>(gt)) + ".png";
    writeMask(scene_->dir / "mask" / file, mask);
    writeMask(scene_->dir / "mask_visib" / file, visib);
  }
  const std::string key = std::to_string(im);
  scene_->camera[key] = {{"cam_K", {cam.fx, 0.0, cam.cx, 0.0, cam.fy, cam.cy, 0.0, 0.0, 1.0}},
                         {"depth_scale", kDepthScale},
                         {"cam_R_w2c", rowMajor(T_camera_world.linear())},
                         {"cam_t_w2c", millimetres(T_camera_world.translation())}};
  scene_->gt[key] = gts;
  scene_->gt_info[key] = infos;
  ++views_;
  camera_ = cam;
}

void BopWriter::writeScene() {
  if (scene_->images == 0) {  // a trial whose robot took no image: no scene
    std::error_code ec;
    fs::remove_all(scene_->dir, ec);
    scene_.reset();
    return;
  }
  ++scenes_;
  writeFileAtomically(scene_->dir / "scene_camera.json", scene_->camera.dump(2));
  writeFileAtomically(scene_->dir / "scene_gt.json", scene_->gt.dump(2));
  writeFileAtomically(scene_->dir / "scene_gt_info.json", scene_->gt_info.dump(2));
  scene_.reset();
}

void BopWriter::finish() {
  if (scene_) writeScene();
  json info = json::object();
  for (size_t i = 0; i < models_.size(); ++i) {
    const Model& m = models_[i];
    const int id = static_cast<int>(i) + 1;
    // One vertex per corner of each triangle, with the triangle's normal (flat faces, as drawn).
    std::string ply;
    const size_t nf = m.surface.faces.size();
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "ply\nformat ascii 1.0\ncomment minimanip: object surface [mm]\nelement vertex %zu\n"
                  "property float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
                  "element face %zu\nproperty list uchar int vertex_indices\nend_header\n",
                  3 * nf, nf);
    ply += buf;
    Vec3 lo = Vec3::Constant(1e9), hi = Vec3::Constant(-1e9);
    for (const auto& f : m.surface.faces) {
      const Vec3 &a = m.surface.vertices[static_cast<size_t>(f[0])], &b = m.surface.vertices[static_cast<size_t>(f[1])],
                 &c = m.surface.vertices[static_cast<size_t>(f[2])];
      Vec3 n = (b - a).cross(c - a);
      n = n.norm() > 0 ? Vec3(n.normalized()) : Vec3(0, 0, 1);
      for (const Vec3* p : {&a, &b, &c}) {
        std::snprintf(buf, sizeof buf, "%.6f %.6f %.6f %.6f %.6f %.6f\n", p->x() * kMm, p->y() * kMm, p->z() * kMm, n.x(), n.y(), n.z());
        ply += buf;
      }
    }
    for (size_t k = 0; k < nf; ++k) {
      std::snprintf(buf, sizeof buf, "3 %zu %zu %zu\n", 3 * k, 3 * k + 1, 3 * k + 2);
      ply += buf;
    }
    for (const Vec3& p : m.surface.vertices) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    double diameter = 0;  // the farthest two points of the surface
    const std::vector<Vec3>& v = m.surface.vertices;
    for (size_t a = 0; a < v.size(); ++a)
      for (size_t b = a + 1; b < v.size(); ++b) diameter = std::max(diameter, (v[a] - v[b]).squaredNorm());
    writeFileAtomically(root_ / "models" / ("obj_" + sixDigits(static_cast<uint64_t>(id)) + ".ply"), ply);
    json e = {{"diameter", std::sqrt(diameter) * kMm},
              {"min_x", lo.x() * kMm}, {"min_y", lo.y() * kMm}, {"min_z", lo.z() * kMm},
              {"size_x", (hi - lo).x() * kMm}, {"size_y", (hi - lo).y() * kMm}, {"size_z", (hi - lo).z() * kMm}};
    for (const auto& [k, s] : m.symmetries.items()) e[k] = s;
    info[std::to_string(id)] = e;
  }
  writeFileAtomically(root_ / "models" / "models_info.json", info.dump(2));
  if (views_ > 0) {
    const json camera = {{"cx", camera_.cx}, {"cy", camera_.cy}, {"fx", camera_.fx}, {"fy", camera_.fy},
                         {"width", camera_.width}, {"height", camera_.height}, {"depth_scale", kDepthScale}};
    writeFileAtomically(root_ / "camera.json", camera.dump(2));
  }
}

}  // namespace mm
