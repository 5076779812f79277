#include "perception/camera_perception.h"

#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>

namespace mm {
namespace {

// OpenCV runs its parallel loops on TBB worker threads unless told otherwise. Library calls run in
// the calling thread here (docs/design/determinism.md); a worker thread alive at exit also crashed
// LeakSanitizer's end-of-process check now and then.
[[maybe_unused]] const int kOpenCvInCallingThread = (cv::setNumThreads(0), 0);

// The 24 rotations that map the axes onto themselves (signed permutations with determinant +1).
const std::vector<Mat3>& axisRotations() {
  static const std::vector<Mat3> all = [] {
    std::vector<Mat3> v;
    const std::array<std::array<int, 3>, 6> perms = {{{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}}};
    for (const auto& p : perms)
      for (int s = 0; s < 8; ++s) {
        Mat3 R = Mat3::Zero();
        for (int r = 0; r < 3; ++r) R(r, p[static_cast<size_t>(r)]) = (s >> r) & 1 ? -1.0 : 1.0;
        if (R.determinant() > 0) v.push_back(R);
      }
    return v;
  }();
  return all;
}

// The rotations that map a box of these half sizes onto itself.
std::vector<Mat3> symmetries(const Vec3& half) {
  std::vector<Mat3> v;
  for (const Mat3& S : axisRotations())
    if (((S * half).cwiseAbs() - half).cwiseAbs().maxCoeff() < 1e-6) v.push_back(S);
  return v;
}

struct Plane {
  Vec3 n = Vec3::UnitZ();
  double d = 0;  // n . p = d
  double distance(const Vec3& p) const { return n.dot(p) - d; }
};

// Least-squares plane through points (the normal: the smallest principal axis).
Plane fitPlane(const std::vector<Vec3>& pts) {
  Vec3 c = Vec3::Zero();
  for (const Vec3& p : pts) c += p;
  c /= static_cast<double>(pts.size());
  Mat3 C = Mat3::Zero();
  for (const Vec3& p : pts) C += (p - c) * (p - c).transpose();
  Eigen::SelfAdjointEigenSolver<Mat3> es(C);
  Plane pl;
  pl.n = es.eigenvectors().col(0).normalized();
  if (pl.n.z() < 0) pl.n = -pl.n;
  pl.d = pl.n.dot(c);
  return pl;
}

// RANSAC for the dominant plane, then a least-squares refit on its inliers.
Plane ransacPlane(const std::vector<Vec3>& pts, double threshold, Rng& rng, int* inliers) {
  Plane best;
  int best_count = -1;
  if (pts.size() < 3) return best;
  for (int it = 0; it < 200; ++it) {
    const Vec3& a = pts[rng.below(pts.size())];
    const Vec3& b = pts[rng.below(pts.size())];
    const Vec3& c = pts[rng.below(pts.size())];
    Vec3 n = (b - a).cross(c - a);
    if (n.norm() < 1e-9) continue;
    Plane pl;
    pl.n = n.normalized();
    if (pl.n.z() < 0) pl.n = -pl.n;
    pl.d = pl.n.dot(a);
    int count = 0;
    for (size_t i = 0; i < pts.size(); i += 4) count += std::abs(pl.distance(pts[i])) < threshold;  // a quarter is enough to rank
    if (count > best_count) best_count = count, best = pl;
  }
  std::vector<Vec3> in;
  for (const Vec3& p : pts)
    if (std::abs(best.distance(p)) < threshold) in.push_back(p);
  *inliers = static_cast<int>(in.size());
  return in.size() >= 3 ? fitPlane(in) : best;
}

// The plane of a set of points from their moments (about an origin near them, for precision).
struct Moments {
  Vec3 origin = Vec3::Zero(), sum = Vec3::Zero();
  Mat3 outer = Mat3::Zero();
  double n = 0;
  void add(const Vec3& p) {
    const Vec3 q = p - origin;
    sum += q, outer += q * q.transpose(), n += 1;
  }
  // The plane, and the mean squared distance of the points from it.
  Plane plane(double* mse = nullptr) const {
    const Vec3 c = sum / n;
    const Mat3 C = outer / n - c * c.transpose();
    Eigen::SelfAdjointEigenSolver<Mat3> es(C);
    Plane pl;
    pl.n = es.eigenvectors().col(0).normalized();
    if (pl.n.z() < 0) pl.n = -pl.n;
    pl.d = pl.n.dot(c + origin);
    if (mse) *mse = std::max(0.0, es.eigenvalues()(0));
    return pl;
  }
};

// Faces: regions grown over the pixels above the floor whose points lie on the region's plane
// within the sensor's noise (3 sigma, sigma = k z^2) and join their neighbour without a depth jump.
// Seeds: a 9 x 9 patch around every 4th pixel, flattest first (its plane's residual against the
// noise expected there); a patch not flat within 1.5 sigma seeds nothing (a ridge, an edge).
std::vector<std::vector<int>> growFaces(const std::vector<Vec3>& pts, const std::vector<int>& index_of, int w, int h,
                                        const std::vector<float>& depth, const CameraPerceptionOptions& o, const Plane& floor) {
  auto valid = [&](int k) { return index_of[static_cast<size_t>(k)] >= 0 && floor.distance(pts[static_cast<size_t>(index_of[static_cast<size_t>(k)])]) > o.plane_threshold; };
  auto P = [&](int k) -> const Vec3& { return pts[static_cast<size_t>(index_of[static_cast<size_t>(k)])]; };
  auto sigma = [&](int k) {
    const double z = depth[static_cast<size_t>(k)];
    return std::max(0.0005, o.depth_sigma_k * z * z);
  };
  constexpr int r = 4, step = 4;
  std::vector<std::pair<double, int>> seeds;
  for (int v = r; v < h - r; v += step)
    for (int u = r; u < w - r; u += step) {
      const int k = v * w + u;
      if (!valid(k)) continue;
      Moments m;
      m.origin = P(k);
      bool full = true;
      for (int dv = -r; dv <= r && full; ++dv)
        for (int du = -r; du <= r; ++du) {
          const int q = k + dv * w + du;
          if (!valid(q)) {
            full = false;
            break;
          }
          m.add(P(q));
        }
      if (!full) continue;
      double mse = 0;
      m.plane(&mse);
      const double flatness = std::sqrt(mse) / sigma(k);
      if (flatness < 1.5) seeds.push_back({flatness, k});
    }
  std::stable_sort(seeds.begin(), seeds.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<int> label(static_cast<size_t>(w) * static_cast<size_t>(h), -1);
  std::vector<std::vector<int>> regions;
  for (const auto& [flat, seed] : seeds) {
    if (label[static_cast<size_t>(seed)] >= 0) continue;
    const int id = static_cast<int>(regions.size());
    std::vector<int> region;
    Moments m;
    m.origin = P(seed);
    for (int dv = -r; dv <= r; ++dv)
      for (int du = -r; du <= r; ++du) {
        const int q = seed + dv * w + du;
        if (label[static_cast<size_t>(q)] >= 0) continue;
        label[static_cast<size_t>(q)] = id;
        region.push_back(q);
        m.add(P(q));
      }
    Plane pl = m.plane();
    double refit_at = 2 * m.n;
    for (size_t head = 0; head < region.size(); ++head) {
      const int k = region[head];
      const int u = k % w, v = k / w;
      const int nb[4] = {u > 0 ? k - 1 : -1, u < w - 1 ? k + 1 : -1, v > 0 ? k - w : -1, v < h - 1 ? k + w : -1};
      for (int q : nb) {
        if (q < 0 || label[static_cast<size_t>(q)] >= 0 || !valid(q)) continue;
        const double tol = 3 * sigma(q);
        if (std::abs(pl.distance(P(q))) > tol || (P(q) - P(k)).norm() > tol + 0.005) continue;
        label[static_cast<size_t>(q)] = id;
        region.push_back(q);
        m.add(P(q));
        if (m.n >= refit_at) pl = m.plane(), refit_at = 2 * m.n;
      }
    }
    regions.push_back(std::move(region));
  }
  return regions;
}

// A rectangle on a face's plane (2-D plane coordinates): a catalogue kind's face, its centre and
// angle, and which of the kind's axes stands out of the face.
struct FaceRect {
  const KnownShape* shape = nullptr;
  int up = 2;
  bool swap = false;
  Eigen::Vector2d c = Eigen::Vector2d::Zero();
  double theta = 0;
  double half_w = 0, half_h = 0;  ///< along theta, across it
  int pixels = 0;
  double seen = 1;  ///< the share of the rectangle the face's region covers
};

// The kind and axis whose face sides fit a w x h rectangle best; returns the cost (|dw| + |dh|).
double bestFaceKind(const std::vector<KnownShape>& shapes, double fw, double fh, FaceRect* out) {
  double best_cost = std::numeric_limits<double>::infinity();
  for (const KnownShape& sh : shapes)
    for (int a = 0; a < 3 && sh.shape == ObjectShape::kBox; ++a) {
      const int b = (a + 1) % 3, d = (a + 2) % 3;
      for (int sw = 0; sw < 2; ++sw) {
        const double sa = 2 * sh.half_size[sw ? d : b], sb = 2 * sh.half_size[sw ? b : d];
        const double cost = std::abs(fw - sa) + std::abs(fh - sb);
        if (cost < best_cost) {
          best_cost = cost;
          out->shape = &sh, out->up = a, out->swap = sw, out->half_w = sa / 2, out->half_h = sb / 2;
        }
      }
    }
  return best_cost;
}

// The outline fit: boundary points against the rectangle's four edges, its centre and angle (and
// size, when `fit_size`) by Gauss-Newton, robust beyond 3 mm (pixel quantization averages out
// over the edges' many points, where minAreaRect's hull rests on a few). Without `fit_size` only
// the points within 4 mm of the rectangle's sides count (a face sharing a side with another).
void fitOutline(const std::vector<Eigen::Vector2d>& all_edge, FaceRect& fr, bool fit_size) {
  std::vector<Eigen::Vector2d> edge;
  if (fit_size) {
    edge = all_edge;
  } else {
    const Eigen::Vector2d ax(std::cos(fr.theta), std::sin(fr.theta)), ay(-std::sin(fr.theta), std::cos(fr.theta));
    for (const Eigen::Vector2d& q : all_edge) {
      const double x = std::abs(ax.dot(q - fr.c)), y = std::abs(ay.dot(q - fr.c));
      const bool on_x = std::abs(x - fr.half_w) < 0.004 && y < fr.half_h + 0.004;
      const bool on_y = std::abs(y - fr.half_h) < 0.004 && x < fr.half_w + 0.004;
      if (on_x || on_y) edge.push_back(q);
    }
    if (edge.size() < 12) return;
  }
  for (int it = 0; it < 15; ++it) {
    Eigen::Matrix<double, 5, 5> H = Eigen::Matrix<double, 5, 5>::Zero();
    Eigen::Matrix<double, 5, 1> g = Eigen::Matrix<double, 5, 1>::Zero();
    const Eigen::Vector2d ax(std::cos(fr.theta), std::sin(fr.theta)), ay(-std::sin(fr.theta), std::cos(fr.theta));
    for (const Eigen::Vector2d& q : edge) {
      const Eigen::Vector2d r = q - fr.c;
      const double x = ax.dot(r), y = ay.dot(r);
      // The nearer of the two edges across the point's side: the x edges or the y edges.
      const bool x_edge = std::abs(std::abs(x) - fr.half_w) < std::abs(std::abs(y) - fr.half_h);
      const Eigen::Vector2d nrm = x_edge ? (x >= 0 ? ax : Eigen::Vector2d(-ax)) : (y >= 0 ? ay : Eigen::Vector2d(-ay));
      const double res_k = nrm.dot(r) - (x_edge ? fr.half_w : fr.half_h);
      const double wgt = std::abs(res_k) < 0.003 ? 1.0 : 0.003 / std::abs(res_k);
      // d/dc = -n; d/dtheta = (dn/dtheta) . r, dn/dtheta = n rotated by +90 degrees; d/dsize = -1.
      const Eigen::Vector2d dn(-nrm.y(), nrm.x());
      Eigen::Matrix<double, 5, 1> J;
      J << -nrm.x(), -nrm.y(), dn.dot(r), x_edge ? -1.0 : 0.0, x_edge ? 0.0 : -1.0;
      if (!fit_size) J(3) = J(4) = 0;
      H += wgt * J * J.transpose();
      g += wgt * J * res_k;
    }
    if (!fit_size) H(3, 3) = H(4, 4) = 1;
    const Eigen::Matrix<double, 5, 1> step = H.ldlt().solve(-g);
    if (!step.allFinite()) break;
    fr.c += step.head<2>();
    fr.theta += step(2);
    fr.half_w += step(3);
    fr.half_h += step(4);
    if (step.norm() < 1e-8) break;
  }
}

// Faces of several boxes in one plane: the region's points rasterized on the plane (1.5 mm
// cells, closed), its outline's straight edges (approxPolyDP), and along each edge long enough,
// the catalogue's face rectangles laid inward from either end; the rectangle whose cells are the
// most covered by the region's still unclaimed cells is taken (at least 92% covered) and its cells
// claimed, until none is. Each taken rectangle is then fitted to the outline points along its own
// sides, its size kept.
std::vector<FaceRect> packFaceRects(const std::vector<cv::Point2f>& flat, const std::vector<Eigen::Vector2d>& edge,
                                    const std::vector<KnownShape>& shapes, const std::function<int(const Eigen::Vector2d&)>& seen,
                                    double min_coverage) {
  std::vector<FaceRect> out;
  if (flat.empty() || shapes.empty()) return out;
  constexpr double cell = 0.0015;
  float x0 = flat[0].x, y0 = flat[0].y, x1 = x0, y1 = y0;
  for (const cv::Point2f& p : flat) x0 = std::min(x0, p.x), y0 = std::min(y0, p.y), x1 = std::max(x1, p.x), y1 = std::max(y1, p.y);
  const int gw = static_cast<int>((x1 - x0) / cell) + 3, gh = static_cast<int>((y1 - y0) / cell) + 3;
  if (static_cast<double>(gw) * gh > 4e6) return out;
  cv::Mat grid = cv::Mat::zeros(gh, gw, CV_8UC1);
  for (const cv::Point2f& p : flat) grid.at<uint8_t>(static_cast<int>((p.y - y0) / cell) + 1, static_cast<int>((p.x - x0) / cell) + 1) = 255;
  cv::morphologyEx(grid, grid, cv::MORPH_CLOSE, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(5, 5)));
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(grid.clone(), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  auto to_plane = [&](double gx, double gy) { return Eigen::Vector2d(x0 + (gx - 1 + 0.5) * cell, y0 + (gy - 1 + 0.5) * cell); };
  cv::Mat claimed = cv::Mat::zeros(gh, gw, CV_8UC1);
  // The share of a rectangle's cells that are the region's and unclaimed; 0 when more than 5% of
  // the others are contradicted by the camera: it sees past the face there (floor, a lower
  // surface), or a surface at the face's depth that is not this region's (another box's face, one
  // already claimed). Only cells hidden behind something nearer are not: a face half under a
  // leaning cube. Cells the sensor lost say nothing either way.
  auto coverage = [&](const FaceRect& fr) {
    const Eigen::Vector2d ax(std::cos(fr.theta), std::sin(fr.theta)), ay(-std::sin(fr.theta), std::cos(fr.theta));
    int in = 0, all = 0, bad = 0;
    for (double s = -fr.half_w + cell / 2; s < fr.half_w; s += cell)
      for (double t = -fr.half_h + cell / 2; t < fr.half_h; t += cell) {
        const Eigen::Vector2d q = fr.c + s * ax + t * ay;
        const int gx = static_cast<int>(std::floor((q.x() - x0) / cell)) + 1, gy = static_cast<int>(std::floor((q.y() - y0) / cell)) + 1;
        ++all;
        if (gx >= 0 && gy >= 0 && gx < gw && gy < gh && grid.at<uint8_t>(gy, gx)) {
          in += !claimed.at<uint8_t>(gy, gx);
        } else {
          const int what = seen(q);
          bad += what == 0 || what == 2;
        }
      }
    if (all == 0 || bad > 0.05 * all) return 0.0;
    return static_cast<double>(in) / all;
  };
  // Hypotheses: for every straight edge, every face size, both ends.
  std::vector<FaceRect> hyps;
  for (const std::vector<cv::Point>& contour : contours) {
    std::vector<cv::Point> poly;
    cv::approxPolyDP(contour, poly, 2.0, true);
    for (size_t i = 0; i < poly.size(); ++i) {
      const Eigen::Vector2d p = to_plane(poly[i].x, poly[i].y), q = to_plane(poly[(i + 1) % poly.size()].x, poly[(i + 1) % poly.size()].y);
      const double len = (q - p).norm();
      if (len < 0.015) continue;
      const Eigen::Vector2d t = (q - p) / len;
      for (const KnownShape& sh : shapes)
        for (int a = 0; a < 3 && sh.shape == ObjectShape::kBox; ++a) {
          const int b = (a + 1) % 3, d = (a + 2) % 3;
          for (int sw = 0; sw < 2; ++sw) {
            const double along = 2 * sh.half_size[sw ? d : b], across = 2 * sh.half_size[sw ? b : d];
            if (len < 0.5 * along) continue;
            for (int end = 0; end < 2; ++end)
              for (int side = 0; side < 2; ++side) {
                const Eigen::Vector2d n = side ? Eigen::Vector2d(-t.y(), t.x()) : Eigen::Vector2d(t.y(), -t.x());
                const Eigen::Vector2d start = end ? Eigen::Vector2d(q - t * along) : p;
                FaceRect fr;
                fr.shape = &sh, fr.up = a, fr.swap = sw, fr.half_w = along / 2, fr.half_h = across / 2;
                fr.c = start + t * (along / 2) + n * (across / 2);
                fr.theta = std::atan2(t.y(), t.x());
                hyps.push_back(fr);
              }
          }
        }
    }
  }
  for (;;) {
    double best = min_coverage;
    int pick = -1;
    for (size_t i = 0; i < hyps.size(); ++i) {
      const double cov = coverage(hyps[i]);
      if (cov > best) best = cov, pick = static_cast<int>(i);
    }
    if (pick < 0) break;
    FaceRect fr = hyps[static_cast<size_t>(pick)];
    // Claim its cells.
    const Eigen::Vector2d ax(std::cos(fr.theta), std::sin(fr.theta)), ay(-std::sin(fr.theta), std::cos(fr.theta));
    int cells = 0;
    for (double s = -fr.half_w; s <= fr.half_w; s += cell / 2)
      for (double t = -fr.half_h; t <= fr.half_h; t += cell / 2) {
        const Eigen::Vector2d q = fr.c + s * ax + t * ay;
        const int gx = static_cast<int>(std::floor((q.x() - x0) / cell)) + 1, gy = static_cast<int>(std::floor((q.y() - y0) / cell)) + 1;
        if (gx >= 0 && gy >= 0 && gx < gw && gy < gh && !claimed.at<uint8_t>(gy, gx)) claimed.at<uint8_t>(gy, gx) = 255, ++cells;
      }
    fitOutline(edge, fr, false);
    fr.pixels = cells;
    fr.seen = best;
    out.push_back(fr);
  }
  return out;
}

}  // namespace

CameraPerceptionResult detectKnownObjects(const Frame& frame, const std::vector<KnownShape>& shapes,
                                   const CameraPerceptionOptions& o, Rng& rng) {
  CameraPerceptionResult res;
  // Wall-clock time of each step, for benchmarks only (nothing decides by it).
  auto mark = std::chrono::steady_clock::now();
  auto lap = [&](double& into) {
    const auto now = std::chrono::steady_clock::now();
    into += std::chrono::duration<double>(now - mark).count();
    mark = now;
  };
  const CameraModel& cam = frame.camera;
  const int w = cam.width, h = cam.height;
  if (frame.depth.size() != static_cast<size_t>(w) * static_cast<size_t>(h)) {
    res.reason = "no depth image";
    return res;
  }
  // Points inside the crop box, in the crop frame (z up from the bin floor), and their pixels.
  const Pose T_crop_camera = o.T_world_crop.inverse() * cam.T_world_camera;
  std::vector<Vec3> pts;
  std::vector<int> pix;
  pts.reserve(static_cast<size_t>(w) * static_cast<size_t>(h) / 4);
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      const float z = frame.depth[static_cast<size_t>(v) * static_cast<size_t>(w) + static_cast<size_t>(u)];
      if (z <= 0) continue;
      const Vec3 p = T_crop_camera * Vec3((u - cam.cx) / cam.fx * z, (v - cam.cy) / cam.fy * z, z);
      if (o.crop_half.x() > 0 && (std::abs(p.x()) > o.crop_half.x() || std::abs(p.y()) > o.crop_half.y())) continue;
      if (p.z() < -0.03 || p.z() > o.crop_height) continue;
      pts.push_back(p);
      pix.push_back(v * w + u);
    }
  // Depth missing over the bin: the pixels whose rays meet the bin's floor inside its footprint
  // (what is in the bin stands in front of the floor and has depth too), against those of them
  // with none. A few percent are lost at depth edges; a blackout or a dropout loses much more.
  if (o.crop_half.x() > 0) {
    const Mat3 R = T_crop_camera.linear();
    const Vec3 t = T_crop_camera.translation();
    double u0 = w, u1 = 0, v0 = h, v1 = 0;
    for (double sx : {-1.0, 1.0})
      for (double sy : {-1.0, 1.0}) {
        const Vec3 c = T_crop_camera.inverse() * Vec3(sx * o.crop_half.x(), sy * o.crop_half.y(), 0);
        if (c.z() <= 0) continue;
        u0 = std::min(u0, cam.fx * c.x() / c.z() + cam.cx), u1 = std::max(u1, cam.fx * c.x() / c.z() + cam.cx);
        v0 = std::min(v0, cam.fy * c.y() / c.z() + cam.cy), v1 = std::max(v1, cam.fy * c.y() / c.z() + cam.cy);
      }
    long floor_px = 0, missing_px = 0;
    for (int v = std::max(0, static_cast<int>(v0)); v < std::min(h, static_cast<int>(v1) + 1); ++v)
      for (int u = std::max(0, static_cast<int>(u0)); u < std::min(w, static_cast<int>(u1) + 1); ++u) {
        const Vec3 d = R * Vec3((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1.0);
        if (d.z() >= 0) continue;
        const Vec3 hit = t + (-t.z() / d.z()) * d;
        if (std::abs(hit.x()) > o.crop_half.x() || std::abs(hit.y()) > o.crop_half.y()) continue;
        ++floor_px;
        missing_px += !(frame.depth[static_cast<size_t>(v) * static_cast<size_t>(w) + static_cast<size_t>(u)] > 0);
      }
    res.missing = floor_px > 0 ? static_cast<double>(missing_px) / static_cast<double>(floor_px) : 0.0;
    if (res.missing > o.max_missing) {
      char buf[160];
      std::snprintf(buf, sizeof buf, "no depth over %.0f%% of the bin (more than %.0f%%: a blackout or a dropout); look again",
                    100 * res.missing, 100 * o.max_missing);
      res.reason = buf;
      return res;
    }
  }
  if (pts.size() < 100) {
    res.reason = "the camera sees too little of the bin (" + std::to_string(pts.size()) + " points)";
    return res;
  }
  lap(res.seconds.cloud);
  // The support plane: the bin floor. What rises above it is objects.
  const Plane floor = ransacPlane(pts, o.plane_threshold, rng, &res.plane_inliers);
  lap(res.seconds.floor);
  std::vector<int> index_of(static_cast<size_t>(w) * static_cast<size_t>(h), -1);  // pixel -> point
  for (size_t i = 0; i < pts.size(); ++i)
    if (floor.distance(pts[i]) > o.plane_threshold) {
      index_of[static_cast<size_t>(pix[i])] = static_cast<int>(i);
    }
  // The faces: regions of the image grown over points that lie on one plane (within the sensor's
  // noise), from seeds where the surface is flattest (PCL's region growing orders its seeds by
  // curvature for the same reason: a seed on a ridge would grow a strip across two faces). A
  // region's plane is refitted as it grows. Touching faces at different heights or angles part;
  // coplanar touching faces stay one region (the rectangles found in it later).
  const std::vector<std::vector<int>> cluster_pixels = growFaces(pts, index_of, w, h, frame.depth, o, floor);
  lap(res.seconds.faces);
  const Vec3 eye = T_crop_camera.translation();
  auto ray = [&](int k) {
    const int u = k % w, v = k / w;
    return Vec3(T_crop_camera.linear() * Vec3((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1.0));
  };
  for (const std::vector<int>& px : cluster_pixels) {
    if (static_cast<int>(px.size()) < o.min_pixels) continue;
    auto point = [&](int k) { return pts[static_cast<size_t>(index_of[static_cast<size_t>(k)])]; };
    // The face: the region's points (a few of an adjoining face's rim among them: the refit's
    // band below leaves them out).
    std::vector<Vec3> top_pts;
    for (int k : px) top_pts.push_back(point(k));
    // The plane through them, refitted on its inliers: the highest centimetre of a cluster also
    // holds the rims of the sides the camera sees. The band is 2.5 robust sigmas of the residuals
    // (the sensor's noise, from the median absolute deviation), at least 1.5 mm.
    Plane face = fitPlane(top_pts);
    double band = 0.008;
    for (int round = 0; round < 4; ++round) {
      std::vector<double> dev;
      for (const Vec3& p : top_pts) dev.push_back(std::abs(face.distance(p)));
      std::nth_element(dev.begin(), dev.begin() + static_cast<long>(dev.size() / 2), dev.end());
      band = std::clamp(2.5 * 1.4826 * dev[dev.size() / 2], 0.0015, 0.008);
      std::vector<Vec3> in;
      for (const Vec3& p : top_pts)
        if (std::abs(face.distance(p)) < band) in.push_back(p);
      if (in.size() < 10) break;
      face = fitPlane(in);
    }
    // A box resting on the floor has its top face parallel to it: within 3 degrees, take the floor's
    // normal (fitted on thousands of points) rather than the face's own (hundreds).
    if (face.n.dot(floor.n) > std::cos(3 * M_PI / 180)) {
      double sum = 0;
      int count = 0;
      for (const Vec3& p : top_pts)
        if (std::abs(face.distance(p)) < band) sum += floor.n.dot(p), ++count;
      face.n = floor.n;
      face.d = sum / std::max(1, count);
    }
    // The face's pixels (those within the band: the visible sides' rims stay out as far as the
    // noise allows), each placed where its ray meets the plane: the depth noise leaves the
    // outline alone, only the pixel grid limits it.
    std::vector<int> face_px;
    for (int k : px)
      if (std::abs(face.distance(point(k))) < band) face_px.push_back(k);
    if (face_px.size() < 10) continue;
    const Vec3 e1 = face.n.unitOrthogonal(), e2 = face.n.cross(e1);
    auto on_plane = [&](int k) {
      const Vec3 d = ray(k);
      const Vec3 p = eye + d * ((face.d - face.n.dot(eye)) / face.n.dot(d));
      return Eigen::Vector2d(e1.dot(p), e2.dot(p));
    };
    std::vector<cv::Point2f> flat;
    for (int k : face_px) {
      const Eigen::Vector2d q = on_plane(k);
      flat.emplace_back(static_cast<float>(q.x()), static_cast<float>(q.y()));
    }
    // The face's outline: its mask closed (the pixels the sensor lost at the edges and the few its
    // noise took out of the band: a pixel's place on the plane needs its ray, not its depth), then
    // eroded by a pixel (what is left of a side's rim goes), and its boundary.
    cv::Mat face_mask = cv::Mat::zeros(h, w, CV_8UC1), closed, eroded;
    for (int k : face_px) face_mask.data[k] = 255;
    cv::morphologyEx(face_mask, closed, cv::MORPH_CLOSE, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(5, 5)));
    cv::erode(closed, eroded, cv::getStructuringElement(cv::MORPH_CROSS, cv::Size(3, 3)));
    int u0 = w, u1 = 0, v0 = h, v1 = 0;
    for (int k : face_px) u0 = std::min(u0, k % w), u1 = std::max(u1, k % w), v0 = std::min(v0, k / w), v1 = std::max(v1, k / w);
    std::vector<Eigen::Vector2d> edge;
    for (int v = std::max(1, v0 - 3); v < std::min(h - 1, v1 + 4); ++v)
      for (int u = std::max(1, u0 - 3); u < std::min(w - 1, u1 + 4); ++u) {
        const int k = v * w + u;
        if (!eroded.data[k]) continue;
        if (eroded.data[k - 1] && eroded.data[k + 1] && eroded.data[k - w] && eroded.data[k + w]) continue;
        edge.push_back(on_plane(k));
      }
    if (edge.size() < 12) continue;
    // A rectangle found on the face becomes a box behind it, if the box rests on something.
    auto emit = [&](const FaceRect& fr) {
      const int up = fr.up, b = (up + 1) % 3, d = (up + 2) % 3;
      const Vec3 side_w = std::cos(fr.theta) * e1 + std::sin(fr.theta) * e2;
      Mat3 R_crop;
      R_crop.col(up) = face.n;
      R_crop.col(fr.swap ? d : b) = side_w;
      R_crop.col(fr.swap ? b : d) = face.n.cross(side_w);
      if (R_crop.determinant() < 0) R_crop.col(fr.swap ? b : d) *= -1;
      const Vec3 centre2 = fr.c.x() * e1 + fr.c.y() * e2;
      const Vec3 on_face = centre2 + face.n * (face.d - face.n.dot(centre2));
      const KnownShape& sh = *fr.shape;
      const Pose T_crop_box = makePose(on_face - face.n * sh.half_size[up], R_crop);
      double lowest = 1;
      for (int c = 0; c < 8; ++c) {
        const Vec3 v((c & 1 ? 1 : -1) * sh.half_size.x(), (c & 2 ? 1 : -1) * sh.half_size.y(), (c & 4 ? 1 : -1) * sh.half_size.z());
        lowest = std::min(lowest, floor.distance(T_crop_box * v));
      }
      if (lowest < -0.01) return;
      CameraDetection det;
      det.pixels = static_cast<int>(px.size());
      det.face_pixels = fr.pixels;
      det.object.seen = fr.seen;
      det.object.name = sh.name;
      det.object.half_size = sh.half_size;
      det.object.mass = sh.mass;
      det.object.T_world_object = o.T_world_crop * T_crop_box;
      res.detections.push_back(det);
    };
    const cv::RotatedRect rect = cv::minAreaRect(flat);
    // A round face: an upright cylinder's top disc (its hull fills pi/4 of the bounding square, a
    // rectangle's all of it), of a catalogue cylinder's radius within 5 mm. Its centre and radius
    // fitted to the outline points (Gauss-Newton; the erosion's inset moves only the radius).
    if (std::any_of(shapes.begin(), shapes.end(), [](const KnownShape& k) { return k.shape == ObjectShape::kCylinder; })) {
      std::vector<cv::Point2f> hull;
      cv::convexHull(flat, hull);
      const double fill = cv::contourArea(hull) / std::max(1e-12, static_cast<double>(rect.size.width) * rect.size.height);
      cv::Point2f cc;
      float rr = 0;
      cv::minEnclosingCircle(flat, cc, rr);
      const KnownShape* cyl = nullptr;
      double best_dr = 0.005;
      for (const KnownShape& k : shapes)
        if (k.shape == ObjectShape::kCylinder && std::abs(rr - k.half_size.x()) < best_dr) best_dr = std::abs(rr - k.half_size.x()), cyl = &k;
      if (fill < 0.88 && cyl) {
        Eigen::Vector2d c(cc.x, cc.y);
        double radius = rr;
        for (int it = 0; it < 15; ++it) {
          Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
          Eigen::Vector3d g = Eigen::Vector3d::Zero();
          for (const Eigen::Vector2d& q : edge) {
            const Eigen::Vector2d dq = q - c;
            const double dist = dq.norm();
            if (dist < 1e-9) continue;
            const double r = dist - radius;
            const double wgt = std::abs(r) < 0.003 ? 1.0 : 0.003 / std::abs(r);
            const Eigen::Vector3d J(-dq.x() / dist, -dq.y() / dist, -1.0);
            H += wgt * J * J.transpose();
            g += wgt * J * r;
          }
          const Eigen::Vector3d step = H.ldlt().solve(-g);
          if (!step.allFinite()) break;
          c += step.head<2>();
          radius += step(2);
          if (step.norm() < 1e-8) break;
        }
        const Vec3 centre2 = c.x() * e1 + c.y() * e2;
        const Vec3 on_face = centre2 + face.n * (face.d - face.n.dot(centre2));
        const Vec3 centre = on_face - face.n * cyl->half_size.z();
        if (floor.distance(centre) - cyl->half_size.z() * face.n.dot(floor.n) > -0.01) {
          Mat3 R_crop;
          R_crop.col(2) = face.n;
          R_crop.col(0) = e1;
          R_crop.col(1) = face.n.cross(e1);
          CameraDetection det;
          det.pixels = static_cast<int>(px.size());
          det.face_pixels = static_cast<int>(face_px.size());
          det.object.name = cyl->name;
          det.object.shape = ObjectShape::kCylinder;
          det.object.half_size = cyl->half_size;
          det.object.mass = cyl->mass;
          det.object.T_world_object = o.T_world_crop * makePose(centre, R_crop);
          res.detections.push_back(det);
        }
        continue;
      }
    }
    // One face of one box: the rectangle around it (minAreaRect), the kind and the axis standing up
    // whose face sides fit it best, then the outline fit (centre, angle and size: the erosion's
    // inset, the same on every side, moves neither the centre nor the angle).
    FaceRect one;
    one.pixels = static_cast<int>(face_px.size());
    const double cost = bestFaceKind(shapes, rect.size.width, rect.size.height, &one);
    if (one.shape && cost <= 0.006) {
      one.c = Eigen::Vector2d(rect.center.x, rect.center.y);
      one.theta = rect.angle * M_PI / 180.0;
      fitOutline(edge, one, true);
      emit(one);
      continue;
    }
    // Several boxes' faces side by side in one plane (touching cubes, as dropped): rectangles of
    // the catalogue's face sizes laid along the outline's straight edges, the best covered first.
    // A face partly hidden (under a leaning box) is one of them: covered at least half where the
    // rest is hidden, not seen through. What the camera sees at a point of the face's plane: 0 a
    // surface at its depth, 1 something nearer, 2 something farther (past the face), 3 nothing (a
    // lost pixel, outside the image).
    auto seen = [&](const Eigen::Vector2d& q) {
      const Vec3 on = q.x() * e1 + q.y() * e2;
      const Vec3 p_crop = on + face.n * (face.d - face.n.dot(on));
      const Vec3 pc = T_crop_camera.inverse() * p_crop;
      if (pc.z() <= 0) return 0;
      const int u = static_cast<int>(std::lround(cam.fx * pc.x() / pc.z() + cam.cx)), v = static_cast<int>(std::lround(cam.fy * pc.y() / pc.z() + cam.cy));
      if (u < 0 || v < 0 || u >= w || v >= h) return 0;
      const double z = frame.depth[static_cast<size_t>(v) * static_cast<size_t>(w) + static_cast<size_t>(u)];
      const double tol = 3 * std::max(0.0005, o.depth_sigma_k * pc.z() * pc.z()) + 0.002;
      if (z <= 0) return 3;
      if (std::abs(z - pc.z()) <= tol) return 0;
      return z < pc.z() ? 1 : 2;
    };
    for (const FaceRect& fr : packFaceRects(flat, edge, shapes, seen, 0.5)) emit(fr);
  }
  // One box seen by two faces (a tilted cube shows two or three): the face seen best stands for it.
  std::stable_sort(res.detections.begin(), res.detections.end(),
                   [](const CameraDetection& a, const CameraDetection& b) { return a.face_pixels > b.face_pixels; });
  std::vector<CameraDetection> kept;
  for (const CameraDetection& d : res.detections) {
    bool same = false;
    for (const CameraDetection& k : kept)
      same = same || (k.object.T_world_object.translation() - d.object.T_world_object.translation()).norm() <
                         std::min(k.object.half_size.minCoeff(), d.object.half_size.minCoeff());
    if (!same) kept.push_back(d);
  }
  res.detections = std::move(kept);
  lap(res.seconds.fit);
  // The points no detection explains (outside every detected box grown by 4 mm sideways and by
  // 4 sigma of the depth noise along the axis nearest the vertical: a margin wider sideways would
  // eat into a touching neighbour just where a finger goes down), in connected patches of at least
  // `min_pixels`, each an upright box from the floor to its top.
  {
    std::vector<Pose> T_box_crop;
    std::vector<Vec3> margin;
    const double vertical = 4 * std::max(0.0005, o.depth_sigma_k * eye.z() * eye.z()) + 0.002;
    for (const CameraDetection& d : res.detections) {
      T_box_crop.push_back((o.T_world_crop.inverse() * d.object.T_world_object).inverse());
      int up = 0;
      for (int a = 1; a < 3; ++a)
        if (std::abs(T_box_crop.back().linear()(a, 2)) > std::abs(T_box_crop.back().linear()(up, 2))) up = a;
      Vec3 m = Vec3::Constant(0.004);
      m[up] = vertical;
      margin.push_back(m);
    }
    cv::Mat loose = cv::Mat::zeros(h, w, CV_8UC1);
    for (size_t i = 0; i < pts.size(); ++i) {
      if (floor.distance(pts[i]) <= o.plane_threshold) continue;
      bool explained = false;
      for (size_t b = 0; b < T_box_crop.size() && !explained; ++b) {
        const Vec3 q = T_box_crop[b] * pts[i];
        explained = ((q.cwiseAbs() - res.detections[b].object.half_size - margin[b]).array() < 0).all();
      }
      if (!explained) loose.data[pix[i]] = 255;
    }
    cv::morphologyEx(loose, loose, cv::MORPH_OPEN, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3)));
    cv::Mat labels, stats, centroids;
    const int n = cv::connectedComponentsWithStats(loose, labels, stats, centroids, 8, CV_32S);
    std::vector<std::vector<cv::Point2f>> xy(static_cast<size_t>(n));
    std::vector<double> top(static_cast<size_t>(n), 0.0);
    for (size_t i = 0; i < pts.size(); ++i) {
      const int l = labels.at<int>(pix[i]);
      if (l <= 0 || stats.at<int>(l, cv::CC_STAT_AREA) < o.min_pixels) continue;
      xy[static_cast<size_t>(l)].emplace_back(static_cast<float>(pts[i].x()), static_cast<float>(pts[i].y()));
      top[static_cast<size_t>(l)] = std::max(top[static_cast<size_t>(l)], floor.distance(pts[i]));
    }
    for (int l = 1; l < n; ++l) {
      if (xy[static_cast<size_t>(l)].size() < 3) continue;
      const cv::RotatedRect r = cv::minAreaRect(xy[static_cast<size_t>(l)]);
      Obstacle ob;
      ob.type = Obstacle::Type::kBox;
      ob.size = Vec3(r.size.width / 2 + 0.003, r.size.height / 2 + 0.003, top[static_cast<size_t>(l)] / 2);
      const double floor_z = floor.d / floor.n.z();  // the floor's height under the crop frame's origin
      ob.T_world = o.T_world_crop * makePose(Vec3(r.center.x, r.center.y, floor_z + ob.size.z()), rotZ(r.angle * M_PI / 180));
      ob.name = "unexplained_" + std::to_string(res.unexplained.size());
      res.unexplained.push_back(ob);
    }
  }
  lap(res.seconds.unexplained);
  res.ok = !res.detections.empty();
  if (!res.ok) res.reason = "no object detected in the depth image";
  return res;
}

// Whether each pixel of a depth image (w x h) lies on an edge: its 3x3 neighbourhood (the image's
// border repeated) holds valid depths (> 0) spanning more than `jump`. The neighbourhood's least
// and greatest valid depths, by rows then by columns (a min and max filter: the same values as
// read pixel by pixel, whatever the order). Only a pixel with a depth can be on an edge. A row at
// a time, from three rows' filters kept in turn (nothing image-sized: the row's edges are found
// before the noise is written over it, and the row below is read while still as rendered).
namespace {
class DepthEdges {
 public:
  DepthEdges(const std::vector<float>& depth, int w, int h, double jump)
      : depth_(depth), w_(w), h_(h), jump_(jump), lo_(3 * static_cast<size_t>(w)), hi_(3 * static_cast<size_t>(w)),
        a_(static_cast<size_t>(w)), b_(static_cast<size_t>(w)) {}

  /// Row v's edges into `edge` (w of them). Rows are asked for in order, 0 first; row v reads the
  /// depth of rows v - 1 to v + 1 as they were when first read (v + 1 is read here).
  void row(int v, char* edge) {
    const int up = std::max(v - 1, 0), down = std::min(v + 1, h_ - 1);
    for (; filtered_ <= down; ++filtered_) filterRow(filtered_);
    const float* lu = slot(lo_, up);
    const float* la = slot(lo_, v);
    const float* ld = slot(lo_, down);
    const float* gu = slot(hi_, up);
    const float* ga = slot(hi_, v);
    const float* gd = slot(hi_, down);
    const float* z = depth_.data() + static_cast<size_t>(v) * w_;
    for (int u = 0; u < w_; ++u) {
      const float least = std::min(std::min(lu[u], la[u]), ld[u]);
      const float most = std::max(std::max(gu[u], ga[u]), gd[u]);
      edge[u] = static_cast<char>((z[u] > 0) & (static_cast<double>(most - least) > jump_));
    }
  }

 private:
  static constexpr float kInf = std::numeric_limits<float>::infinity();
  const float* slot(const std::vector<float>& rows, int v) const { return rows.data() + static_cast<size_t>(v % 3) * w_; }

  // Over each pixel's row of three: the least valid depth (+inf if none) and the greatest (-inf).
  // Branch-free loops the compiler vectorizes (min and max of floats are exact: the same values).
  void filterRow(int v) {
    const int w = w_;
    const float* row = depth_.data() + static_cast<size_t>(v) * w;
    float* l = lo_.data() + static_cast<size_t>(v % 3) * w;
    float* g = hi_.data() + static_cast<size_t>(v % 3) * w;
    float* a = a_.data();
    float* b = b_.data();
    for (int u = 0; u < w; ++u) {
      const bool valid = row[u] > 0;  // not a NaN either
      a[u] = valid ? row[u] : kInf;
      b[u] = valid ? row[u] : -kInf;
    }
    for (int u = 1; u + 1 < w; ++u) {
      l[u] = std::min(std::min(a[u - 1], a[u]), a[u + 1]);
      g[u] = std::max(std::max(b[u - 1], b[u]), b[u + 1]);
    }
    for (const int u : {0, w - 1}) {  // the border repeated
      const int u0 = std::max(u - 1, 0), u1 = std::min(u + 1, w - 1);
      l[u] = std::min(std::min(a[u0], a[u]), a[u1]);
      g[u] = std::max(std::max(b[u0], b[u]), b[u1]);
    }
  }

  const std::vector<float>& depth_;
  int w_, h_;
  double jump_;
  int filtered_ = 0;  // the rows filtered so far
  std::vector<float> lo_, hi_, a_, b_;  // three rows' filters (row v in slot v % 3); one row's inputs
};
}  // namespace

void applyDepthNoise(Frame& f, const DepthNoise& noise, Rng& rng) {
  const int w = f.camera.width, h = f.camera.height;
  if (f.depth.empty()) return;
  DepthEdges edges(f.depth, w, h, noise.edge_jump);
  std::vector<char> edge(static_cast<size_t>(w));
  std::vector<double> gauss_row(static_cast<size_t>(w)), drop_row(static_cast<size_t>(w));
  for (int v = 0; v < h; ++v) {
    // Every pixel draws the same numbers whatever happens to it, so the streams stay aligned: a
    // normal then a uniform, a row at a time.
    if (noise.sampler == NoiseSampler::kBoxMuller) rng.boxMullerNormalsAndUniforms(gauss_row.data(), drop_row.data(), gauss_row.size());
    else rng.normalsAndUniforms(gauss_row.data(), drop_row.data(), gauss_row.size());
    edges.row(v, edge.data());  // before the row is written over
    float* d = f.depth.data() + static_cast<size_t>(v) * static_cast<size_t>(w);
    const char* e = edge.data();
    for (size_t u = 0; u < static_cast<size_t>(w); ++u) {  // branch-free: the drops are a coin's toss
      const float z = d[u];
      const bool lost = (drop_row[u] < noise.edge_dropout) & (e[u] != 0);  // lost where the depth jumps
      const float noisy = static_cast<float>(z + gauss_row[u] * noise.k * z * z);
      d[u] = z <= 0 ? z : lost ? 0.0f : noisy;
    }
  }
}

PoseError poseError(const Pose& est, const Pose& truth, const Vec3& half, ObjectShape shape) {
  PoseError e;
  e.centre = (est.translation() - truth.translation()).norm();
  e.rotation = e.mssd = std::numeric_limits<double>::infinity();
  if (shape == ObjectShape::kCylinder) {
    e.rotation = std::acos(std::min(1.0, std::abs(est.linear().col(2).dot(truth.linear().col(2)))));
    std::vector<Vec3> rim;
    for (int k = 0; k < 36; ++k)
      for (double z : {-half.z(), half.z()}) rim.emplace_back(half.x() * std::cos(k * M_PI / 18), half.x() * std::sin(k * M_PI / 18), z);
    for (double flip : {0.0, M_PI})
      for (int k = 0; k < 180; ++k) {
        const Pose sym = truth * makePose(Vec3::Zero(), Mat3(rotX(flip) * rotZ(k * M_PI / 90)));
        double worst = 0;
        for (const Vec3& v : rim) worst = std::max(worst, (est * v - sym * v).norm());
        e.mssd = std::min(e.mssd, worst);
      }
    return e;
  }
  for (const Mat3& S : symmetries(half)) {
    const Mat3 R = est.linear().transpose() * truth.linear() * S;
    e.rotation = std::min(e.rotation, std::acos(std::clamp((R.trace() - 1) / 2, -1.0, 1.0)));
    const Pose sym = truth * makePose(Vec3::Zero(), S);
    double worst = 0;
    for (int c = 0; c < 8; ++c) {
      const Vec3 v((c & 1 ? 1 : -1) * half.x(), (c & 2 ? 1 : -1) * half.y(), (c & 4 ? 1 : -1) * half.z());
      worst = std::max(worst, (est * v - sym * v).norm());
    }
    e.mssd = std::min(e.mssd, worst);
  }
  return e;
}

}  // namespace mm
