#include "perception/camera_perception.h"

#include <opencv2/imgproc.hpp>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace mm {
namespace {

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

}  // namespace

CameraPerceptionResult detectBoxes(const Frame& frame, const std::vector<KnownShape>& shapes,
                                   const CameraPerceptionOptions& o, Rng& rng) {
  CameraPerceptionResult res;
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
  if (pts.size() < 100) {
    res.reason = "the camera sees too little of the bin (" + std::to_string(pts.size()) + " points)";
    return res;
  }
  // The support plane: the bin floor. What rises above it is objects.
  const Plane floor = ransacPlane(pts, o.plane_threshold, rng, &res.plane_inliers);
  cv::Mat mask = cv::Mat::zeros(h, w, CV_8UC1);
  std::vector<int> index_of(static_cast<size_t>(w) * static_cast<size_t>(h), -1);  // pixel -> point
  for (size_t i = 0; i < pts.size(); ++i)
    if (floor.distance(pts[i]) > o.plane_threshold) {
      mask.data[pix[i]] = 255;
      index_of[static_cast<size_t>(pix[i])] = static_cast<int>(i);
    }
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
  std::vector<std::vector<int>> cluster_pixels(static_cast<size_t>(n));
  for (int k = 0; k < w * h; ++k) {
    const int l = labels.at<int>(k);
    if (l > 0) cluster_pixels[static_cast<size_t>(l)].push_back(k);
  }
  const Vec3 eye = T_crop_camera.translation();
  auto ray = [&](int k) {
    const int u = k % w, v = k / w;
    return Vec3(T_crop_camera.linear() * Vec3((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1.0));
  };
  for (int l = 1; l < n; ++l) {
    const std::vector<int>& px = cluster_pixels[static_cast<size_t>(l)];
    if (static_cast<int>(px.size()) < o.min_pixels) continue;
    auto point = [&](int k) { return pts[static_cast<size_t>(index_of[static_cast<size_t>(k)])]; };
    // The top face: the points near the cluster's highest (above the floor) surface, and the plane
    // through them.
    std::vector<double> heights;
    for (int k : px) heights.push_back(floor.distance(point(k)));
    std::vector<double> sorted = heights;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() * 9 / 10), sorted.end());
    const double top = sorted[sorted.size() * 9 / 10];
    std::vector<Vec3> top_pts;
    for (size_t i = 0; i < px.size(); ++i)
      if (heights[i] > top - 0.01) top_pts.push_back(point(px[i]));
    if (top_pts.size() < 10) continue;
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
    const cv::RotatedRect rect = cv::minAreaRect(flat);
    const double fw = rect.size.width, fh = rect.size.height;
    const double height = floor.distance(face.n * face.d);  // the face's height above the floor
    // The kind and the axis standing up that fit the face's sides and height best.
    const KnownShape* best = nullptr;
    int up = 2;
    double best_cost = std::numeric_limits<double>::infinity();
    bool swap = false;
    for (const KnownShape& sh : shapes)
      for (int a = 0; a < 3; ++a) {
        const int b = (a + 1) % 3, d = (a + 2) % 3;
        for (int sw = 0; sw < 2; ++sw) {
          const double sa = 2 * sh.half_size[sw ? d : b], sb = 2 * sh.half_size[sw ? b : d];
          const double cost = std::abs(fw - sa) + std::abs(fh - sb) + std::abs(height - 2 * sh.half_size[a]);
          if (cost < best_cost) best_cost = cost, best = &sh, up = a, swap = sw;
        }
      }
    // Not a known box (a bin wall's top, the hand reaching in): nothing the robot should pick.
    if (!best || best_cost > 0.02) continue;
    const int b = (up + 1) % 3, d = (up + 2) % 3;
    const double half_w = best->half_size[swap ? d : b], half_h = best->half_size[swap ? b : d];
    // The outline fit: the face's boundary pixels against the known rectangle's four edges, its
    // centre and angle by Gauss-Newton from minAreaRect's (pixel quantization averages out over
    // the edges' many pixels, where minAreaRect's hull rests on a few).
    // The face's mask closed (the pixels the sensor lost at the edges and the few its noise took
    // out of the band: a pixel's place on the plane needs its ray, not its depth), then eroded by
    // a pixel (what is left of a side's rim goes), and its boundary. The rectangle's size is
    // fitted too, so that the erosion's inset, the same on every side, moves neither the centre
    // nor the angle.
    cv::Mat face_mask = cv::Mat::zeros(h, w, CV_8UC1), closed, eroded;
    for (int k : face_px) face_mask.data[k] = 255;
    cv::morphologyEx(face_mask, closed, cv::MORPH_CLOSE, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(5, 5)));
    cv::erode(closed, eroded, cv::getStructuringElement(cv::MORPH_CROSS, cv::Size(3, 3)));
    std::vector<Eigen::Vector2d> edge;
    for (int v = 1; v < h - 1; ++v)
      for (int u = 1; u < w - 1; ++u) {
        const int k = v * w + u;
        if (!eroded.data[k]) continue;
        if (eroded.data[k - 1] && eroded.data[k + 1] && eroded.data[k - w] && eroded.data[k + w]) continue;
        edge.push_back(on_plane(k));
      }
    if (edge.size() < 12) continue;
    Eigen::Vector2d c(rect.center.x, rect.center.y);
    double theta = rect.angle * M_PI / 180.0;
    double fit_w = half_w, fit_h = half_h;
    for (int it = 0; it < 15; ++it) {
      Eigen::Matrix<double, 5, 5> H = Eigen::Matrix<double, 5, 5>::Zero();
      Eigen::Matrix<double, 5, 1> g = Eigen::Matrix<double, 5, 1>::Zero();
      const Eigen::Vector2d ax(std::cos(theta), std::sin(theta)), ay(-std::sin(theta), std::cos(theta));
      for (const Eigen::Vector2d& q : edge) {
        const Eigen::Vector2d r = q - c;
        const double x = ax.dot(r), y = ay.dot(r);
        // The nearer of the two edges across the point's side: the x edges or the y edges.
        const bool x_edge = std::abs(std::abs(x) - fit_w) < std::abs(std::abs(y) - fit_h);
        const Eigen::Vector2d nrm = x_edge ? (x >= 0 ? ax : Eigen::Vector2d(-ax)) : (y >= 0 ? ay : Eigen::Vector2d(-ay));
        const double res_k = nrm.dot(r) - (x_edge ? fit_w : fit_h);
        const double wgt = std::abs(res_k) < 0.003 ? 1.0 : 0.003 / std::abs(res_k);
        // d/dc = -n; d/dtheta = (dn/dtheta) . r, dn/dtheta = n rotated by +90 degrees; d/dsize = -1.
        const Eigen::Vector2d dn(-nrm.y(), nrm.x());
        Eigen::Matrix<double, 5, 1> J;
        J << -nrm.x(), -nrm.y(), dn.dot(r), x_edge ? -1.0 : 0.0, x_edge ? 0.0 : -1.0;
        H += wgt * J * J.transpose();
        g += wgt * J * res_k;
      }
      const Eigen::Matrix<double, 5, 1> step = H.ldlt().solve(-g);
      if (!step.allFinite()) break;
      c += step.head<2>();
      theta += step(2);
      fit_w += step(3);
      fit_h += step(4);
      if (step.norm() < 1e-8) break;
    }
    // The box frame: `up` along the face normal, the fitted rectangle's sides along the other two.
    const Vec3 side_w = std::cos(theta) * e1 + std::sin(theta) * e2;
    Mat3 R_crop;
    R_crop.col(up) = face.n;
    R_crop.col(swap ? d : b) = side_w;
    R_crop.col(swap ? b : d) = face.n.cross(side_w);
    if (R_crop.determinant() < 0) R_crop.col(swap ? b : d) *= -1;
    const Vec3 centre2 = c.x() * e1 + c.y() * e2;
    const Vec3 on_face = centre2 + face.n * (face.d - face.n.dot(centre2));
    CameraDetection det;
    det.pixels = static_cast<int>(px.size());
    det.face_pixels = static_cast<int>(face_px.size());
    det.object.name = best->name;
    det.object.half_size = best->half_size;
    det.object.mass = best->mass;
    det.object.T_world_object = o.T_world_crop * makePose(on_face - face.n * best->half_size[up], R_crop);
    res.detections.push_back(det);
  }
  res.ok = !res.detections.empty();
  if (!res.ok) res.reason = "no object detected in the depth image";
  return res;
}

void applyDepthNoise(Frame& f, const DepthNoise& noise, Rng& rng) {
  const int w = f.camera.width, h = f.camera.height;
  if (f.depth.empty()) return;
  const std::vector<float> z0 = f.depth;
  auto at = [&](int u, int v) { return z0[static_cast<size_t>(v) * static_cast<size_t>(w) + static_cast<size_t>(u)]; };
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      float& z = f.depth[static_cast<size_t>(v) * static_cast<size_t>(w) + static_cast<size_t>(u)];
      // Every pixel draws the same numbers whatever happens to it, so the streams stay aligned.
      const double gauss = rng.normal(), drop = rng.uniform();
      if (z <= 0) continue;
      float lo = z, hi = z;
      for (int dv = -1; dv <= 1; ++dv)
        for (int du = -1; du <= 1; ++du) {
          const int uu = std::clamp(u + du, 0, w - 1), vv = std::clamp(v + dv, 0, h - 1);
          const float zz = at(uu, vv);
          if (zz <= 0) continue;
          lo = std::min(lo, zz), hi = std::max(hi, zz);
        }
      if (hi - lo > noise.edge_jump && drop < noise.edge_dropout) {
        z = 0;
        continue;
      }
      z = static_cast<float>(z + gauss * noise.k * z * z);
    }
}

PoseError poseError(const Pose& est, const Pose& truth, const Vec3& half) {
  PoseError e;
  e.centre = (est.translation() - truth.translation()).norm();
  e.rotation = e.mssd = std::numeric_limits<double>::infinity();
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
