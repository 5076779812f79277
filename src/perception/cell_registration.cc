#include "perception/cell_registration.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>

namespace mm {

namespace {

// The nearest point of a box's surface to p (world frame), the surface's outward normal there
// (outside a face: towards p; beyond an edge or corner: along p - q) and p's signed distance
// along it (negative inside the box).
struct SurfacePoint {
  Vec3 q = Vec3::Zero(), n = Vec3::Zero();
  double signed_distance = 0;
};

struct Box {
  Pose T_box_world, T_world_box;
  Vec3 half;
  SurfacePoint nearest(const Vec3& p_world) const {
    const Vec3 p = T_box_world * p_world;
    SurfacePoint s;
    const Vec3 clamped = p.cwiseMax(-half).cwiseMin(half);
    const Vec3 out = p - clamped;
    if (out.squaredNorm() > 0) {
      const double d = out.norm();
      s.q = clamped, s.n = out / d, s.signed_distance = d;
    } else {  // inside: the nearest face
      int axis = 0;
      double depth = 1e18;
      for (int i = 0; i < 3; ++i)
        if (half[i] - std::abs(p[i]) < depth) depth = half[i] - std::abs(p[i]), axis = i;
      s.q = p;
      s.q[axis] = p[axis] >= 0 ? half[axis] : -half[axis];
      s.n = Vec3::Zero();
      s.n[axis] = p[axis] >= 0 ? 1.0 : -1.0;
      s.signed_distance = -depth;
    }
    s.q = T_world_box * s.q;
    s.n = T_world_box.linear() * s.n;
    return s;
  }
  // Where the ray from c along unit d (world frame) enters the box: the distance along it and the
  // face's outward normal (world frame); false when it misses, or starts inside.
  bool enter(const Vec3& c, const Vec3& d, double* t, Vec3* n) const {
    const Vec3 o = T_box_world * c, v = T_box_world.linear() * d;
    double t_in = -1e18, t_out = 1e18;
    int axis = -1;
    for (int i = 0; i < 3; ++i) {
      if (std::abs(v[i]) < 1e-12) {
        if (std::abs(o[i]) > half[i]) return false;
        continue;
      }
      const double a = (-half[i] - o[i]) / v[i], b = (half[i] - o[i]) / v[i];
      if (std::min(a, b) > t_in) t_in = std::min(a, b), axis = i;
      t_out = std::min(t_out, std::max(a, b));
    }
    if (axis < 0 || t_in > t_out || t_in <= 0) return false;
    Vec3 local = Vec3::Zero();
    local[axis] = v[axis] > 0 ? -1.0 : 1.0;
    *t = t_in;
    *n = T_world_box.linear() * local;
    return true;
  }
};

}  // namespace

CellRegistrationOptions checkOptions(CellRegistrationOptions o) {
  o.first_gate = o.last_gate;
  o.max_iterations = 30;
  o.points = 3000;
  o.tolerance = 1e-4;  // a tenth of a millimetre: the check tells millimetres
  return o;
}

CellRegistration registerCameraToCell(const Frame& frame, const std::vector<Obstacle>& statics,
                                      const CellRegistrationOptions& o) {
  CellRegistration res;
  const CameraModel& cam = frame.camera;
  const int w = cam.width, h = cam.height;
  if (frame.depth.size() != static_cast<size_t>(w) * static_cast<size_t>(h)) {
    res.reason = "no depth image";
    return res;
  }
  std::vector<Box> boxes;
  for (const Obstacle& s : statics)
    if (s.type == Obstacle::Type::kBox) boxes.push_back({s.T_world.inverse(), s.T_world, s.size});
  if (boxes.empty()) {
    res.reason = "the cell has no static boxes to register the camera against";
    return res;
  }
  // About o.points of the image's points spread evenly, in the camera frame, and besides them
  // every other pixel where the depth jumps (the walls' faces and top edges, the table's edge):
  // what pins the camera's x, y and turn about the vertical is there, a few hundredths of the image.
  std::vector<Vec3> pc;
  const int coarse = std::max(1, static_cast<int>(std::lround(std::sqrt(static_cast<double>(w) * h / std::max(1, o.points)))));
  const int fine = std::max(1, coarse / 4);
  const int stride = std::max(1, coarse / fine) * fine;  // a multiple of the fine step: the even points lie on its grid
  auto depth = [&](int u, int v) {
    return u < 0 || v < 0 || u >= w || v >= h ? 0.0f : frame.depth[static_cast<size_t>(v) * static_cast<size_t>(w) + static_cast<size_t>(u)];
  };
  for (int v = fine / 2; v < h; v += fine)
    for (int u = fine / 2; u < w; u += fine) {
      const float z = depth(u, v);
      if (!(z > 0)) continue;
      bool keep = (u - fine / 2) % stride == 0 && (v - fine / 2) % stride == 0;
      for (int k = 0; !keep && k < 4; ++k) {
        const int du = k == 0 ? 2 * fine : k == 1 ? -2 * fine : 0, dv = k == 2 ? 2 * fine : k == 3 ? -2 * fine : 0;
        const float zn = depth(u + du, v + dv);
        keep = zn > 0 && std::abs(zn - z) > 0.01f;
      }
      if (keep) pc.push_back(Vec3((u - cam.cx) / cam.fx * z, (v - cam.cy) / cam.fy * z, z));
    }
  long with_depth = 0;
  for (const float z : frame.depth) with_depth += z > 0;
  if (with_depth < static_cast<long>(frame.depth.size()) / 10 || static_cast<int>(pc.size()) < o.min_points) {
    res.blind = with_depth < static_cast<long>(frame.depth.size()) / 10;  // a blackout: nothing to tell by
    char buf[160];
    std::snprintf(buf, sizeof buf, "the camera sees too little (%.0f%% of the image with depth, %zu points)",
                  100.0 * static_cast<double>(with_depth) / static_cast<double>(frame.depth.size()), pc.size());
    res.reason = buf;
    return res;
  }
  Pose T = cam.T_world_camera;
  // Each point's candidate boxes: those within reach at the start (the gate and a margin for the
  // correction), nearest first, at most four.
  constexpr int kCandidates = 4;
  constexpr double kProjectiveGate = 0.02;  // [m]
  std::vector<std::array<int, kCandidates>> near(pc.size());
  {
    const double reach = o.first_gate + 0.03;
    std::vector<std::pair<double, int>> d(boxes.size());
    for (size_t i = 0; i < pc.size(); ++i) {
      const Vec3 p = T * pc[i];
      for (size_t b = 0; b < boxes.size(); ++b) {
        // Beyond the box's bounding sphere by more than the reach: no need for the nearest point.
        const double bound = (p - boxes[b].T_world_box.translation()).norm() - boxes[b].half.norm();
        d[b] = {bound > reach ? bound : std::abs(boxes[b].nearest(p).signed_distance), static_cast<int>(b)};
      }
      std::partial_sort(d.begin(), d.begin() + std::min<size_t>(kCandidates, d.size()), d.end());
      for (int k = 0; k < kCandidates; ++k) near[i][k] = k < static_cast<int>(d.size()) && d[k].first < reach ? d[k].second : -1;
    }
  }
  const Pose T_bin_world = o.T_world_bin.inverse();
  const double inset = 0.004;  // [m] the bin's walls and floor are the cell; what is inside and above is not
  Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
  std::vector<Vec3> region;
  if (o.bin_half.x() > 0) {
    for (double sx : {-1.0, 1.0})
      for (double sy : {-1.0, 1.0})
        for (double z : {0.0, o.bin_height}) region.push_back(o.T_world_bin * Vec3(sx * o.bin_half.x(), sy * o.bin_half.y(), z));
  } else {
    Vec3 mean = Vec3::Zero();
    for (const Vec3& p : pc) mean += T * p;
    region.push_back(mean / static_cast<double>(pc.size()));
  }
  int at_gate = 0;
  double gate = o.first_gate, scale = 1;
  Eigen::Matrix<double, 6, 1> last_step = Eigen::Matrix<double, 6, 1>::Zero();
  int it = 0;
  bool converged = false;
  for (; it < o.max_iterations; ++it) {
    H.setZero();
    Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
    const Vec3 c = T.translation();
    int n = 0;
    double sq = 0, z2 = 0;
    for (size_t i = 0; i < pc.size(); ++i) {
      if (near[i][0] < 0) continue;
      const Vec3 p = T * pc[i];
      bool over_bin = false;  // over the bin's footprint, where an object can stand against a wall
      if (o.bin_half.x() > 0) {
        const Vec3 b = T_bin_world * p;
        // Above the floor by more than the noise allows (3 sigma, at least 4 mm): an object.
        const double above = std::max(inset, 3 * o.depth_sigma_k * pc[i].z() * pc[i].z());
        if (std::abs(b.x()) < o.bin_half.x() - inset && std::abs(b.y()) < o.bin_half.y() - inset && b.z() > above) continue;
        over_bin = std::abs(b.x()) < o.bin_half.x() && std::abs(b.y()) < o.bin_half.y();
      }
      // Far off (wide gates): the nearest surface. Near (narrow gates): the surface the pixel's
      // ray meets first; the sensor's noise is along the ray, and beside an edge the nearest
      // surface can be a face the camera does not see, a bias the nearest match leaves.
      SurfacePoint best;
      if (gate > kProjectiveGate) {
        double best_abs = gate;
        bool found = false;
        for (int k = 0; k < kCandidates && near[i][k] >= 0; ++k) {
          const SurfacePoint s = boxes[static_cast<size_t>(near[i][k])].nearest(p);
          if (std::abs(s.signed_distance) < best_abs) best_abs = std::abs(s.signed_distance), best = s, found = true;
        }
        if (!found) continue;
      } else {
        const Vec3 ray = (p - c).normalized();
        double t_hit = 1e18;
        for (int k = 0; k < kCandidates && near[i][k] >= 0; ++k) {
          double tk;
          Vec3 nk;
          if (boxes[static_cast<size_t>(near[i][k])].enter(c, ray, &tk, &nk) && tk < t_hit) t_hit = tk, best.n = nk;
        }
        best.q = c + t_hit * ray;
        // A point its ray does not explain, just outside a box (beside a wall's top, where the
        // estimate has the ray pass the edge): the nearest point of that box, which tells the
        // estimate which way the edge lies. Points inside a box keep the ray's surface; points
        // over the bin are not taken so (an object against a wall, as high as it, would pull
        // the wall towards it).
        if (t_hit == 1e18 || std::abs(best.n.dot(p - best.q)) > gate) {
          if (over_bin) continue;
          double best_d = gate;
          bool found = false;
          for (int k = 0; k < kCandidates && near[i][k] >= 0; ++k) {
            const SurfacePoint s = boxes[static_cast<size_t>(near[i][k])].nearest(p);
            if (s.signed_distance > 0 && s.signed_distance < best_d) best_d = s.signed_distance, best = s, found = true;
          }
          if (!found) continue;
        }
      }
      const double r = best.n.dot(p - best.q);
      if (std::abs(r) > gate) continue;
      const double wgt = std::abs(r) <= o.huber ? 1.0 : o.huber / std::abs(r);
      Eigen::Matrix<double, 6, 1> J;
      J.head<3>() = (p - c).cross(best.n);
      J.tail<3>() = best.n;
      H += wgt * J * J.transpose();
      g += wgt * r * J;
      sq += r * r;
      z2 += pc[i].z() * pc[i].z();
      ++n;
    }
    res.points = n;
    res.rms = n > 0 ? std::sqrt(sq / n) : 0;
    res.max_rms = n > 0 ? 1.5 * o.depth_sigma_k * z2 / n + 0.001 : 0;
    if (n < o.min_points) {
      res.reason = "only " + std::to_string(n) + " points lie near the cell's known surfaces (expected " +
                   std::to_string(o.min_points) + "): the camera is too far from its extrinsics, or the cell is not the one described";
      return res;
    }
    Eigen::Matrix<double, 6, 1> step = -H.ldlt().solve(g);
    if (!step.allFinite()) {
      res.reason = "the registration's normal equations are singular";
      return res;
    }
    // How far the step moves what the camera sees in the region that matters (the bin's
    // corners, or the points' centroid): rotations about the camera's centre and translations
    // partly cancel there.
    const Vec3 omega_full = step.head<3>(), t_full = step.tail<3>();
    double moved = 0;
    for (const Vec3& r : region) moved = std::max(moved, (omega_full.cross(r - c) + t_full).norm());
    // Matches that flip between two surfaces as the estimate moves make the steps cycle: a step
    // turning back on the last one halves the steps taken at this gate from then on.
    if (step.dot(last_step) < 0) scale *= 0.5;
    last_step = step;
    step *= scale;
    const Vec3 omega = step.head<3>(), t = step.tail<3>();
    const double angle = omega.norm();
    const Mat3 dR = angle > 0 ? Mat3(Eigen::AngleAxisd(angle, omega / angle)) : Mat3::Identity();
    Pose next = Pose::Identity();
    next.linear() = dR * T.linear();
    next.translation() = c + t;
    T = next;
    ++at_gate;
    // At each gate until the full step moves the region by less than the tolerance (or, matches
    // cycling, for at most 15 iterations), then a gate half as wide: points the fit has brought
    // near their surfaces stay matched; those it has not, a wrong match, drop out.
    const bool settled = moved < o.tolerance;
    if (settled || at_gate >= 15) {
      if (gate <= o.last_gate) {
        converged = settled || moved < 10 * o.tolerance;
        break;
      }
      gate = std::max(o.last_gate, 0.5 * gate);
      scale = 1, last_step.setZero(), at_gate = 0;
    }
  }
  res.iterations = converged ? it + 1 : it;
  res.T_world_camera = T;
  res.rotation = Eigen::AngleAxisd(T.linear() * cam.T_world_camera.linear().transpose()).angle();
  res.translation = (T.translation() - cam.T_world_camera.translation()).norm();
  const Pose move = T * cam.T_world_camera.inverse();
  for (const Vec3& r : region) res.bin_shift = std::max(res.bin_shift, (move * r - r).norm());
  // Every direction of the camera's motion must be pinned down by some surface: the smallest
  // eigenvalue of the normal equations against the largest (rotations weighted by their lever, ~1 m).
  const Eigen::Matrix<double, 6, 1> eig = Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>>(H / res.points).eigenvalues();
  const double weakest = eig(0) / std::max(eig(5), 1e-300);
  char buf[200];
  if (weakest < 1e-5) {
    std::snprintf(buf, sizeof buf, "the cell's surfaces in view leave the camera's pose unconstrained (weakest direction %.1e of the strongest)",
                  weakest);
    res.reason = buf;
  } else if (res.rms > res.max_rms) {
    std::snprintf(buf, sizeof buf, "the cell's surfaces fit the image only to %.1f mm (expected at most %.1f mm at this noise)",
                  1e3 * res.rms, 1e3 * res.max_rms);
    res.reason = buf;
  } else if (!converged) {
    res.reason = "the registration did not converge in " + std::to_string(it) + " iterations";
  } else {
    res.ok = true;
  }
  return res;
}

}  // namespace mm
