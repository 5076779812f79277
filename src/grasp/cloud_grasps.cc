#include "grasp/cloud_grasps.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <memory>
#include <tuple>
#include <utility>
#include <unordered_map>

#include <Eigen/Eigenvalues>

#include "core/obb.h"

namespace mm {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// One integer for a cell of a grid (each index within 2^20 cells of the origin).
int64_t cellKey(const Eigen::Vector3i& c) {
  return (static_cast<int64_t>(c.x() + (1 << 20)) << 42) | (static_cast<int64_t>(c.y() + (1 << 20)) << 21) | (c.z() + (1 << 20));
}

// Points by the cube of side `cell` they fall in: neighbours within a radius in a few lookups.
// The cells over the points' bounding box, each cell's points in the cloud's order.
class Grid {
 public:
  Grid(const std::vector<Vec3>& points, double cell) : cell_(cell) {
    if (points.empty()) return;
    lo_ = hi_ = cellOf(points[0]);
    std::vector<int> of(points.size());
    for (const Vec3& p : points) {
      const Eigen::Vector3i c = cellOf(p);
      lo_ = lo_.cwiseMin(c), hi_ = hi_.cwiseMax(c);
    }
    dims_ = hi_ - lo_ + Eigen::Vector3i::Ones();
    start_.assign(static_cast<size_t>(dims_.x()) * dims_.y() * dims_.z() + 1, 0);
    for (size_t i = 0; i < points.size(); ++i) ++start_[(of[i] = flat(cellOf(points[i]))) + 1];
    for (size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
    index_.resize(points.size());
    std::vector<int> fill(start_.begin(), start_.end() - 1);
    for (size_t i = 0; i < points.size(); ++i) index_[fill[of[i]]++] = static_cast<int>(i);
    // The points' coordinates in the same order, an array each: a cell's are read in a row.
    for (auto* c : {&xs_, &ys_, &zs_}) c->resize(points.size());
    for (size_t k = 0; k < index_.size(); ++k) {
      const Vec3& q = points[static_cast<size_t>(index_[k])];
      xs_[k] = q.x(), ys_[k] = q.y(), zs_[k] = q.z();
    }
  }
  /// Indices of the points within `r` of `p`, cell by cell (x, then y, then z), each cell's in
  /// the cloud's order (the same for the same cloud).
  void near(const Vec3& p, double r, std::vector<int>& out) const {
    out.clear();
    if (index_.empty()) return;
    const Eigen::Vector3i a = cellOf(p - Vec3::Constant(r)).cwiseMax(lo_), b = cellOf(p + Vec3::Constant(r)).cwiseMin(hi_);
    for (int x = a.x(); x <= b.x(); ++x)
      for (int y = a.y(); y <= b.y(); ++y)
        for (int z = a.z(); z <= b.z(); ++z) {
          const int c = flat({x, y, z});
          for (int k = start_[c]; k < start_[c + 1]; ++k) {
            const double dx = xs_[k] - p.x(), dy = ys_[k] - p.y(), dz = zs_[k] - p.z();
            if (dx * dx + dy * dy + dz * dz <= r * r) out.push_back(index_[k]);
          }
        }
  }

 private:
  Eigen::Vector3i cellOf(const Vec3& p) const { return (p / cell_).array().floor().cast<int>(); }
  int flat(const Eigen::Vector3i& c) const { return ((c.x() - lo_.x()) * dims_.y() + (c.y() - lo_.y())) * dims_.z() + (c.z() - lo_.z()); }
  double cell_;
  Eigen::Vector3i lo_, hi_, dims_;
  std::vector<int> start_, index_;  // each cell's first place in index_; the points by cell
  std::vector<double> xs_, ys_, zs_;  // their coordinates, in index_'s order
};

// The points at [first, last) of a list of a cloud's indices, all within `radius` of `centre`.
struct Block {
  Vec3 centre;
  double radius;
  size_t first, last;
  Vec3 half;  // the half sizes of the points' bounding box about `centre`
};

// Points by the cube of side `size` they fall in (a hand skips the cubes its boxes miss): `ids`
// (of P's points) sorted by cube, each cube's in their order before, and the cubes as blocks over
// that order.
std::vector<Block> blocksOf(const std::vector<Vec3>& P, std::vector<int>& ids, double size) {
  std::vector<std::pair<int64_t, int>> keyed;
  keyed.reserve(ids.size());
  for (size_t k = 0; k < ids.size(); ++k) keyed.push_back({cellKey((P[ids[k]] / size).array().floor().cast<int>()), static_cast<int>(k)});
  std::sort(keyed.begin(), keyed.end());
  const std::vector<int> before = ids;
  for (size_t k = 0; k < keyed.size(); ++k) ids[k] = before[keyed[k].second];
  std::vector<Block> blocks;
  for (size_t k = 0; k < keyed.size();) {
    size_t e = k;
    Vec3 lo = P[ids[k]], hi = lo;
    for (; e < keyed.size() && keyed[e].first == keyed[k].first; ++e) lo = lo.cwiseMin(P[ids[e]]), hi = hi.cwiseMax(P[ids[e]]);
    Block b{(lo + hi) / 2, 0.0, k, e, (hi - lo) / 2};
    for (size_t j = k; j < e; ++j) b.radius = std::max(b.radius, (P[ids[j]] - b.centre).norm());
    blocks.push_back(b);
    k = e;
  }
  return blocks;
}

// The blocks within reach of a seed (centres about it), and in a hand's frame each one's centre
// and its reach along each axis (its bounding box's, or its ball's if less), all at once in loops
// over arrays: which of them a box of the hand's frame can meet.
class NearBlocks {
 public:
  void select(const std::vector<Block>& all, const Vec3& seed, double reach) {
    list_.clear();
    for (const Block& b : all)
      if ((b.centre - seed).norm() <= reach + b.radius + 1e-9) list_.push_back({b.centre - seed, b.radius, b.first, b.last, b.half});
    for (auto* v : {&c_[0], &c_[1], &c_[2], &h_[0], &h_[1], &h_[2], &r_, &m_[0], &m_[1], &m_[2], &s_[0], &s_[1], &s_[2]}) v->resize(list_.size());
    for (size_t i = 0; i < list_.size(); ++i) {
      for (int a = 0; a < 3; ++a) c_[a][i] = list_[i].centre[a], h_[a][i] = list_[i].half[a];
      r_[i] = list_[i].radius;
    }
  }
  /// The blocks in the frame of the hand whose axes are R's columns.
  void project(const Mat3& R) {
    for (int a = 0; a < 3; ++a) {
      const double e0 = R(0, a), e1 = R(1, a), e2 = R(2, a), f0 = std::abs(e0), f1 = std::abs(e1), f2 = std::abs(e2);
      const double *cx = c_[0].data(), *cy = c_[1].data(), *cz = c_[2].data(), *hx = h_[0].data(), *hy = h_[1].data(), *hz = h_[2].data();
      double* __restrict m = m_[a].data();
      double* __restrict s = s_[a].data();
      for (size_t i = 0; i < list_.size(); ++i) {
        m[i] = e0 * cx[i] + e1 * cy[i] + e2 * cz[i];
        s[i] = std::min(r_[i], f0 * hx[i] + f1 * hy[i] + f2 * hz[i]) + 1e-9;
      }
    }
  }
  /// Whether block i can meet the box [-hx, hx] x [-hy, hy] x [zlo, zhi] of the hand's frame.
  bool meets(size_t i, double hx, double hy, double zlo, double zhi) const { return meetsBox(i, hx, -hy, hy, zlo, zhi); }
  /// Whether block i can meet the box [-hx, hx] x [ylo, yhi] x [zlo, zhi] of the hand's frame.
  bool meetsBox(size_t i, double hx, double ylo, double yhi, double zlo, double zhi) const {
    return std::abs(m_[0][i]) <= hx + s_[0][i] && m_[1][i] >= ylo - s_[1][i] && m_[1][i] <= yhi + s_[1][i] && m_[2][i] >= zlo - s_[2][i] &&
           m_[2][i] <= zhi + s_[2][i];
  }
  size_t size() const { return list_.size(); }
  const Block& operator[](size_t i) const { return list_[i]; }

 private:
  std::vector<Block> list_;
  std::vector<double> c_[3], h_[3], r_, m_[3], s_[3];
};

enum CellPart : char { kNotCell = 0, kFloor = 1, kWall = 2 };

// A point in the hand's frame: x across the pads, y the closing direction, z the approach.
struct Local {
  Vec3 p;
  char part;  // CellPart
};

// A part a line across the pads is tested against: a mesh object's convex piece (an object of
// that one piece), else a whole object; and a ball about it that holds all of it.
struct Part {
  ObjectState object;
  Vec3 centre;
  double radius;
};

// Each object as its parts (partsOf).
std::vector<std::vector<Part>> partsOf(const std::vector<ObjectState>& objects) {
  std::vector<std::vector<Part>> out;
  out.reserve(objects.size());
  for (const ObjectState& ob : objects) {
    std::vector<Part> parts;
    if (ob.shape == ObjectShape::kMesh && ob.pieces)
      for (const ConvexPiece& piece : *ob.pieces) {
        // The piece is the hull of its vertices (its planes are the hull's faces).
        Vec3 mid = Vec3::Zero();
        for (const Vec3& v : piece.vertices) mid += v;
        mid /= static_cast<double>(std::max<size_t>(1, piece.vertices.size()));
        double radius = 0;
        for (const Vec3& v : piece.vertices) radius = std::max(radius, (v - mid).norm());
        Part part{ob, ob.T_world_object * mid, radius};
        part.object.pieces = std::make_shared<const std::vector<ConvexPiece>>(std::vector<ConvexPiece>{piece});
        parts.push_back(std::move(part));
      }
    else  // a box, or a cylinder inside the box of its half sizes
      parts.push_back({ob, ob.T_world_object.translation(), ob.half_size.norm()});
    out.push_back(std::move(parts));
  }
  return out;
}

// objectBetweenPads over the objects' parts (partsOf). The lines across the pads, where they count
// (within `open` of the axis), lie in one box of the hand's frame: a part whose ball misses it is
// met by none of them and is not tested.
int objectBetweenPadsOf(const GraspCandidate& g, const std::vector<std::vector<Part>>& objects, const CloudGraspOptions& o) {
  const Mat3& R = g.T_world_tcp.linear();
  const Vec3 tcp = g.T_world_tcp.translation();
  const double open = g.width / 2 + o.finger_margin;
  const double z_lo = o.pad_z_min + 0.002, z_hi = o.pad_z_max - 0.002;
  const Vec3 probe_centre(0, 0, (z_lo + z_hi) / 2), probe_half(0.8 * o.pad_half_width, open, std::max(0.0, (z_hi - z_lo) / 2));
  std::vector<const ObjectState*> near;
  int found = -1;
  for (size_t k = 0; k < objects.size(); ++k) {
    near.clear();
    for (const Part& part : objects[k]) {
      const Vec3 q = R.transpose() * (part.centre - tcp) - probe_centre;
      const Vec3 outside = (q.cwiseAbs() - probe_half).cwiseMax(0.0);
      if (outside.norm() <= part.radius + 1e-6) near.push_back(&part.object);
    }
    if (near.empty()) continue;
    bool between = false;
    for (double fz = o.pad_z_min + 0.002; fz <= o.pad_z_max - 0.002 && !between; fz += 0.004)
      for (double fx : {-0.8 * o.pad_half_width, 0.0, 0.8 * o.pad_half_width}) {
        const Vec3 p = g.T_world_tcp * Vec3(fx, 0, fz);
        for (const ObjectState* part : near) {
          double t1, t2;
          Vec3 n1, n2;
          if (lineThroughObject(*part, p, R.col(1), t1, t2, n1, n2) && t2 > -open && t1 < open) between = true;
        }
      }
    if (!between) continue;
    if (found >= 0) return -2;
    found = static_cast<int>(k);
  }
  return found;
}

// The points of cloudFromDepth, without their normals.
std::vector<Vec3> voxelPoints(const Frame& frame, const CloudGraspOptions& o) {
  const CameraModel& cam = frame.camera;
  const Pose T_region_world = o.T_world_region.inverse();
  const double hx = o.region_half.x() + o.region_margin, hy = o.region_half.y() + o.region_margin;
  if (cam.width <= 0 || cam.height <= 0) return {};
  // One point per voxel: the mean of its pixels' points, in the order of the first pixel.
  std::unordered_map<int64_t, int> voxel_of;
  std::vector<Vec3> sum;
  std::vector<int> count;
  // Only the pixels whose rays can meet the region.
  const PixelRect rect = boxPixels(cam, o.T_world_region, Vec3(-hx, -hy, -0.01), Vec3(hx, hy, o.region_height));
  for (int v = rect.v0; v <= rect.v1; ++v)
    for (int u = rect.u0; u <= rect.u1; ++u) {
      const float z = frame.depth[static_cast<size_t>(v) * cam.width + u];
      if (!(z > 0) || !std::isfinite(z)) continue;
      const Vec3 p = cam.unproject(u, v, z), q = T_region_world * p;
      if (std::abs(q.x()) > hx || std::abs(q.y()) > hy || q.z() < -0.01 || q.z() > o.region_height) continue;
      const int64_t k = cellKey((p / o.voxel).array().floor().cast<int>());
      const auto [it, fresh] = voxel_of.emplace(k, static_cast<int>(sum.size()));
      if (fresh) sum.push_back(Vec3::Zero()), count.push_back(0);
      sum[it->second] += p;
      ++count[it->second];
    }
  std::vector<Vec3> points;
  points.reserve(sum.size());
  for (size_t i = 0; i < sum.size(); ++i) points.push_back(sum[i] / count[i]);
  return points;
}

// Each point's normal, fitted the first time it is read (a view's detector reads few of the
// floor's): the least principal axis of its neighbours within `radius`, turned towards `eye`
// (towards `eye` itself for a point with fewer than 3 neighbours). The same fit whenever read.
class Normals {
 public:
  Normals(const std::vector<Vec3>& points, double radius, const Vec3& eye)
      : points_(points), grid_(points, radius), radius_(radius), eye_(eye), normals_(points.size()), fitted_(points.size(), 0) {}
  const Vec3& operator[](size_t i) {
    if (!fitted_[i]) normals_[i] = fit(i), fitted_[i] = 1;
    return normals_[i];
  }
  /// The normals fitted so far, zero for the points none was asked of (the object is spent).
  std::vector<Vec3> release() {
    for (size_t i = 0; i < normals_.size(); ++i)
      if (!fitted_[i]) normals_[i].setZero();
    return std::move(normals_);
  }

 private:
  Vec3 fit(size_t i) {
    const Vec3& p = points_[i];
    grid_.near(p, radius_, nb_);
    if (nb_.size() < 3) return (eye_ - p).normalized();
    Vec3 mean = Vec3::Zero();
    for (int j : nb_) mean += points_[j];
    mean /= static_cast<double>(nb_.size());
    Mat3 C = Mat3::Zero();
    for (int j : nb_) C += (points_[j] - mean) * (points_[j] - mean).transpose();
    Vec3 n = Eigen::SelfAdjointEigenSolver<Mat3>(C).eigenvectors().col(0);
    if (n.dot(eye_ - p) < 0) n = -n;
    return n;
  }
  const std::vector<Vec3>& points_;
  const Grid grid_;
  const double radius_;
  const Vec3 eye_;
  std::vector<Vec3> normals_;
  std::vector<char> fitted_;
  std::vector<int> nb_;
};

// The farthest the centre of the run of points between the pads can be from the hand's seed: the
// run holds the seed and is no wider than the stroke less the fingers' margins.
double runCentreReach(const CloudGraspOptions& o) { return std::max(0.0, o.hand_opening / 2 - o.finger_margin); }

}  // namespace

CloudGraspOptions cloudGraspOptionsFor(const GraspOptions& hand) {
  CloudGraspOptions o;
  o.approach_clear = hand.approach_distance;
  o.hand_opening = hand.max_opening;
  o.finger_thickness = hand.finger_thickness;
  o.pad_half_width = hand.pad_half_width;
  o.pad_z_min = hand.pad_z_min;
  o.pad_z_max = hand.pad_z_max;
  o.hand_back = hand.hand_back;
  o.hand_half_thickness = hand.hand_half_thickness;
  o.hand_half_width = hand.hand_half_width;
  return o;
}

PointCloud cloudFromDepth(const Frame& frame, const CloudGraspOptions& o) {
  PointCloud cloud;
  cloud.points = voxelPoints(frame, o);
  Normals normals(cloud.points, o.normal_radius, frame.camera.T_world_camera.translation());
  cloud.normals.reserve(cloud.points.size());
  for (size_t i = 0; i < cloud.points.size(); ++i) cloud.normals.push_back(normals[i]);
  return cloud;
}

CloudGraspResult cloudGrasps(const Frame& frame, const CloudGraspOptions& o, const Vec3& preferred_x, Rng& rng) {
  CloudGraspResult res;
  auto t0 = Clock::now();
  res.cloud.points = voxelPoints(frame, o);
  res.seconds.cloud = since(t0);
  t0 = Clock::now();
  const std::vector<Vec3>& P = res.cloud.points;
  if (P.empty()) return res;
  Normals N(P, o.normal_radius, frame.camera.T_world_camera.translation());
  const Pose T_region_world = o.T_world_region.inverse();
  const Vec3 down = -o.T_world_region.linear().col(2);
  auto height = [&](const Vec3& p_world) { return (T_region_world * p_world).z(); };  // above the floor
  // The cell's own points (the floor, the walls: outside the footprint less a margin) are
  // obstacles, never seeds. The pads never close on a wall; the floor under an object is not
  // between them (the fingers' volume keeps clear of it).
  std::vector<int> seedable, tested;
  std::vector<char> cell(P.size(), 0), on_plane(P.size(), 0);  // on_plane: the floor's, within its noise
  const Pose T_camera_world = frame.camera.T_world_camera.inverse();
  for (size_t i = 0; i < P.size(); ++i) {
    const Vec3 q = T_region_world * P[i];
    // The floor: low, and facing up (an object's side near the floor faces sideways).
    const bool up = q.z() > o.floor_noise && q.z() <= o.floor_margin && (T_region_world.linear() * N[i]).z() > std::cos(o.floor_normal);
    const bool floor = q.z() <= o.floor_noise || up;
    const bool wall = std::abs(q.x()) > o.region_half.x() - o.wall_margin || std::abs(q.y()) > o.region_half.y() - o.wall_margin;
    cell[i] = wall ? kWall : floor ? kFloor : kNotCell;
    // The floor's plane: within floor_noise of it, or facing up within the sensor's noise of it
    // (floor_sigmas of sigma = depth_sigma_k z^2 at the point's depth): the noisy floor the
    // fingertips pass over, not an obstacle on it.
    auto sigmas = [&] {  // floor_sigmas of the sensor's sigma at the point's depth, read only for a point facing up
      const double zc = (T_camera_world * P[i]).z();
      return o.floor_sigmas * o.depth_sigma_k * zc * zc;
    };
    on_plane[i] = floor && (q.z() <= o.floor_noise || (up && q.z() <= sigmas()));
    if (!cell[i]) seedable.push_back(static_cast<int>(i));
    if (!(on_plane[i] && cell[i] == kFloor)) tested.push_back(static_cast<int>(i));
  }
  // The points the hands test, by blocks of 4 cm: sorted by block, each block's points in the
  // cloud's order (a hand's obstacles are read in this order). And those that can lie between the
  // pads (all but the floor's), by blocks of 2 cm: the pads' box is thin.
  const std::vector<Block> all_blocks = blocksOf(P, tested, 0.04);
  std::vector<int> pad_ids;
  for (const int i : tested)
    if (cell[i] != kFloor) pad_ids.push_back(i);
  const std::vector<Block> pad_blocks = blocksOf(P, pad_ids, 0.02);
  std::vector<double> pad_x(pad_ids.size()), pad_y(pad_ids.size()), pad_z(pad_ids.size());
  std::vector<char> pad_cell(pad_ids.size());
  for (size_t k = 0; k < pad_ids.size(); ++k) {
    const int i = pad_ids[k];
    pad_x[k] = P[i].x(), pad_y[k] = P[i].y(), pad_z[k] = P[i].z(), pad_cell[k] = cell[i];
  }
  // The tested points in that order: a coordinate to an array, and what they are of the cell.
  std::vector<double> tx(tested.size()), ty(tested.size()), tz(tested.size());
  std::vector<unsigned char> t_on_plane(tested.size());
  std::vector<char> t_cell(tested.size());
  for (size_t k = 0; k < tested.size(); ++k) {
    const int i = tested[k];
    tx[k] = P[i].x(), ty[k] = P[i].y(), tz[k] = P[i].z();
    t_on_plane[k] = on_plane[i];
    t_cell[k] = cell[i];
  }
  const Grid grid(P, 0.02);
  const double pad = o.padding;
  const CameraModel& cam = frame.camera;
  auto unseen = [&](const Vec3& p_world) {  // behind the observed surface, or where no depth is
    const Vec3 uvz = cam.projectFromCamera(T_camera_world * p_world);  // the camera's inverse taken once
    const int u = static_cast<int>(std::lround(uvz.x())), v = static_cast<int>(std::lround(uvz.y()));
    if (u < 0 || v < 0 || u >= cam.width || v >= cam.height || uvz.z() <= 0) return true;
    const float d = frame.depth[static_cast<size_t>(v) * cam.width + u];
    return !(d > 0) || uvz.z() > d + o.unknown_margin;
  };

  // The fingers' samples along the pads (the check of the unseen space below): every 4 mm at most
  // from the back to the tip, both ends included.
  std::vector<double> pad_zs;
  {
    const int steps = std::max(1, static_cast<int>(std::ceil((o.pad_z_max - o.pad_z_min) / 0.004 - 1e-9)));
    for (int i = 0; i <= steps; ++i) pad_zs.push_back(o.pad_z_min + (o.pad_z_max - o.pad_z_min) * i / steps);
  }

  // Whether the open fingers of `g` (inner faces `open` from its axis), at the grasp or backed up
  // its approach by up to 6 cm, enter a box of `o.boxes` (padded) not of the object between its
  // pads. Each finger's volume over that stretch is one box, tested exactly against each box
  // nearby. Which object is between the pads is asked only when a finger is in some object's box.
  constexpr double kBackUp = 0.06;  // [m]
  const std::vector<std::vector<Part>> object_parts = partsOf(o.objects);  // once a view, not once a hand
  auto fingersInNeighbour = [&](const GraspCandidate& g, double open) {
    const Mat3& Rg = g.T_world_tcp.linear();
    const Vec3 tcp = g.T_world_tcp.translation();
    const double within = open + o.finger_thickness + std::abs(o.pad_z_min) + kBackUp + o.pad_half_width;
    OrientedBox finger[2];
    for (int k = 0; k < 2; ++k) {
      const int side = k == 0 ? -1 : 1;
      finger[k].axes = Rg;
      finger[k].half = Vec3(o.pad_half_width, o.finger_thickness / 2, (o.pad_z_max - o.pad_z_min + kBackUp) / 2);
      finger[k].centre = tcp + Rg * Vec3(0, side * (open + o.finger_thickness / 2), (o.pad_z_max + o.pad_z_min - kBackUp) / 2);
    }
    std::vector<int> owners;  // of the boxes a finger is in
    for (const OwnedBox& b : o.boxes) {
      if ((b.T_world.translation() - tcp).norm() > within + b.half.norm() + pad) continue;
      if (std::find(owners.begin(), owners.end(), b.owner) != owners.end()) continue;
      const OrientedBox box{b.T_world.translation(), b.T_world.linear(), b.half + Vec3::Constant(pad)};
      if (!boxesOverlap(finger[0], box) && !boxesOverlap(finger[1], box)) continue;
      if (b.owner < 0) return true;  // a patch no object explains is never the one held
      owners.push_back(b.owner);
    }
    if (owners.empty()) return false;
    const int target = objectBetweenPadsOf(g, object_parts, o);
    if (target < 0) return false;  // on none or on two: the caller's assignment drops it
    return std::any_of(owners.begin(), owners.end(), [&](int k) { return k != target; });
  };

  // The clearance beside the fingers is measured up to this (a hand's score reads no more).
  constexpr double kClearFar = 0.02;  // [m]
  // In a hand's frame about its seed, the points a test of it reads over all its depths lie in two
  // boxes (conservative bounds, 1e-9 wider for the rounding of the tests' sums): the fingers' slab
  // (the fingers' padded sweep along the approach, the points between and beside the pads) and
  // the hand body's (its padded sweep behind the fingers). Along the closing axis they reach from
  // the farthest the hand's centre can be from the seed (the run between the pads holds the seed
  // and is no wider than the stroke less the fingers' margins: its centre within half that) the
  // hand's padded half width (the body's), or the fingers' padded reach and the clearance's 2 cm
  // (the fingers' slab: a point farther changes no check).
  const double d_first = o.min_bite - o.pad_z_max, d_last = -o.pad_z_min + 1e-9;
  const double half_span = o.hand_opening / 2 + o.finger_thickness;
  const double centre_max = runCentreReach(o);
  const double fingers_y = centre_max + half_span + std::max(o.padding, kClearFar) + 1e-9;
  const double body_y = centre_max + o.hand_half_width + o.padding + 1e-9;
  const double fingers_x = o.pad_half_width + o.padding + 1e-9;
  const double fingers_z_lo = d_first + std::min(o.pad_z_min, -o.hand_back - o.approach_clear) - 1e-9;
  const double fingers_z_hi = d_last + o.pad_z_max + o.padding + 1e-9;
  const double body_x = o.hand_half_thickness + o.padding + 1e-9;
  const double body_z_lo = d_first - o.hand_back - o.hand_length - o.approach_clear - 1e-9;
  const double body_z_hi = d_last - o.hand_back + o.padding + 1e-9;
  // Along the approach, the pads' span over all depths.
  const double pads_z_lo = d_first + o.pad_z_min - 1e-9, pads_z_hi = d_last + o.pad_z_max + 1e-9;
  // The farthest a point of those boxes is from the seed: a block farther than this and its own
  // radius holds none.
  double reach = 0;
  for (const auto& [bx, bz_lo, bz_hi] : {std::tuple{fingers_x, fingers_z_lo, fingers_z_hi}, std::tuple{body_x, body_z_lo, body_z_hi},
                                         std::tuple{o.pad_half_width, pads_z_lo, pads_z_hi}})
    reach = std::max(reach, std::hypot(bx, std::max(fingers_y, body_y), std::max(std::abs(bz_lo), std::abs(bz_hi))));
  std::vector<int> frame_nb;
  // The pads' box over all depths: the farthest its points are from the seed.
  const double pads_reach = std::hypot(o.pad_half_width, half_span, std::max(std::abs(pads_z_lo), std::abs(pads_z_hi)));
  NearBlocks blocks, near_pads;
  // A hand's points between the pads and its obstacles: the first n_pads and n_obstacles. Every
  // point a pass reads is written at the end, which moves on only if the point is kept (no branch).
  std::vector<Local> pads(tested.size()), obstacles(tested.size());
  size_t n_pads = 0, n_obstacles = 0;
  std::vector<double> bx_;  // a block's points' x in a hand's frame
  std::vector<int> within_;  // and which of them are within the box's x
  for (const std::vector<Block>* set : {&all_blocks, &pad_blocks})
    for (const Block& b : *set) {
      const size_t n = b.last - b.first;
      if (n > bx_.size()) bx_.resize(n), within_.resize(n);
    }
  // A depth's points between the pads on each side of the seed (y > 0 and y < 0; one at y = 0 ends
  // no run and is no wall's in it): their y, and whether each is a wall's.
  std::vector<double> ys_pos(tested.size()), ys_neg(tested.size());
  std::vector<char> wall_pos(tested.size()), wall_neg(tested.size());
  std::vector<double> run_(tested.size());  // the run's points not yet passed
  // A hand's blocks: of `blocks`, those meeting its boxes, and where each one's points are among
  // the obstacles once computed; of `near_pads`, those meeting the pads' box over all depths (the
  // first of them not gathered yet).
  std::vector<size_t> hand_blocks, hand_pad_blocks;
  constexpr size_t kNotYet = SIZE_MAX;  // a span's first: the block's points not computed yet
  std::vector<std::pair<size_t, size_t>> span;
  // The hands of `n_seeds` seeds, each kept one added to `found`; the second look of a view that
  // gave none or only weak ones (snap_down, floor_contacts, weak_score): `second_look`.
  std::vector<GraspCandidate> found;  // every hand kept, of both looks
  // A seed drawn again in a look (the draws are with replacement) gives the same hands as the
  // first time: those it kept are in `found` already (the same hand twice is one candidate), and
  // its tallies (the hands evaluated, why each was dropped) are counted again, not evaluated again.
  const std::array<int*, 11> tallies{&res.hands,   &res.tilted, &res.on_cell,       &res.fingers_blocked, &res.hand_blocked, &res.too_wide,
                                     &res.too_low, &res.sparse, &res.not_antipodal, &res.unseen,          &res.neighbour};
  std::unordered_map<int, std::array<int, 11>> drawn;  // a seed drawn in this look: its own tallies
  auto search = [&](bool second_look) {
    const int n_seeds = std::min<int>(o.seeds, static_cast<int>(seedable.size()));
    res.seeds += n_seeds;
    drawn.clear();
    for (int s = 0; s < n_seeds; ++s) {
      const int seed = seedable[rng.below(seedable.size())];
      if (const auto again = drawn.find(seed); again != drawn.end()) {
        for (size_t k = 0; k < tallies.size(); ++k) *tallies[k] += again->second[k];
        ++res.seeds_repeated;
        continue;
      }
      std::array<int, 11>& own = drawn[seed];
      for (size_t k = 0; k < tallies.size(); ++k) own[k] = -*tallies[k];
      const Vec3& ps = P[seed];
      const double seed_height = height(ps);  // above the floor
      grid.near(ps, o.frame_radius, frame_nb);
      Mat3 M = Mat3::Zero();
      for (int j : frame_nb) M += N[j] * N[j].transpose();
      const Eigen::SelfAdjointEigenSolver<Mat3> es(M);
      Vec3 normal = es.eigenvectors().col(2), axis = es.eigenvectors().col(0);
      if (normal.dot(N[seed]) < 0) normal = -normal;
      // A face that is flat (normals all alike) curves about no axis in particular (the eigenvector
      // the solver returns is any in its plane, the same for every seed of a noise-free face): the
      // axis is taken along the face's longest extent around the seed, so that the first hand closes
      // across its narrowest, and three more are tried turned by 45 degrees. The second look turns
      // every seed's so (a curved top by a wall: its axis gives hands across it, onto the wall, or
      // leaning a step of the approach's turn over the wall; turned, one closes along it straight down).
      std::vector<Vec3> axes{axis};
      if (second_look || es.eigenvalues()(1) < 0.02 * es.eigenvalues()(2)) {
        constexpr double kFaceRadius = 0.04, kFaceOffset = 0.003;  // [m] the face's points: this near the seed, this near its plane
        const Vec3 e1 = (axis - axis.dot(normal) * normal).normalized(), e2 = normal.cross(e1);
        grid.near(ps, kFaceRadius, frame_nb);
        Eigen::Matrix2d C = Eigen::Matrix2d::Zero();
        Eigen::Vector2d mean = Eigen::Vector2d::Zero();
        std::vector<Eigen::Vector2d> face;
        for (int j : frame_nb) {
          const Vec3 r = P[j] - ps;
          if (!cell[j] && std::abs(normal.dot(r)) <= kFaceOffset && N[j].dot(normal) >= std::cos(o.cone))
            face.emplace_back(e1.dot(r), e2.dot(r)), mean += face.back();
        }
        if (face.size() >= 10) {
          mean /= static_cast<double>(face.size());
          for (const Eigen::Vector2d& f : face) C += (f - mean) * (f - mean).transpose();
          const Eigen::Vector2d major = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(C).eigenvectors().col(1);
          axes[0] = (major.x() * e1 + major.y() * e2).normalized();
        }
        for (int k = 1; k < 4; ++k) axes.push_back(Eigen::AngleAxisd(M_PI / 4 * k, normal) * axes[0]);
      }
      // The blocks within reach (the whole pile, mostly) of the tested points (all but the floor's
      // within its noise, which no test reads: the floor is checked as its plane), each block's
      // centre about the seed.
      blocks.select(all_blocks, ps, reach);
      near_pads.select(pad_blocks, ps, pads_reach);
      const double sx0 = ps.x(), sy0 = ps.y(), sz0 = ps.z();
      for (const Vec3& ax : axes) {
        const Vec3 binormal = ax.cross(normal).normalized();
        // The approaches: -normal turned about the axis; each hand also rolled about its approach to
        // close along the level direction across it (the hand body's width along the floor, not
        // dipping into it), unless its closing axis is that already.
        std::vector<std::pair<Vec3, Vec3>> hands;  // approach z, closing axis y
        for (int a = 0; a < o.approach_steps; ++a) {
          const double theta = -M_PI / 2 + M_PI * a / o.approach_steps;
          const Mat3 turn = Eigen::AngleAxisd(theta, ax).toRotationMatrix();
          Vec3 z = turn * -normal, y = turn * binormal;
          // The second look: an approach this near straight down is straight down, its closing axis
          // level (the normals' noise tilts a low flat top's hands, and a tilted hand's far finger
          // dips to the floor).
          if (second_look && z.dot(down) >= std::cos(o.snap_down) && (y - y.dot(down) * down).norm() > 1e-3) {
            z = down;
            y = (y - y.dot(down) * down).normalized();
          }
          hands.push_back({z, y});
          // The level direction across the approach (for an approach near straight down, a turn
          // about it: one more heading).
          const Vec3 u = z.cross(down);
          if (std::acos(std::clamp(z.dot(down), -1.0, 1.0)) <= o.max_tilt && u.norm() > 1e-3) {
            const Vec3 level = (u.dot(y) < 0 ? -u : u).normalized();
            if (level.dot(y) < std::cos(o.level_turn)) hands.push_back({z, level});
          }
        }
        for (const auto& [z, y] : hands) {
          ++res.hands;
          if (std::acos(std::clamp(z.dot(down), -1.0, 1.0)) > o.max_tilt) {
            ++res.tilted;
            continue;
          }
          Vec3 x = y.cross(z);
          Mat3 R;
          R << x, y, z;
          // Too low at its first depth whatever the pads close on: the depth loop below would end
          // there (on a wall, too wide or too low), none kept. Counted too low, its points unread.
          if (handTooLowAtFirstDepth(R, seed_height, -down, o)) {
            ++res.too_low;
            continue;
          }
          // The tested points in the hand's frame, by blocks: a block whose bounding box (or ball)
          // misses a box [-hx, hx] x [-hy, hy] x [zlo, zhi] of the hand's frame holds none of its
          // points and is skipped whole.
          near_pads.project(R);
          // A block's points (of the coordinates X, Y, Z) in the hand's frame about the seed, x first:
          // x of every point in one loop over arrays (which the compiler vectorizes), y and z only of
          // those within `across` of the hand's yz-plane, each handed to keep(k, x, y, z) (k: its
          // place in X, Y, Z). A point has the same coordinates whichever pass reads it.
          auto inHand = [&](const Block& b, const std::vector<double>& X, const std::vector<double>& Y, const std::vector<double>& Z, double across,
                            auto&& keep) {
            const double x0 = x.x(), x1 = x.y(), x2 = x.z(), y0 = y.x(), y1 = y.y(), y2 = y.z(), z0 = z.x(), z1 = z.y(), z2 = z.z();
            const double* __restrict px = X.data() + b.first;
            const double* __restrict py = Y.data() + b.first;
            const double* __restrict pz = Z.data() + b.first;
            double* __restrict ox = bx_.data();
            const size_t n = b.last - b.first;
            for (size_t j = 0; j < n; ++j) ox[j] = x0 * (px[j] - sx0) + x1 * (py[j] - sy0) + x2 * (pz[j] - sz0);
            size_t m = 0;
            for (size_t j = 0; j < n; ++j) within_[m] = static_cast<int>(j), m += std::abs(ox[j]) <= across;
            for (size_t t = 0; t < m; ++t) {
              const size_t j = within_[t];
              const double dx = px[j] - sx0, dy = py[j] - sy0, dz = pz[j] - sz0;
              keep(b.first + j, ox[j], y0 * dx + y1 * dy + y2 * dz, z0 * dx + z1 * dy + z2 * dz);
            }
          };
          // The points that may lie between the pads at some depth (the contacts; not the floor's),
          // read first: most hands end on them alone (too wide, on a wall, too low). Gathered block by
          // block as the depths reach them (most hands end at the first): padsAt(d) adds those of the
          // blocks that meet the pads' box at depth d. A depth reads the points between its pads in
          // any order (the run's ends, its walls and the contact faces are extremes and tests over
          // all of them, the same in any order).
          n_pads = 0;
          hand_pad_blocks.clear();
          for (size_t i = 0; i < near_pads.size(); ++i)
            if (near_pads.meets(i, o.pad_half_width, half_span, pads_z_lo, pads_z_hi)) hand_pad_blocks.push_back(i);
          size_t pads_left = hand_pad_blocks.size();  // not gathered yet: the first pads_left of hand_pad_blocks
          auto padsAt = [&](double d) {
            for (size_t t = 0; t < pads_left;) {
              const size_t i = hand_pad_blocks[t];
              if (!near_pads.meets(i, o.pad_half_width, half_span, d + o.pad_z_min - 1e-9, d + o.pad_z_max + 1e-9)) {
                ++t;
                continue;
              }
              inHand(near_pads[i], pad_x, pad_y, pad_z, o.pad_half_width, [&](size_t k, double px, double py, double pz) {
                pads[n_pads] = {Vec3(px, py, pz), pad_cell[k]};
                n_pads += (std::abs(py) <= half_span) & (pz >= pads_z_lo) & (pz <= pads_z_hi);
              });
              hand_pad_blocks[t] = hand_pad_blocks[--pads_left];
            }
          };
          // The obstacles (but the floor within its noise, checked as the plane) in the boxes the
          // fingers and the body sweep at some depth: the blocks that meet those boxes, in the tested
          // points' order (listed when a depth first reads obstacles: fewer than half the hands do),
          // each block's points in the hand's frame computed when a depth's regions first meet it
          // (obstaclesOf: where they are among the obstacles), kept for the deeper depths.
          n_obstacles = 0;
          bool listed = false;
          auto listBlocks = [&]() {
            blocks.project(R);
            hand_blocks.clear();
            for (size_t i = 0; i < blocks.size(); ++i)
              if (blocks.meets(i, fingers_x, fingers_y, fingers_z_lo, fingers_z_hi) || blocks.meets(i, body_x, body_y, body_z_lo, body_z_hi))
                hand_blocks.push_back(i);
            span.assign(hand_blocks.size(), {kNotYet, 0});
            listed = true;
          };
          auto obstaclesOf = [&](size_t t) {
            if (span[t].first == kNotYet) {
              const size_t first = n_obstacles;
              inHand(blocks[hand_blocks[t]], tx, ty, tz, std::max(fingers_x, body_x), [&](size_t k, double px, double py, double pz) {
                const double across = std::abs(px);
                const double along = std::abs(py);
                const bool fingers = (across <= fingers_x) & (along <= fingers_y) & (pz >= fingers_z_lo) & (pz <= fingers_z_hi);
                const bool body = (across <= body_x) & (along <= body_y) & (pz >= body_z_lo) & (pz <= body_z_hi);
                obstacles[n_obstacles] = {Vec3(px, py, pz), t_cell[k]};
                n_obstacles += (fingers | body) & !t_on_plane[k];
              });
              span[t] = {first, n_obstacles};
            }
            return span[t];
          };
          // Push the hand forward: the TCP at depth d along z from the seed. The deepest hand whose
          // straight approach is clear, with enough points between the pads, is kept.
          bool have = false;
          GraspCandidate best;
          int best_contacts = 0, best_points = 0;
          double best_clear = 0, best_margin = 0;
          enum { kNone, kOnCell, kFingers, kHand, kWide, kLow, kSparse, kAntipodal } why = kNone;
          // The second look: the deepest hand the pads hold with floor_contacts cells (fewer than
          // min_contacts), kept if no hand is and the next depth is below the floor (the object lies
          // too low to fill more).
          bool have_low = false;
          GraspCandidate low;
          int low_contacts = 0, low_points = 0;
          double low_clear = 0, low_margin = 0;
          for (double d = d_first; d <= d_last; d += o.depth_step) {
            padsAt(d);
            // Between the pads: the run of points along y around the seed, split by a gap a finger fits in.
            size_t n_pos = 0, n_neg = 0;
            for (size_t i = 0; i < n_pads; ++i) {  // written at the end of both, kept by one or neither (no branch)
              const Local& l = pads[i];
              const double zz = l.p.z() - d, yy = l.p.y();
              const bool between = (zz >= o.pad_z_min) & (zz <= o.pad_z_max) & (std::abs(yy) <= o.hand_opening / 2 + o.finger_thickness);
              ys_pos[n_pos] = ys_neg[n_neg] = yy;
              wall_pos[n_pos] = wall_neg[n_neg] = l.part == kWall;
              n_pos += between & (yy > 0);
              n_neg += between & (yy < 0);
            }
            // The run ends [lo, hi]: from the seed each way, the farthest point reached in steps
            // shorter than a finger (the farthest within a finger of the end so far, until none).
            // (A point the end has passed is never read again: each look reads those beyond the last.)
            auto runEnd = [&](const std::vector<double>& from, size_t n, double side) {
              const double* ys = from.data();
              double e = 0;
              for (bool moved = true; moved;) {
                double next = e;
                size_t beyond = 0;
                for (size_t i = 0; i < n; ++i) {
                  const double yy = side * ys[i];
                  if (yy > e && yy - e < o.finger_thickness) next = std::max(next, yy);
                  run_[beyond] = ys[i];
                  beyond += yy > e;
                }
                ys = run_.data(), n = beyond;
                moved = next > e, e = next;
              }
              return side * e;
            };
            const double hi = runEnd(ys_pos, n_pos, 1.0), lo = runEnd(ys_neg, n_neg, -1.0);
            // On a wall: a wall's point in the run, but one at the very y of an object's point above
            // the seed (the run is read upwards with an object's point first, downwards with a
            // wall's: the rule as first written, kept so that outcomes stay as measured).
            bool on_cell = false;
            for (size_t i = 0; i < n_neg && !on_cell; ++i) on_cell = wall_neg[i] && ys_neg[i] >= lo;
            for (size_t i = 0; i < n_pos && !on_cell; ++i) {
              if (!wall_pos[i] || ys_pos[i] > hi) continue;
              on_cell = true;
              for (size_t j = 0; j < n_pos && on_cell; ++j) on_cell = wall_pos[j] || ys_pos[j] != ys_pos[i];
            }
            if (on_cell) {  // the pads would close on a wall
              if (!have) why = kOnCell;
              break;
            }
            const double width = hi - lo, c = (lo + hi) / 2, open = width / 2 + o.finger_margin;
            if (2 * open > o.hand_opening) {
              if (!have) why = kWide;
              break;
            }
            // The floor is the bin's known plane, not its noisy points (those within its noise are
            // left out below; the floor's points above them stay obstacles): the fingers' and the
            // hand's corners (padded) this far above it.
            double lowest = INFINITY;
            for (int side = -1; side <= 1; side += 2)
              for (double sx : {-1.0, 1.0})
                for (double zz : {o.pad_z_min, o.pad_z_max + pad})
                  for (double yy : {open, open + o.finger_thickness + pad})
                    lowest = std::min(lowest, height(ps + R * Vec3(sx * (o.pad_half_width + pad), c + side * yy, d + zz)));
            for (double sx : {-1.0, 1.0})
              for (double sy : {-1.0, 1.0})
                lowest = std::min(lowest, height(ps + R * Vec3(sx * (o.hand_half_thickness + pad), c + sy * (o.hand_half_width + pad), d - o.hand_back + pad)));
            if (lowest < o.floor_clearance) {
              if (!have && have_low) {
                have = true;
                best = low;
                best_contacts = low_contacts, best_points = low_points, best_clear = low_clear, best_margin = low_margin;
              }
              if (!have) why = kLow;
              break;  // deeper is lower
            }
            // The fingers and the hand body, swept along the straight approach back from the grasp.
            int blocked = kNone;
            int between = 0;
            double clear = kClearFar;
            // The obstacles in their order, of the blocks that meet one of this depth's regions (a
            // block that meets none holds no point a test below counts; the first point that blocks
            // is the first as if all were read): the fingers' padded sweep on each side of the run,
            // the hand body's, and between and beside the pads out to where a point lowers the
            // clearance (|y - c| - open - finger_thickness < kClearFar). Each region is 1e-9 wider
            // for the rounding of the tests' sums, the last 1e-6 (the rounding of that difference).
            if (!listed) listBlocks();
            constexpr double kSlack = 1e-9;
            const double fy_in = open - kSlack, fy_out = open + o.finger_thickness + pad + kSlack;
            const double f_zlo = d - o.hand_back - o.approach_clear - kSlack, f_zhi = d + o.pad_z_max + pad + kSlack;
            const double h_y = o.hand_half_width + pad + kSlack, h_zlo = d - o.hand_back - o.hand_length - o.approach_clear - kSlack,
                         h_zhi = d - o.hand_back + pad + kSlack;
            const double p_y = open + o.finger_thickness + kClearFar + 1e-6, p_zlo = d + o.pad_z_min - kSlack, p_zhi = d + o.pad_z_max + kSlack;
            for (size_t t = 0; t < hand_blocks.size() && blocked == kNone; ++t) {
              const size_t b = hand_blocks[t];
              if (!blocks.meetsBox(b, o.pad_half_width + pad + kSlack, c + fy_in, c + fy_out, f_zlo, f_zhi) &&
                  !blocks.meetsBox(b, o.pad_half_width + pad + kSlack, c - fy_out, c - fy_in, f_zlo, f_zhi) &&
                  !blocks.meetsBox(b, o.hand_half_thickness + pad + kSlack, c - h_y, c + h_y, h_zlo, h_zhi) &&
                  !blocks.meetsBox(b, o.pad_half_width + kSlack, c - p_y, c + p_y, p_zlo, p_zhi))
                continue;
              const auto [first, last] = obstaclesOf(t);
              for (size_t i = first; i < last; ++i) {
                const Local& l = obstacles[i];
                const double zz = l.p.z() - d, yy = l.p.y() - c, ay = std::abs(yy);
                if (zz <= o.pad_z_max + pad && zz >= -o.hand_back - o.approach_clear && std::abs(l.p.x()) <= o.pad_half_width + pad &&
                    ay >= open && ay <= open + o.finger_thickness + pad) {
                  blocked = kFingers;
                  break;
                }
                if (zz < -o.hand_back + pad && zz >= -o.hand_back - o.hand_length - o.approach_clear &&
                    std::abs(l.p.x()) <= o.hand_half_thickness + pad && ay <= o.hand_half_width + pad) {
                  blocked = kHand;
                  break;
                }
                if (std::abs(l.p.x()) <= o.pad_half_width && zz >= o.pad_z_min && zz <= o.pad_z_max) {
                  if (ay < open) between += l.part != kFloor;
                  else clear = std::min(clear, ay - open - o.finger_thickness);
                }
              }
            }
            if (blocked != kNone) {
              if (!have) why = static_cast<decltype(why)>(blocked);
              break;  // deeper only sweeps further into what blocked it
            }
            if (between < o.min_points) {
              if (!have) why = kSparse;
              continue;
            }
            // Antipodal contacts. The faces the pads meet are mostly unseen from above (a wall's
            // sides), so a contact face is the outermost surface of the points between the pads: per
            // cell of a grid over the pad (x across it, z along it), the outermost y on each side; a
            // plane y = a x + b z + c fitted to those, its normal's angle from the closing axis
            // (within the friction cone: the pads squeeze, they do not push the object out).
            constexpr int kNx = 3, kNz = 6;
            double ext[2][kNx][kNz];
            bool filled[2][kNx][kNz] = {};
            for (size_t i = 0; i < n_pads; ++i) {
              const Local& l = pads[i];
              const double zz = l.p.z() - d;
              if (zz < o.pad_z_min || zz > o.pad_z_max || l.p.y() < lo || l.p.y() > hi) continue;
              const int ix = std::clamp(static_cast<int>((l.p.x() + o.pad_half_width) / (2 * o.pad_half_width) * kNx), 0, kNx - 1);
              const int iz = std::clamp(static_cast<int>((zz - o.pad_z_min) / (o.pad_z_max - o.pad_z_min) * kNz), 0, kNz - 1);
              for (int side = 0; side < 2; ++side) {
                const double yy = side == 0 ? -l.p.y() : l.p.y();  // outward: -y on the left, +y on the right
                if (!filled[side][ix][iz] || yy > ext[side][ix][iz]) ext[side][ix][iz] = yy, filled[side][ix][iz] = true;
              }
            }
            int cells = 0;
            double worst = 0;
            for (int side = 0; side < 2; ++side) {
              Eigen::Matrix3d AtA = Eigen::Matrix3d::Zero();
              Vec3 Atb = Vec3::Zero();
              int n = 0;
              for (int ix = 0; ix < kNx; ++ix)
                for (int iz = 0; iz < kNz; ++iz) {
                  if (!filled[side][ix][iz]) continue;
                  const Vec3 row(-o.pad_half_width + (ix + 0.5) * 2 * o.pad_half_width / kNx,
                                 o.pad_z_min + (iz + 0.5) * (o.pad_z_max - o.pad_z_min) / kNz, 1.0);
                  AtA += row * row.transpose();
                  Atb += row * ext[side][ix][iz];
                  ++n;
                }
              // A slope no cell constrains (one column, one row) is taken as none: a small ridge.
              AtA(0, 0) += 1e-6, AtA(1, 1) += 1e-6;
              const Vec3 abc = AtA.ldlt().solve(Atb);
              worst = std::max(worst, std::atan(std::hypot(abc.x(), abc.y())));
              cells = side == 0 ? n : std::min(cells, n);
            }
            if (second_look && worst <= o.cone && cells < o.min_contacts && cells >= o.floor_contacts) {
              have_low = true;
              low.T_world_tcp = makePose(ps + R * Vec3(0, c, d), R);
              low.width = width;
              low_contacts = cells, low_margin = o.cone - worst, low_points = between, low_clear = clear;
            }
            if (cells < o.min_contacts || worst > o.cone) {
              if (!have) why = kAntipodal;
              continue;
            }
            have = true;
            best.T_world_tcp = makePose(ps + R * Vec3(0, c, d), R);
            best.width = width;
            best_contacts = cells;
            best_margin = o.cone - worst;
            best_points = between;
            best_clear = clear;
          }
          if (!have) {
            if (why == kOnCell) ++res.on_cell;
            else if (why == kFingers) ++res.fingers_blocked;
            else if (why == kHand) ++res.hand_blocked;
            else if (why == kWide) ++res.too_wide;
            else if (why == kLow) ++res.too_low;
            else if (why == kSparse) ++res.sparse;
            else ++res.not_antipodal;
            continue;
          }
          // The fingers' volume at the grasp, out of the space the camera could not see.
          const Mat3& Rg = best.T_world_tcp.linear();
          const Vec3 tcp = best.T_world_tcp.translation();
          const double open = best.width / 2 + o.finger_margin;
          if (!o.boxes.empty() && fingersInNeighbour(best, open)) {
            ++res.neighbour;
            continue;
          }
          int total = 0, hidden = 0;
          for (int side = -1; side <= 1; side += 2)
            for (double fx : {-o.pad_half_width, 0.0, o.pad_half_width})
              for (const double fz : pad_zs)
                for (double fy : {open, open + o.finger_thickness}) {
                  ++total;
                  hidden += unseen(tcp + Rg * Vec3(fx, side * fy, fz));
                }
          if (hidden > o.max_unknown * total) {
            ++res.unseen;
            continue;
          }
          // The TCP's x nearer the preferred direction (the same grasp turned half a turn about z).
          if (Rg.col(0).dot(preferred_x) < 0) best.T_world_tcp.linear() = halfTurnAboutApproach(Rg);
          best.type = GraspType::kCloud;
          best.approach = -Rg.col(2);
          best.yaw = yawOf(best.T_world_tcp.linear());
          best.clearance = best_clear;
          best.closure_margin = best_margin;
          const double tilt = std::acos(std::clamp(Rg.col(2).dot(down), -1.0, 1.0));
          best.score = o.contact_weight * best_contacts / 18.0 + o.closure_weight * best_margin + o.points_weight * std::min(1.0, best_points / 100.0) -
                       o.tilt_weight * tilt + o.clearance_weight * std::max(0.0, best_clear);
          found.push_back(best);
        }
      }
      for (size_t k = 0; k < tallies.size(); ++k) own[k] += *tallies[k];
    }
  };
  // The hands kept so far, ranked into res.candidates: best first; a candidate near a better one
  // (close and hardly turned from it) is the same grasp.
  auto rank = [&]() {
    res.candidates.clear();
    std::stable_sort(found.begin(), found.end(), [](const GraspCandidate& a, const GraspCandidate& b) { return a.score > b.score; });
    for (const GraspCandidate& g : found) {
      bool same = false;
      for (const GraspCandidate& k : res.candidates) {
        const double dist = (g.T_world_tcp.translation() - k.T_world_tcp.translation()).norm();
        const Mat3 D = g.T_world_tcp.linear().transpose() * k.T_world_tcp.linear();
        const double angle = std::acos(std::clamp((D.trace() - 1) / 2, -1.0, 1.0));
        // The same hand turned half a turn about its approach is the same grasp.
        const double flipped = std::acos(std::clamp((D.trace() - 1) / 2 - (D(0, 0) + D(1, 1)) , -1.0, 1.0));
        if (dist < o.nms_distance && std::min(angle, flipped) < o.nms_angle) {
          same = true;
          break;
        }
      }
      if (!same) res.candidates.push_back(g);
      if (static_cast<int>(res.candidates.size()) >= o.max_candidates) break;
    }
  };
  search(false);
  rank();
  // The second look: a view with no candidate, or whose best scores below weak_score.
  if (o.snap_down > 0 && (res.candidates.empty() || res.candidates.front().score < o.weak_score)) {
    search(true);
    rank();
  }
  res.cloud.normals = N.release();
  res.seconds.hands = since(t0);
  return res;
}

bool handTooLowAtFirstDepth(const Mat3& R, double seed_height, const Vec3& up, const CloudGraspOptions& o) {
  const double pad = o.padding, d_first = o.min_bite - o.pad_z_max;
  const Vec3 g = R.transpose() * up;  // a step along each of the hand's axes rises by this
  const double gx = std::abs(g.x()), gy = std::abs(g.y()), gz = g.z();
  // The depth loop's corners (each finger's, padded, at its inner and outer face, back and tip;
  // the hand body's front) at the first depth, about the run's centre c with the fingers `open`
  // from it. The fingers' lowest corner is highest with the run centred on the seed and the pads
  // closed on it (open >= finger_margin + |c|: the run holds the seed); the body's with c as far
  // as the stroke allows towards the side the body rises on.
  const double fingers = -gx * (o.pad_half_width + pad) - gy * (o.finger_margin + o.finger_thickness + pad) + gz * d_first +
                         std::min(gz * o.pad_z_min, gz * (o.pad_z_max + pad));
  const double body = -gx * (o.hand_half_thickness + pad) + gy * runCentreReach(o) - gy * (o.hand_half_width + pad) +
                      gz * (d_first - o.hand_back + pad);
  return seed_height + std::min(fingers, body) < o.floor_clearance - 1e-9;  // 1e-9: the loop's own sums round otherwise
}

int objectBetweenPads(const GraspCandidate& g, const std::vector<ObjectState>& objects, const CloudGraspOptions& o) {
  return objectBetweenPadsOf(g, partsOf(objects), o);
}

}  // namespace mm
