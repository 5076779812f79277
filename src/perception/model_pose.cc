#include "perception/model_pose.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <stdexcept>
#include <unordered_map>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include "perception/segmentation.h"

namespace mm {

// ---- the model ---------------------------------------------------------------------------------

ObjectModel ObjectModel::fromMesh(std::string name, std::vector<Vec3> vertices, std::vector<std::array<int, 3>> faces,
                                  const std::vector<Mat3>& generators) {
  ObjectModel m;
  m.name = std::move(name);
  m.vertices = std::move(vertices);
  m.faces = std::move(faces);
  double volume = 0;
  for (const auto& f : m.faces) volume += m.vertices[f[0]].dot(m.vertices[f[1]].cross(m.vertices[f[2]])) / 6;
  if (volume < 0)
    for (auto& f : m.faces) std::swap(f[1], f[2]);
  for (size_t i = 0; i < m.vertices.size(); ++i)
    for (size_t j = i + 1; j < m.vertices.size(); ++j) m.diameter = std::max(m.diameter, (m.vertices[i] - m.vertices[j]).norm());
  m.symmetries = symmetryGroup(generators);
  return m;
}

double mssd(const ObjectModel& m, const Pose& est, const Pose& truth) {
  double e = std::numeric_limits<double>::infinity();
  for (const Mat3& S : m.symmetries) {
    const Pose sym = truth * makePose(Vec3::Zero(), S);
    double worst = 0;
    for (const Vec3& v : m.vertices) worst = std::max(worst, (est * v - sym * v).squaredNorm());
    e = std::min(e, std::sqrt(worst));
  }
  return e;
}

double mspd(const ObjectModel& m, const Pose& est, const Pose& truth, const CameraModel& cam) {
  double e = std::numeric_limits<double>::infinity();
  for (const Mat3& S : m.symmetries) {
    const Pose sym = truth * makePose(Vec3::Zero(), S);
    double worst = 0;
    for (const Vec3& v : m.vertices) worst = std::max(worst, (cam.project(est * v) - cam.project(sym * v)).head<2>().squaredNorm());
    e = std::min(e, std::sqrt(worst));
  }
  return e;
}

// ---- drawing -----------------------------------------------------------------------------------

std::array<int, 4> modelWindow(const ObjectModel& m, const Pose& T_world_object, const CameraModel& cam, bool clip) {
  const Pose T_cam_object = cam.T_world_camera.inverse() * T_world_object;
  double u0 = INFINITY, v0 = INFINITY, u1 = -INFINITY, v1 = -INFINITY;
  for (const Vec3& x : m.vertices) {
    const Vec3 p = T_cam_object * x;
    if (p.z() <= 1e-3) return {0, 0, 0, 0};
    const double u = cam.fx * p.x() / p.z() + cam.cx, v = cam.fy * p.y() / p.z() + cam.cy;
    u0 = std::min(u0, u), u1 = std::max(u1, u), v0 = std::min(v0, v), v1 = std::max(v1, v);
  }
  // Unclipped: up to twice the image's size beyond each edge (a pose just in front of the camera
  // projects anywhere; its drawing must stay a size that can be held).
  auto bound = [&](double x, int hi) {
    return static_cast<int>(clip ? std::clamp(x, 0.0, static_cast<double>(hi)) : std::clamp(x, -2.0 * hi, 3.0 * hi));
  };
  return {bound(std::floor(u0) - 1, cam.width), bound(std::floor(v0) - 1, cam.height), bound(std::ceil(u1) + 2, cam.width),
          bound(std::ceil(v1) + 2, cam.height)};
}

ModelDrawing drawModel(const ObjectModel& m, const Pose& T_world_object, const CameraModel& cam, int u0, int v0, int u1, int v1) {
  ModelDrawing d;
  d.u0 = u0, d.v0 = v0, d.width = std::max(0, u1 - u0), d.height = std::max(0, v1 - v0);
  d.depth.assign(static_cast<size_t>(d.width) * d.height, 0.0f);
  d.face.assign(d.depth.size(), -1);
  if (d.depth.empty()) return d;
  const Pose T_cam_object = cam.T_world_camera.inverse() * T_world_object;
  std::vector<Vec3> p(m.vertices.size());
  for (size_t i = 0; i < p.size(); ++i) p[i] = T_cam_object * m.vertices[i];
  for (size_t f = 0; f < m.faces.size(); ++f) {
    const Vec3 &a = p[m.faces[f][0]], &b = p[m.faces[f][1]], &c = p[m.faces[f][2]];
    if (a.z() <= 1e-3 || b.z() <= 1e-3 || c.z() <= 1e-3) continue;
    const Vec3 n = (b - a).cross(c - a);
    const double nd = n.dot(a);
    if (nd >= 0) continue;  // seen from behind (outward normals) or edge on
    // The triangle in the image, and the pixels whose centres fall inside it.
    const double ua = cam.fx * a.x() / a.z() + cam.cx, va = cam.fy * a.y() / a.z() + cam.cy;
    const double ub = cam.fx * b.x() / b.z() + cam.cx, vb = cam.fy * b.y() / b.z() + cam.cy;
    const double uc = cam.fx * c.x() / c.z() + cam.cx, vc = cam.fy * c.y() / c.z() + cam.cy;
    const double area = (ub - ua) * (vc - va) - (uc - ua) * (vb - va);
    if (std::abs(area) < 1e-12) continue;
    // Clipped to the window as doubles (a pose far off projects anywhere; no int overflows).
    const int ulo = static_cast<int>(std::ceil(std::clamp(std::min({ua, ub, uc}), static_cast<double>(u0), static_cast<double>(u1))));
    const int uhi = static_cast<int>(std::floor(std::clamp(std::max({ua, ub, uc}), static_cast<double>(u0) - 1, static_cast<double>(u1 - 1))));
    const int vlo = static_cast<int>(std::ceil(std::clamp(std::min({va, vb, vc}), static_cast<double>(v0), static_cast<double>(v1))));
    const int vhi = static_cast<int>(std::floor(std::clamp(std::max({va, vb, vc}), static_cast<double>(v0) - 1, static_cast<double>(v1 - 1))));
    for (int v = vlo; v <= vhi; ++v)
      for (int u = ulo; u <= uhi; ++u) {
        const double w0 = ((ub - u) * (vc - v) - (uc - u) * (vb - v)) / area;
        const double w1 = ((uc - u) * (va - v) - (ua - u) * (vc - v)) / area;
        const double w2 = 1 - w0 - w1;
        if (w0 < 0 || w1 < 0 || w2 < 0) continue;
        // The face's plane along the pixel's ray: z = (n . a) / (n . ray), ray = ((u-cx)/fx, (v-cy)/fy, 1).
        const double z = nd / (n.x() * (u - cam.cx) / cam.fx + n.y() * (v - cam.cy) / cam.fy + n.z());
        const size_t k = static_cast<size_t>(v - v0) * d.width + (u - u0);
        if (z > 0 && (d.depth[k] == 0 || z < d.depth[k])) d.depth[k] = static_cast<float>(z), d.face[k] = static_cast<int>(f);
      }
  }
  return d;
}

std::vector<double> vsd(const ObjectModel& m, const Pose& est, const Pose& truth, const CameraModel& cam,
                        const std::vector<float>& depth, double delta, const std::vector<double>& taus) {
  const std::array<int, 4> we = modelWindow(m, est, cam), wt = modelWindow(m, truth, cam);
  // The union of the two windows (an empty one, a pose behind the camera, adds nothing).
  std::array<int, 4> w = wt;
  if (wt[2] <= wt[0]) w = we;
  else if (we[2] > we[0]) w = {std::min(we[0], wt[0]), std::min(we[1], wt[1]), std::max(we[2], wt[2]), std::max(we[3], wt[3])};
  std::vector<double> errors(taus.size(), 1.0);
  if (w[2] <= w[0] || w[3] <= w[1] || depth.size() != static_cast<size_t>(cam.width) * cam.height) return errors;
  const ModelDrawing de = drawModel(m, est, cam, w[0], w[1], w[2], w[3]), dt = drawModel(m, truth, cam, w[0], w[1], w[2], w[3]);
  long union_count = 0, inter_count = 0;
  std::vector<long> far(taus.size(), 0);  // pixels of the intersection whose distances differ by tau or more
  for (int v = w[1]; v < w[3]; ++v)
    for (int u = w[0]; u < w[2]; ++u) {
      const float ze = de.at(u, v), zt = dt.at(u, v);
      if (ze <= 0 && zt <= 0) continue;
      // Depth to distance along the pixel's ray, for the view and both drawings alike.
      const double ray = std::hypot((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1.0);
      const float zs = depth[static_cast<size_t>(v) * cam.width + u];
      const double ds = zs > 0 && std::isfinite(zs) ? zs * ray : 0.0, de_ = ze * ray, dt_ = zt * ray;
      const bool seen_t = zt > 0 && (ds == 0 || dt_ - ds <= delta);
      const bool seen_e = ze > 0 && (ds == 0 || de_ - ds <= delta || seen_t);
      if (!seen_t && !seen_e) continue;
      ++union_count;
      if (!(seen_t && seen_e)) continue;
      ++inter_count;
      const double apart = std::abs(de_ - dt_) / m.diameter;
      for (size_t i = 0; i < taus.size(); ++i) far[i] += apart >= taus[i];
    }
  if (union_count == 0) return errors;
  for (size_t i = 0; i < taus.size(); ++i)
    errors[i] = static_cast<double>(far[i] + (union_count - inter_count)) / static_cast<double>(union_count);
  return errors;
}

// ---- the estimator -----------------------------------------------------------------------------

namespace {

// An oriented point: a surface point and its outward normal.
struct Oriented {
  Vec3 p, n;
};

// Points on a voxel grid `step` apart: the points of each voxel averaged, kept apart where their
// normals differ by more than 30 degrees (an edge's two faces stay two points).
std::vector<Oriented> thin(const std::vector<Oriented>& in, double step) {
  std::map<std::array<long, 3>, std::vector<std::pair<Oriented, int>>> cells;  // ordered: the same input, the same output
  for (const Oriented& x : in) {
    const std::array<long, 3> key{std::lround(std::floor(x.p.x() / step)), std::lround(std::floor(x.p.y() / step)),
                                  std::lround(std::floor(x.p.z() / step))};
    auto& groups = cells[key];
    bool joined = false;
    for (auto& [g, count] : groups)
      if (g.n.normalized().dot(x.n) > std::cos(M_PI / 6)) {
        g.p += x.p, g.n += x.n, ++count, joined = true;
        break;
      }
    if (!joined) groups.push_back({x, 1});
  }
  std::vector<Oriented> out;
  for (const auto& [key, groups] : cells)
    for (const auto& [g, count] : groups) out.push_back({g.p / count, g.n.normalized()});
  return out;
}

// Points on every face, on a barycentric grid `step` apart at most, with the face's normal; none
// closer than `edge_clearance` to a sharp edge (two faces meeting at more than 20 degrees), where
// a camera's normals, fitted over a neighbourhood, bend round the edge.
std::vector<Oriented> surfacePoints(const ObjectModel& m, double step, double edge_clearance) {
  std::map<std::pair<int, int>, std::vector<Vec3>> edge_normals;
  for (const auto& f : m.faces) {
    const Vec3 n = (m.vertices[f[1]] - m.vertices[f[0]]).cross(m.vertices[f[2]] - m.vertices[f[0]]).normalized();
    for (int e = 0; e < 3; ++e) edge_normals[{std::min(f[e], f[(e + 1) % 3]), std::max(f[e], f[(e + 1) % 3])}].push_back(n);
  }
  std::vector<std::pair<Vec3, Vec3>> sharp;
  for (const auto& [e, ns] : edge_normals)
    for (size_t i = 1; i < ns.size(); ++i)
      if (ns[0].dot(ns[i]) < std::cos(20 * M_PI / 180)) {
        sharp.push_back({m.vertices[static_cast<size_t>(e.first)], m.vertices[static_cast<size_t>(e.second)]});
        break;
      }
  auto nearEdge = [&](const Vec3& x) {
    for (const auto& [a, b] : sharp) {
      const Vec3 ab = b - a;
      const double t = std::clamp((x - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
      if ((a + t * ab - x).squaredNorm() < edge_clearance * edge_clearance) return true;
    }
    return false;
  };
  std::vector<Oriented> pts;
  for (const auto& f : m.faces) {
    const Vec3 &a = m.vertices[f[0]], &b = m.vertices[f[1]], &c = m.vertices[f[2]];
    const Vec3 cross = (b - a).cross(c - a);
    if (cross.norm() < 1e-12) continue;
    const int k = std::max(1, static_cast<int>(std::ceil(std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()}) / step)));
    for (int i = 0; i <= k; ++i)
      for (int j = 0; i + j <= k; ++j) {
        const Vec3 x = a + (b - a) * (static_cast<double>(i) / k) + (c - a) * (static_cast<double>(j) / k);
        if (!nearEdge(x)) pts.push_back({x, cross.normalized()});
      }
  }
  return pts;
}

// A rectangle on a plane: its centre, its long and short axes and the plane's normal (the
// columns of R, a right-handed frame), and its half sides.
struct PlaneRect {
  Mat3 R;
  Vec3 centre;
  double half_long = 0, half_short = 0;
};

// The smallest rectangle round `points` on the plane through `on` with normal `n` (OpenCV's
// minAreaRect over the points in a basis of the plane): a face's sides, or a segment's.
PlaneRect rectOn(const std::vector<Vec3>& points, const Vec3& n, const Vec3& on) {
  const Vec3 u = n.unitOrthogonal(), v = n.cross(u);
  std::vector<cv::Point2f> flat;
  flat.reserve(points.size());
  for (const Vec3& p : points) flat.emplace_back(static_cast<float>(u.dot(p - on)), static_cast<float>(v.dot(p - on)));
  const cv::RotatedRect r = cv::minAreaRect(flat);
  const double a = r.angle * M_PI / 180;
  Vec3 e1 = std::cos(a) * u + std::sin(a) * v;
  double h1 = r.size.width / 2.0, h2 = r.size.height / 2.0;
  if (h1 < h2) std::swap(h1, h2), e1 = n.cross(e1);
  PlaneRect out;
  out.R.col(0) = e1, out.R.col(1) = n.cross(e1), out.R.col(2) = n;
  out.centre = on + r.center.x * u + r.center.y * v;
  out.half_long = h1, out.half_short = h2;
  return out;
}

// A model's plane faces: its triangles grouped by the plane they lie on (normals within a degree,
// offsets within 0.1 mm), each group of at least `min_area` as its smallest rectangle.
std::vector<PlaneRect> planeFaces(const ObjectModel& m, double min_area) {
  struct Group {
    Vec3 n;
    double d = 0, area = 0;
    std::vector<Vec3> corners;
  };
  std::vector<Group> groups;
  for (const auto& f : m.faces) {
    const Vec3 &a = m.vertices[f[0]], &b = m.vertices[f[1]], &c = m.vertices[f[2]];
    const Vec3 cross = (b - a).cross(c - a);
    if (cross.norm() < 1e-12) continue;
    const Vec3 n = cross.normalized();
    auto g = std::find_if(groups.begin(), groups.end(),
                          [&](const Group& x) { return x.n.dot(n) > std::cos(M_PI / 180) && std::abs(x.d - n.dot(a)) < 1e-4; });
    if (g == groups.end()) g = groups.insert(groups.end(), Group{n, n.dot(a), 0, {}});
    g->area += cross.norm() / 2;
    g->corners.insert(g->corners.end(), {a, b, c});
  }
  std::vector<PlaneRect> out;
  for (const Group& g : groups)
    if (g.area >= min_area) out.push_back(rectOn(g.corners, g.n, g.d * g.n));
  return out;
}

// The rigid motion taking oriented point `r` to the origin with its normal along +x (Drost et al.'s
// T_{m->g}).
Pose toOrigin(const Oriented& r) {
  const Vec3 x = Vec3::UnitX();
  Mat3 R;
  const Vec3 axis = r.n.cross(x);
  const double s = axis.norm(), c = r.n.dot(x);
  if (s < 1e-9) R = c > 0 ? Mat3::Identity() : Mat3(Eigen::AngleAxisd(M_PI, Vec3::UnitZ()));
  else R = Eigen::AngleAxisd(std::atan2(s, c), axis / s).toRotationMatrix();
  Pose T = Pose::Identity();
  T.linear() = R;
  T.translation() = -R * r.p;
  return T;
}

// Point-pair features (Drost, Ulrich, Navab, Ilic, CVPR 2010): for oriented points r and i, the
// distance between them and the three angles (r's normal and i's to the line between them, and
// between the normals), quantized into one key; and the angle about +x that turns i, with r at
// the origin along +x, into the half-plane y > 0, z = 0.
class PointPairModel {
 public:
  PointPairModel(std::vector<Oriented> points, double diameter, double distance_step, int angle_steps, int bucket_cap)
      : points_(std::move(points)), diameter_(diameter), distance_step_(distance_step * diameter), angle_steps_(angle_steps),
        bucket_cap_(bucket_cap) {
    if (angle_steps_ < 4 || angle_steps_ > 126) throw std::invalid_argument("ModelPoseOptions::angle_steps: expected 4 to 126 (6 bits a half turn)");
    for (int k = 1; k * 2 <= angle_steps_; ++k) cos_edges_.push_back(std::cos(2 * M_PI * k / angle_steps_));
    for (size_t r = 0; r < points_.size(); ++r) {
      const Pose T = toOrigin(points_[r]);
      for (size_t i = 0; i < points_.size(); ++i) {
        if (i == r) continue;
        const uint64_t key = feature(points_[r], points_[i]);
        if (key == kNone) continue;
        table_[key].push_back({static_cast<int>(r), static_cast<float>(alpha(T * points_[i].p))});
      }
    }
    // A crowded bin (pairs on one face: a plane's pairs look alike) keeps evenly spaced entries,
    // `bucket_cap` to 2 bucket_cap - 1 of them: its votes spread over the face's every shift and
    // turn and locate little, and would cost the most.
    if (bucket_cap_ > 0)
      for (auto& [key, bucket] : table_) {
        const size_t stride = std::max<size_t>(1, bucket.size() / static_cast<size_t>(bucket_cap_));
        if (stride == 1) continue;
        std::vector<Entry> kept;
        for (size_t b = 0; b < bucket.size(); b += stride) kept.push_back(bucket[b]);
        bucket = std::move(kept);
      }
  }

  size_t size() const { return points_.size(); }

  // Votes of the scene's oriented points (every `reference_every`-th a reference): for each
  // reference, the model point and rotation about its normal most voted; its pose and votes.
  struct Vote {
    Pose T_scene_model;
    int votes = 0;
  };
  std::vector<Vote> vote(const std::vector<Oriented>& scene, int reference_every) const {
    std::vector<Vote> out;
    std::vector<int> acc(points_.size() * static_cast<size_t>(angle_steps_), 0);
    std::vector<size_t> touched;
    for (size_t r = 0; r < scene.size(); r += static_cast<size_t>(reference_every)) {
      const Pose Ts = toOrigin(scene[r]);
      for (size_t i = 0; i < scene.size(); ++i) {
        if (i == r || (scene[i].p - scene[r].p).squaredNorm() > diameter_ * diameter_) continue;
        const uint64_t key = feature(scene[r], scene[i]);
        const auto it = key == kNone ? table_.end() : table_.find(key);
        if (it != table_.end()) {
          const double as = alpha(Ts * scene[i].p);
          for (const Entry& e : it->second) {
            double a = e.alpha - as;  // in bins, within (-angle_steps, angle_steps)
            if (a < 0) a += angle_steps_;
            const int bin = std::min(angle_steps_ - 1, static_cast<int>(a));
            const size_t k = static_cast<size_t>(e.model) * angle_steps_ + bin;
            if (acc[k] == 0) touched.push_back(k);
            ++acc[k];
          }
        }
      }
      size_t best = 0;
      int most = 0;
      for (size_t k : touched)
        if (acc[k] > most || (acc[k] == most && k < best)) most = acc[k], best = k;
      if (most > 0) {
        const Oriented& m = points_[best / static_cast<size_t>(angle_steps_)];
        const double a = (static_cast<double>(best % static_cast<size_t>(angle_steps_)) + 0.5) * 2 * M_PI / angle_steps_;
        Pose Rx = Pose::Identity();
        Rx.linear() = Eigen::AngleAxisd(a, Vec3::UnitX()).toRotationMatrix();
        out.push_back({Ts.inverse() * Rx * toOrigin(m), most});
      }
      for (size_t k : touched) acc[k] = 0;
      touched.clear();
    }
    return out;
  }

 private:
  static constexpr uint64_t kNone = ~0ull;
  struct Entry {
    int model;
    float alpha;  // in bins of the turn
  };

  // An angle's bin from its cosine (no acos: the bins' edges' cosines, descending).
  long angleBin(double c) const {
    return std::partition_point(cos_edges_.begin(), cos_edges_.end(), [c](double e) { return e >= c; }) - cos_edges_.begin();
  }
  static uint64_t key(const std::array<long, 4>& b) {
    return ((static_cast<uint64_t>(b[0]) * 64 + static_cast<uint64_t>(b[1])) * 64 + static_cast<uint64_t>(b[2])) * 64 + static_cast<uint64_t>(b[3]);
  }
  uint64_t feature(const Oriented& r, const Oriented& i) const {
    const Vec3 d = i.p - r.p;
    const double dist = d.norm();
    if (dist < 1e-9) return kNone;
    const Vec3 u = d / dist;
    return key({static_cast<long>(dist / distance_step_), angleBin(r.n.dot(u)), angleBin(i.n.dot(u)), angleBin(r.n.dot(i.n))});
  }
  // The angle about +x from the half-plane y > 0, z = 0 to p, in bins of the turn.
  double alpha(const Vec3& p) const { return std::atan2(-p.z(), p.y()) * angle_steps_ / (2 * M_PI); }

  std::vector<Oriented> points_;
  double diameter_, distance_step_;
  int angle_steps_, bucket_cap_;
  std::vector<double> cos_edges_;  // cos(k 2 pi / angle_steps), k = 1 ... angle_steps / 2
  std::unordered_map<uint64_t, std::vector<Entry>> table_;
};

Mat3 expSO3(const Vec3& w) {
  const double a = w.norm();
  if (a < 1e-12) return Mat3::Identity();
  return Eigen::AngleAxisd(a, w / a).toRotationMatrix();
}

// The segment's pixels as a mask over its bounding box.
struct SegmentMask {
  int u0 = 0, v0 = 0, u1 = 0, v1 = 0, width = 0;
  std::vector<char> in;
  bool has(int u, int v) const { return u >= u0 && u < u1 && v >= v0 && v < v1 && in[static_cast<size_t>(v - v0) * width + (u - u0)]; }
};

SegmentMask maskOf(const Segment& s, int image_width) {
  SegmentMask m;
  if (s.pixels.empty()) return m;
  m.u0 = m.v0 = std::numeric_limits<int>::max();
  for (int px : s.pixels) {
    const int u = px % image_width, v = px / image_width;
    m.u0 = std::min(m.u0, u), m.v0 = std::min(m.v0, v), m.u1 = std::max(m.u1, u + 1), m.v1 = std::max(m.v1, v + 1);
  }
  m.width = m.u1 - m.u0;
  m.in.assign(static_cast<size_t>(m.width) * (m.v1 - m.v0), 0);
  for (int px : s.pixels) m.in[static_cast<size_t>(px / image_width - m.v0) * m.width + (px % image_width - m.u0)] = 1;
  return m;
}

}  // namespace

struct ModelPoseEstimator::Impl {
  std::vector<std::shared_ptr<const ObjectModel>> models;
  std::vector<PointPairModel> ppf;
  std::vector<std::vector<Vec3>> normals;  // each model's faces' outward normals
  std::vector<std::vector<PlaneRect>> planes;  // each model's plane faces
  std::vector<Vec3> box_centres;                // each model's vertices' bounding box's centre (its half turns')
  ModelPoseOptions o;

  // The segment's points on a pixel grid about `spacing` apart, each with the normal of a plane
  // fitted to the segment's points within `radius` of it (pointing at the camera), in the world.
  std::vector<Oriented> sceneCloud(const Frame& frame, const SegmentMask& mask, double spacing, double radius) const {
    const CameraModel& cam = frame.camera;
    const Vec3 eye = cam.T_world_camera.translation();
    double z_sum = 0;
    int z_n = 0;
    for (int v = mask.v0; v < mask.v1; ++v)
      for (int u = mask.u0; u < mask.u1; ++u) {
        const float z = frame.depth[static_cast<size_t>(v) * cam.width + u];
        if (mask.has(u, v) && z > 0) z_sum += z, ++z_n;
      }
    if (z_n == 0) return {};
    const double z_mean = z_sum / z_n;
    const int stride = std::max(1, static_cast<int>(std::lround(spacing * cam.fx / z_mean)));
    const int reach = std::max(2, static_cast<int>(std::ceil(radius * cam.fx / z_mean)));
    const int step = std::max(1, reach / 4);
    std::vector<Oriented> pts;
    for (int v = mask.v0; v < mask.v1; v += stride)
      for (int u = mask.u0; u < mask.u1; u += stride) {
        const float z = frame.depth[static_cast<size_t>(v) * cam.width + u];
        if (!mask.has(u, v) || !(z > 0)) continue;
        const Vec3 p = cam.unproject(u, v, z);
        Vec3 mean = Vec3::Zero();
        Mat3 scatter = Mat3::Zero();
        int n = 0;
        for (int dv = -reach; dv <= reach; dv += step)
          for (int du = -reach; du <= reach; du += step) {
            const int uu = u + du, vv = v + dv;
            if (!mask.has(uu, vv)) continue;
            const float zz = frame.depth[static_cast<size_t>(vv) * cam.width + uu];
            if (!(zz > 0)) continue;
            const Vec3 q = cam.unproject(uu, vv, zz);
            if ((q - p).squaredNorm() > radius * radius) continue;
            mean += q, scatter += q * q.transpose(), ++n;
          }
        if (n < 5) continue;
        mean /= n;
        const Eigen::SelfAdjointEigenSolver<Mat3> eig(scatter / n - mean * mean.transpose());
        Vec3 normal = eig.eigenvectors().col(0);
        if (normal.dot(eye - p) < 0) normal = -normal;
        pts.push_back({p, normal});
      }
    return pts;
  }

  // Point-to-plane ICP, each pixel of the segment where the model is drawn pairing the point seen
  // there with the model's surface there (projective association), about `centre`.
  Pose refine(const Frame& frame, const SegmentMask& mask, int k, Pose T, const Vec3& centre) const {
    const ObjectModel& m = *models[static_cast<size_t>(k)];
    const CameraModel& cam = frame.camera;
    for (int it = 0; it < o.icp_iterations; ++it) {
      const ModelDrawing d = drawModel(m, T, cam, mask.u0, mask.v0, mask.u1, mask.v1);
      Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Zero();
      Eigen::Matrix<double, 6, 1> b = Eigen::Matrix<double, 6, 1>::Zero();
      int pairs = 0;
      for (int v = mask.v0; v < mask.v1; ++v)
        for (int u = mask.u0; u < mask.u1; ++u) {
          const float zm = d.at(u, v);
          const float zo = frame.depth[static_cast<size_t>(v) * cam.width + u];
          if (!(zm > 0) || !(zo > 0) || !mask.has(u, v)) continue;
          const Vec3 p = cam.unproject(u, v, zo), q = cam.unproject(u, v, zm);
          if ((p - q).norm() > o.icp_reject) continue;
          const Vec3 n = T.linear() * normals[static_cast<size_t>(k)][static_cast<size_t>(d.face[static_cast<size_t>(v - d.v0) * d.width + (u - d.u0)])];
          Eigen::Matrix<double, 6, 1> J;
          J << (q - centre).cross(n), n;
          const double r = (q - p).dot(n);
          A += J * J.transpose(), b += J * r, ++pairs;
        }
      if (pairs < 12) break;
      // Damped: where the seen surface leaves a direction free (one plane, or faces all parallel
      // to an axis), the step along it stays near zero instead of following rounding noise.
      A.diagonal().array() += 1e-6 * A.trace() / 6;
      const Eigen::Matrix<double, 6, 1> x = A.ldlt().solve(-b);
      if (!x.allFinite()) break;
      const Mat3 dR = expSO3(x.head<3>());
      Pose step = Pose::Identity();
      step.linear() = dR;
      step.translation() = centre + x.tail<3>() - dR * centre;
      T = step * T;
      if (x.head<3>().norm() < 1e-4 && x.tail<3>().norm() < 1e-5) break;
    }
    return T;
  }

  ModelPose verify(const Frame& frame, const SegmentMask& mask, int k, const Pose& T) const {
    const ObjectModel& m = *models[static_cast<size_t>(k)];
    const CameraModel& cam = frame.camera;
    ModelPose r;
    r.model = k, r.T_world_object = T;
    std::array<int, 4> w = modelWindow(m, T, cam);
    if (w[2] <= w[0] || w[3] <= w[1]) w = {mask.u0, mask.v0, mask.u1, mask.v1};  // not in front of the camera: the segment's window
    const int u0 = std::min(w[0], mask.u0), v0 = std::min(w[1], mask.v0), u1 = std::max(w[2], mask.u1), v1 = std::max(w[3], mask.v1);
    const ModelDrawing d = drawModel(m, T, cam, u0, v0, u1, v1);
    for (int v = v0; v < v1; ++v)
      for (int u = u0; u < u1; ++u) {
        const float zm = d.at(u, v);
        const float zo = frame.depth[static_cast<size_t>(v) * cam.width + u];
        const bool mine = mask.has(u, v);
        if (zm > 0) {
          if (!(zo > 0)) continue;  // no depth there: no evidence
          ++r.drawn;
          const double tol = o.agree + 3 * o.depth_sigma_k * zm * zm;
          if (std::abs(zo - zm) <= tol) ++r.agree;
          else if (zo > zm + tol || mine) ++r.contradict;  // seen past the model, or its own surface in front of it
        } else if (mine) {
          ++r.contradict, ++r.uncovered;  // the segment where the model is not
        }
      }
    r.score = r.agree + r.contradict > 0 ? static_cast<double>(r.agree) / (r.agree + r.contradict) : 0;
    return r;
  }
};

ModelPoseEstimator::ModelPoseEstimator(std::vector<std::shared_ptr<const ObjectModel>> models, const ModelPoseOptions& o)
    : impl_(std::make_unique<Impl>()) {
  impl_->models = std::move(models);
  impl_->o = o;
  for (const auto& m : impl_->models) {
    const double step = o.model_sampling * m->diameter;
    impl_->ppf.emplace_back(thin(surfacePoints(*m, 0.5 * step, o.edge_clearance), step), m->diameter, o.distance_step, o.angle_steps, o.bucket_cap);
    std::vector<Vec3> n;
    for (const auto& f : m->faces) {
      const Vec3 c = (m->vertices[f[1]] - m->vertices[f[0]]).cross(m->vertices[f[2]] - m->vertices[f[0]]);
      n.push_back(c.norm() > 0 ? Vec3(c.normalized()) : Vec3::UnitZ());
    }
    impl_->normals.push_back(std::move(n));
    impl_->planes.push_back(planeFaces(*m, o.plane_min_area));
    Vec3 lo = Vec3::Constant(INFINITY), hi = Vec3::Constant(-INFINITY);
    for (const Vec3& v : m->vertices) lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
    impl_->box_centres.push_back((lo + hi) / 2);
  }
}

ModelPoseEstimator::~ModelPoseEstimator() = default;

const std::vector<std::shared_ptr<const ObjectModel>>& ModelPoseEstimator::models() const { return impl_->models; }

ModelPose ModelPoseEstimator::verify(const Frame& frame, const Segment& segment, int model, const Pose& T) const {
  return impl_->verify(frame, maskOf(segment, frame.camera.width), model, T);
}

ModelPose ModelPoseEstimator::estimate(const Frame& frame, const Segment& segment) const {
  const auto t0 = std::chrono::steady_clock::now();
  const Impl& I = *impl_;
  ModelPose best;
  ModelPose part;  // of the poses that fit a part of the segment (min_fit, min_seen), the one most pixels agree with
  best.reason = "no point pair of the segment matches any model's";
  const SegmentMask mask = maskOf(segment, frame.camera.width);
  Vec3 origin = Vec3::Zero();  // ICP turns the pose about the segment's centroid
  for (const Vec3& p : segment.points) origin += p;
  if (!segment.points.empty()) origin /= static_cast<double>(segment.points.size());
  int verified = 0;
  bool enough_points = false;
  // A hypothesis of model k refined, verified, and kept if the best so far (or the best part).
  auto try_pose = [&](int k, const Pose& hypothesis) {
    const ModelPose r = I.verify(frame, mask, k, I.refine(frame, mask, k, hypothesis, origin));
    ++verified;
    if (r.score > best.score || (r.score == best.score && r.agree > best.agree)) best = r;
    const int tell = r.agree + r.contradict - r.uncovered;
    if (tell > 0 && r.agree >= I.o.min_fit * tell && r.agree >= I.o.min_seen * r.drawn && r.agree > part.agree) part = r;
  };
  for (size_t k = 0; k < I.models.size(); ++k) {
    const ObjectModel& m = *I.models[k];
    const double spacing = I.o.scene_sampling * m.diameter;
    const std::vector<Oriented> scene = thin(I.sceneCloud(frame, mask, 0.5 * spacing, std::max(I.o.normal_radius, 1.5 * spacing)), spacing);
    if (scene.size() < 10) continue;
    enough_points = true;
    // The references' votes clustered (within a tenth of the diameter and 15 degrees, up to the
    // model's symmetries), the clusters by their votes.
    std::vector<PointPairModel::Vote> votes = I.ppf[k].vote(scene, std::max(1, static_cast<int>(std::lround(1 / I.o.scene_reference))));
    std::stable_sort(votes.begin(), votes.end(), [](const auto& a, const auto& b) { return a.votes > b.votes; });
    std::vector<PointPairModel::Vote> clusters;
    for (const auto& v : votes) {
      bool joined = false;
      for (auto& c : clusters) {
        if ((c.T_scene_model.translation() - v.T_scene_model.translation()).norm() > 0.1 * m.diameter) continue;
        double angle = M_PI;
        for (const Mat3& S : m.symmetries)
          angle = std::min(angle, Eigen::AngleAxisd(c.T_scene_model.linear().transpose() * v.T_scene_model.linear() * S).angle());
        if (angle > 15 * M_PI / 180) continue;
        c.votes += v.votes, joined = true;
        break;
      }
      if (!joined) clusters.push_back(v);
    }
    std::stable_sort(clusters.begin(), clusters.end(), [](const auto& a, const auto& b) { return a.votes > b.votes; });
    for (size_t h = 0; h < clusters.size() && h < static_cast<size_t>(I.o.hypotheses); ++h) try_pose(static_cast<int>(k), clusters[h].T_scene_model);
  }
  // The segment's largest plane (a face seen whole: a block's top, the half of a step block its
  // concave step splits off): a plane's point pairs locate nothing on a face (each of its shifts
  // and turns votes alike), so each model's plane faces of about its size are laid on it, their
  // smallest rectangles on its, in each quarter turn that fits.
  if (I.o.plane_faces) {
    const std::vector<Oriented> cloud = thin(I.sceneCloud(frame, mask, 0.5 * I.o.plane_spacing, I.o.normal_radius), I.o.plane_spacing);
    // The plane through each point along its normal, by how many points it holds (within
    // plane_tolerance, their normals within 15 degrees): the most held, refitted to them.
    size_t most = 0;
    Vec3 n = Vec3::UnitZ(), on = Vec3::Zero();
    for (const Oriented& c : cloud) {
      size_t held = 0;
      for (const Oriented& q : cloud) held += std::abs(c.n.dot(q.p - c.p)) <= I.o.plane_tolerance && c.n.dot(q.n) > std::cos(M_PI / 12);
      if (held > most) most = held, n = c.n, on = c.p;
    }
    std::vector<Vec3> flat;
    if (most >= 10 && most >= I.o.plane_share * static_cast<double>(cloud.size())) {
      Vec3 mean = Vec3::Zero();
      Mat3 scatter = Mat3::Zero();
      int held = 0;
      for (const Oriented& q : cloud)
        if (std::abs(n.dot(q.p - on)) <= I.o.plane_tolerance && n.dot(q.n) > std::cos(M_PI / 12)) mean += q.p, scatter += q.p * q.p.transpose(), ++held;
      mean /= held;
      const Eigen::SelfAdjointEigenSolver<Mat3> eig(scatter / held - mean * mean.transpose());
      const Vec3 fitted = eig.eigenvectors().col(0);
      n = fitted.dot(n) < 0 ? Vec3(-fitted) : fitted, on = mean;
      for (const Vec3& p : segment.points)
        if (std::abs(n.dot(p - on)) <= I.o.plane_tolerance) flat.push_back(p);
    }
    if (flat.size() >= 10) {
      const PlaneRect seen = rectOn(flat, n, on);
      auto fits = [&](double seen_half, double face_half) { return std::abs(seen_half - face_half) <= I.o.plane_fit; };
      for (size_t k = 0; k < I.models.size(); ++k)
        for (const PlaneRect& f : I.planes[k])
          for (int q = 0; q < 4; ++q) {
            const bool turned = q % 2 == 1;  // the face's long side along the segment's short one
            if (!fits(turned ? seen.half_short : seen.half_long, f.half_long) || !fits(turned ? seen.half_long : seen.half_short, f.half_short))
              continue;
            const Vec3 a = (q < 2 ? 1.0 : -1.0) * seen.R.col(turned ? 1 : 0);
            Mat3 R;
            R.col(0) = a, R.col(1) = n.cross(a), R.col(2) = n;
            Pose T = Pose::Identity();
            T.linear() = R * f.R.transpose();
            T.translation() = seen.centre - T.linear() * f.centre;
            try_pose(static_cast<int>(k), T);
          }
    }
  }
  // The best pose turned half a turn about each axis of its model's bounding box (through its
  // centre), each refined and verified: a block with chamfers at one end, lying on its side, or a
  // wedge on its face, gives votes for itself turned over nearly as many as for itself (the
  // features near the chamfer's edges are left out), and the depth image tells the two apart.
  if (I.o.turns && best.model >= 0) {
    const int k = best.model;
    const ObjectModel& m = *I.models[static_cast<size_t>(k)];
    const Vec3& c = I.box_centres[static_cast<size_t>(k)];
    const Pose found = best.T_world_object;
    for (int axis = 0; axis < 3; ++axis) {
      const Mat3 R = Eigen::AngleAxisd(M_PI, Vec3::Unit(axis)).toRotationMatrix();
      if (std::any_of(m.symmetries.begin(), m.symmetries.end(), [&](const Mat3& S) { return (S - R).norm() < 1e-6; })) continue;
      Pose turn = Pose::Identity();
      turn.linear() = R;
      turn.translation() = c - R * c;
      try_pose(k, found * turn);
    }
  }
  best.ok = best.model >= 0 && best.score >= I.o.min_score;
  if (!best.ok && part.model >= 0) {  // more than one object in the segment: the one explained best
    best = part;
    best.ok = best.partial = true;
  }
  best.hypotheses = verified;
  if (!best.ok && best.model >= 0) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "no model explains the segment: the best, %s, agrees with %.0f%% of the pixels that tell (at least %.0f%% needed)",
                  I.models[static_cast<size_t>(best.model)]->name.c_str(), 100 * best.score, 100 * I.o.min_score);
    best.reason = buf;
  } else if (best.ok) {
    best.reason.clear();
  } else if (verified > 0) {
    best.reason = "no pose of any model agrees with a pixel of the segment";
  } else if (!enough_points) {
    best.reason = "too few points in the segment for any model";
  }
  best.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return best;
}

ViewPoses ModelPoseEstimator::estimateView(const Frame& frame, const std::vector<Segment>& segments, const SegmentationOptions& so) const {
  const auto t0 = std::chrono::steady_clock::now();
  const Impl& I = *impl_;
  const CameraModel& cam = frame.camera;
  const Pose T_region_world = so.T_world_region.inverse();
  const size_t n = static_cast<size_t>(cam.width) * static_cast<size_t>(cam.height);
  ViewPoses out;
  std::vector<char> in_bin(n, 0), taken(n, 0);
  for (const Segment& s : segments)
    for (int p : s.pixels) in_bin[static_cast<size_t>(p)] = 1;
  const int margin = std::max(1, static_cast<int>(std::lround(I.o.explain_margin * cam.width / 640.0)));

  // A segment of the given pixels (ascending), their points and top.
  auto segmentOf = [&](const std::vector<int>& pixels) {
    Segment s;
    s.pixels = pixels;
    for (int p : pixels) {
      const Vec3 q = cam.unproject(p % cam.width, p / cam.width, frame.depth[static_cast<size_t>(p)]);
      s.points.push_back(q);
      s.centroid += q;
      s.top = std::max(s.top, (T_region_world * q).z());
    }
    if (!pixels.empty()) s.centroid /= static_cast<double>(pixels.size());
    return s;
  };
  // Too small to be posed: an obstacle if it rises above the floor's noise (segmentation's rule).
  auto leftOver = [&](Segment s) {
    if (static_cast<int>(s.pixels.size()) >= so.min_obstacle_pixels && s.top >= so.min_obstacle_height) out.small.push_back(std::move(s));
  };
  // The connected parts of `pixels` (ascending; pixels within `margin` of each other join): a
  // flood fill over their bounding box.
  auto parts = [&](const std::vector<int>& pixels) {
    std::vector<std::vector<int>> result;
    if (pixels.empty()) return result;
    int u0 = cam.width, v0 = cam.height, u1 = -1, v1 = -1;
    for (int p : pixels) {
      const int u = p % cam.width, v = p / cam.width;
      u0 = std::min(u0, u), v0 = std::min(v0, v), u1 = std::max(u1, u), v1 = std::max(v1, v);
    }
    const int bw = u1 - u0 + 1;
    std::vector<int> part(static_cast<size_t>(bw) * static_cast<size_t>(v1 - v0 + 1), -2);  // -2: not one of them, -1: not reached
    auto at = [&](int u, int v) -> int& { return part[static_cast<size_t>(v - v0) * bw + static_cast<size_t>(u - u0)]; };
    for (int p : pixels) at(p % cam.width, p / cam.width) = -1;
    for (int seed : pixels) {
      int& first = at(seed % cam.width, seed / cam.width);
      if (first >= 0) continue;
      const int id = static_cast<int>(result.size());
      result.emplace_back();
      std::vector<int> stack{seed};
      first = id;
      while (!stack.empty()) {
        const int p = stack.back();
        stack.pop_back();
        result.back().push_back(p);
        const int u = p % cam.width, v = p / cam.width;
        for (int vv = std::max(v0, v - margin); vv <= std::min(v1, v + margin); ++vv)
          for (int uu = std::max(u0, u - margin); uu <= std::min(u1, u + margin); ++uu) {
            int& q = at(uu, vv);
            if (q != -1) continue;
            q = id;
            stack.push_back(vv * cam.width + uu);
          }
      }
      std::sort(result.back().begin(), result.back().end());
    }
    return result;
  };
  auto area = [&](const std::vector<int>& pixels) {
    double a = 0;
    for (int p : pixels) {
      const double z = frame.depth[static_cast<size_t>(p)];
      a += z * z / (cam.fx * cam.fy);
    }
    return a;
  };

  // The largest first (a merged or split object's larger part decides it); ties by first pixel.
  std::vector<Segment> queue(segments.begin(), segments.end());
  std::stable_sort(queue.begin(), queue.end(), [](const Segment& a, const Segment& b) { return a.pixels.size() > b.pixels.size(); });
  for (size_t i = 0; i < queue.size(); ++i) {
    // What later poses left of it.
    std::vector<int> mine;
    for (int p : queue[i].pixels)
      if (!taken[static_cast<size_t>(p)]) mine.push_back(p);
    if (mine.empty()) continue;
    Segment s;
    if (mine.size() == queue[i].pixels.size()) {
      s = std::move(queue[i]);
    } else {  // a pose took some: its connected parts, each posed if large enough
      bool first = true;
      for (std::vector<int>& part : parts(mine)) {
        if (area(part) < I.o.rest_area) {
          leftOver(segmentOf(part));
        } else if (first) {
          s = segmentOf(part), first = false;
        } else {
          queue.push_back(segmentOf(part));
        }
      }
      if (first) continue;
    }
    ++out.estimates;
    ModelPose pose = estimate(frame, s);
    if (!pose.ok) {
      out.unknown.push_back(std::move(s));
      continue;
    }
    // Its pixels: the bin's pixels not yet taken where the model drawn at the pose, or a pixel of
    // it within `margin`, is within explain_band of the seen depth.
    const ObjectModel& m = *I.models[static_cast<size_t>(pose.model)];
    std::array<int, 4> w = modelWindow(m, pose.T_world_object, cam);
    std::vector<int> own;
    if (w[2] > w[0] && w[3] > w[1]) {
      const ModelDrawing d = drawModel(m, pose.T_world_object, cam, w[0], w[1], w[2], w[3]);
      for (int v = std::max(0, w[1] - margin); v < std::min(cam.height, w[3] + margin); ++v)
        for (int u = std::max(0, w[0] - margin); u < std::min(cam.width, w[2] + margin); ++u) {
          const size_t p = static_cast<size_t>(v) * cam.width + u;
          const float zo = frame.depth[p];
          if (!in_bin[p] || taken[p] || !(zo > 0)) continue;
          bool near = false;
          for (int dv = -margin; dv <= margin && !near; ++dv)
            for (int du = -margin; du <= margin && !near; ++du) {
              const int uu = u + du, vv = v + dv;
              if (uu < d.u0 || vv < d.v0 || uu >= d.u0 + d.width || vv >= d.v0 + d.height) continue;
              const float zm = d.at(uu, vv);
              near = zm > 0 && std::abs(zo - zm) <= I.o.explain_band;
            }
          if (near) own.push_back(static_cast<int>(p));
        }
    }
    for (int p : own) taken[static_cast<size_t>(p)] = 1;
    // What it leaves of its own segment, in parts: posed again if large enough (another object).
    // Each part is smaller than the segment, so this ends.
    std::vector<int> rest;
    for (int p : s.pixels)
      if (!taken[static_cast<size_t>(p)]) rest.push_back(p);
    if (rest.size() == s.pixels.size()) {  // it explains none of its own segment: no pose of it
      for (int p : own) taken[static_cast<size_t>(p)] = 0;
      out.unknown.push_back(std::move(s));
      continue;
    }
    for (std::vector<int>& part : parts(rest)) {
      if (area(part) < I.o.rest_area)
        leftOver(segmentOf(part));
      else
        queue.push_back(segmentOf(part));
    }
    out.poses.push_back(std::move(pose));
    out.explained.push_back(segmentOf(own));
  }
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace mm
