// The only file that includes PCL (its headers cost seconds of compile: 14.5 s for this file on a
// 2-core VM, 7.4 s before the region growing and clustering it is measured against), which
// tests/layering_test.sh checks.
#include "perception/segmentation.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <chrono>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>

#include <Eigen/Eigenvalues>
#include <opencv2/imgproc.hpp>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/common/io.h>
#include <pcl/features/normal_3d.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/conditional_euclidean_clustering.h>
#include <pcl/segmentation/lccp_segmentation.h>
#include <pcl/segmentation/region_growing.h>
#include <pcl/segmentation/supervoxel_clustering.h>

namespace mm {

namespace {

constexpr int kFirstObjectLabel = 2, kObstacleLabel = 255;  // core/camera.h's labels: 2 + k object k, 255 an obstacle

// A point (in the region's frame) segmentation looks at: over the footprint less the walls'
// margin, above the floor's noise, below the tallest object.
bool insideRegion(const Vec3& q, const SegmentationOptions& o) {
  return std::abs(q.x()) <= o.region_half.x() - o.wall_margin && std::abs(q.y()) <= o.region_half.y() - o.wall_margin &&
         q.z() >= o.floor_margin && q.z() <= o.region_height;
}

// How LCCP judges the connection of two neighbouring supervoxels (Stein et al. 2014, section 3:
// the convexity criterion with its concavity tolerance, and the sanity criterion, as PCL 1.13
// computes them): convex, concave, or convex but refused by the sanity criterion (the line between
// the two patches runs nearly along their normals' cross product, where convexity is ill defined).
enum class Connection { kConvex, kConcave, kSanityRefused };

// The angle between two vectors [deg], 0-180.
double angle(const Eigen::Vector3f& x, const Eigen::Vector3f& y) { return static_cast<double>(std::atan2(x.cross(y).norm(), x.dot(y))) * 180 / M_PI; }

Connection judge(const pcl::Supervoxel<pcl::PointXYZ>& a, const pcl::Supervoxel<pcl::PointXYZ>& b, double concavity_tolerance) {
  const Eigen::Vector3f na = a.normal_.getNormalVector3fMap().normalized(), nb = b.normal_.getNormalVector3fMap().normalized();
  const Eigen::Vector3f d = a.centroid_.getVector3fMap() - b.centroid_.getVector3fMap();
  const double normal_angle = angle(na, nb);
  const bool convex = angle(d, na) - angle(d, nb) <= 0 || normal_angle < concavity_tolerance;
  if (!convex) return Connection::kConcave;
  const double intersection = angle(na.cross(nb), d);
  const double singular = std::min(intersection, 180 - intersection);
  const double threshold = 60 / (1 + std::exp(-0.25 * (normal_angle - 25)));
  return singular < threshold ? Connection::kSanityRefused : Connection::kConvex;
}

// Two of LCCP's segments join when the connections between their supervoxels are mostly convex
// ones its sanity criterion refused: at least one, and at least `sanity_join` times the concave
// ones. On the piles, such connections lie inside one object (98% on seed 1's 39 piles): a bar's
// faces meeting at its bend, a cup's wall and rim, seen edge on. The partition (connected
// components of the joins) does not depend on any order. The connections are judged as LCCP
// judges them with its smoothness check and extended convexity off (the defaults): with those on,
// a connection LCCP refused for them alone would count as convex here, and be passed over.
void joinSanityRefused(const std::map<std::uint32_t, pcl::Supervoxel<pcl::PointXYZ>::Ptr>& clusters,
                       const std::multimap<std::uint32_t, std::uint32_t>& adjacency, const SegmentationOptions& o,
                       std::map<std::uint32_t, std::uint32_t>& segment_of) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::array<int, 2>> between;  // segment pair -> refused, concave
  std::set<std::pair<std::uint32_t, std::uint32_t>> connections;  // each once (the map holds both ways)
  for (const auto& [a, b] : adjacency) connections.insert(std::minmax(a, b));
  for (const auto& [a, b] : connections) {
    const auto sa = segment_of.find(a), sb = segment_of.find(b);
    const auto ca = clusters.find(a), cb = clusters.find(b);
    if (sa == segment_of.end() || sb == segment_of.end() || ca == clusters.end() || cb == clusters.end()) continue;
    if (sa->second == sb->second) continue;
    const Connection c = judge(*ca->second, *cb->second, o.concavity_tolerance);
    if (c == Connection::kConvex) continue;  // LCCP would have joined them
    auto& n = between[std::minmax(sa->second, sb->second)];
    ++n[c == Connection::kSanityRefused ? 0 : 1];
  }
  std::map<std::uint32_t, std::uint32_t> parent;
  auto find = [&](std::uint32_t x) {
    for (auto it = parent.find(x); it != parent.end() && it->second != x; it = parent.find(x)) x = it->second;
    return x;
  };
  for (const auto& [pair, n] : between) {
    if (n[0] < 1 || n[0] < o.sanity_join * n[1]) continue;
    const std::uint32_t ra = find(pair.first), rb = find(pair.second);
    if (ra != rb) parent[std::max(ra, rb)] = std::min(ra, rb);
  }
  for (auto& [sv, seg] : segment_of) seg = find(seg);
}

// The spans of points a and b together along the orthonormal axes x and y, measured from `origin`.
Vec2 spansAlong(const std::vector<Vec2>& a, const std::vector<Vec2>& b, const Vec2& origin, const Vec2& x, const Vec2& y) {
  double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
  for (const auto* v : {&a, &b})
    for (const Vec2& p : *v) {
      const double s0 = (p - origin).dot(x), s1 = (p - origin).dot(y);
      lo[0] = std::min(lo[0], s0), hi[0] = std::max(hi[0], s0), lo[1] = std::min(lo[1], s1), hi[1] = std::max(hi[1], s1);
    }
  return Vec2(hi[0] - lo[0], hi[1] - lo[1]);
}

// The principal extents (major, minor) of points seen from above: the points' spread along the
// eigenvectors of their covariance in the region's xy.
std::pair<double, double> extentsFromAbove(const std::vector<Vec2>& a, const std::vector<Vec2>& b) {
  const double n = static_cast<double>(a.size() + b.size());
  Vec2 mean = Vec2::Zero();
  for (const auto* v : {&a, &b})
    for (const Vec2& p : *v) mean += p;
  mean /= n;
  double sxx = 0, sxy = 0, syy = 0;
  for (const auto* v : {&a, &b})
    for (const Vec2& p : *v) {
      const Vec2 d = p - mean;
      sxx += d.x() * d.x(), sxy += d.x() * d.y(), syy += d.y() * d.y();
    }
  const double angle = 0.5 * std::atan2(2 * sxy, sxx - syy);  // the major axis
  const Vec2 major(std::cos(angle), std::sin(angle)), minor(-major.y(), major.x());
  const Vec2 spans = spansAlong(a, b, mean, major, minor);
  return {spans.x(), spans.y()};
}

// An LCCP segment larger than any object can be (its supervoxels' voxels, seen from above, do not
// fit max_object_length by max_object_width) holds two objects or more: LCCP took the valley
// between them, concave by less than its tolerance, for convex. It is cut again at connections
// concave by more than recut_tolerance (LCCP's convexity criterion with that tolerance; a
// connection only its sanity criterion refuses stays joined, as the join of faces seen edge on
// would join it), and pieces of at most min_supervoxels join their largest neighbour within it
// (smallest first, then the first), so that a cut leaves no crumbs. Each segment's decision is its
// own; the segments are visited by label, their supervoxels by label.
void recutOversized(const std::map<std::uint32_t, pcl::Supervoxel<pcl::PointXYZ>::Ptr>& clusters,
                    const std::multimap<std::uint32_t, std::uint32_t>& adjacency, const SegmentationOptions& o,
                    const Pose& T_region_camera, std::map<std::uint32_t, std::uint32_t>& segment_of) {
  std::map<std::uint32_t, std::vector<std::uint32_t>> members;  // segment -> its supervoxels
  std::uint32_t next_label = 0;
  for (const auto& [sv, seg] : segment_of) members[seg].push_back(sv), next_label = std::max(next_label, seg + 1);
  auto fits = [&](const std::vector<std::uint32_t>& svs) {
    std::vector<Vec2> xy;
    for (std::uint32_t sv : svs) {
      const auto c = clusters.find(sv);
      if (c == clusters.end()) continue;
      for (const pcl::PointXYZ& p : *c->second->voxels_) xy.push_back((T_region_camera * Vec3(p.x, p.y, p.z)).head<2>());
    }
    if (xy.size() < 2) return true;
    const auto [length, width] = extentsFromAbove(xy, {});
    return length <= o.max_object_length && width <= o.max_object_width;
  };
  for (const auto& [label, svs] : members) {
    if (svs.size() < 2 || fits(svs)) continue;
    const std::set<std::uint32_t> in(svs.begin(), svs.end());
    std::set<std::pair<std::uint32_t, std::uint32_t>> edges;  // within the segment, each once
    for (const auto& [a, b] : adjacency)
      if (a != b && in.count(a) && in.count(b)) edges.insert(std::minmax(a, b));
    std::map<std::uint32_t, std::uint32_t> parent;
    for (std::uint32_t sv : svs) parent[sv] = sv;
    auto find = [&](std::uint32_t x) {
      while (parent[x] != x) x = parent[x];
      return x;
    };
    auto unite = [&](std::uint32_t a, std::uint32_t b) {
      const std::uint32_t ra = find(a), rb = find(b);
      if (ra != rb) parent[std::max(ra, rb)] = std::min(ra, rb);
    };
    for (const auto& [a, b] : edges) {
      const auto ca = clusters.find(a), cb = clusters.find(b);
      if (ca != clusters.end() && cb != clusters.end() && judge(*ca->second, *cb->second, o.recut_tolerance) != Connection::kConcave) unite(a, b);
    }
    std::map<std::uint32_t, int> size;  // piece (its root) -> supervoxels
    for (std::uint32_t sv : svs) ++size[find(sv)];
    while (size.size() > 1) {
      std::uint32_t small = 0;
      int fewest = o.min_supervoxels + 1;
      for (const auto& [r, n] : size)
        if (n < fewest) small = r, fewest = n;
      if (fewest > o.min_supervoxels) break;
      std::uint32_t big = small;
      for (const auto& [a, b] : edges) {
        const std::uint32_t ra = find(a), rb = find(b);
        if (ra == rb || (ra != small && rb != small)) continue;
        const std::uint32_t other = ra == small ? rb : ra;
        if (big == small || size[other] > size[big] || (size[other] == size[big] && other < big)) big = other;
      }
      if (big == small) break;  // no neighbour (cannot happen within one segment)
      size[big] += size[small];
      size.erase(small);
      parent[small] = big;
    }
    if (size.size() < 2) continue;
    // The piece of the segment's first supervoxel keeps its label; the others get new ones.
    std::map<std::uint32_t, std::uint32_t> label_of;
    for (std::uint32_t sv : svs) {
      const std::uint32_t r = find(sv);
      const auto it = label_of.try_emplace(r, label_of.empty() ? label : next_label).first;
      if (it->second == next_label) ++next_label;
      segment_of[sv] = it->second;
    }
  }
}

// A pixel's four neighbours in the image (du, dv).
constexpr std::array<std::pair<int, int>, 4> kSides{{{1, 0}, {-1, 0}, {0, 1}, {0, -1}}};

// The pixel pairs (4-neighbours) across a border in the image: from one of `pixels` whose side is
// `from` to a neighbour whose side is `to` (side: pixel index -> an int), how many (touch) and how
// many of them within `step` of each other's depth (smooth).
struct BorderPairs {
  int touch = 0, smooth = 0;
};

template <class Side>
BorderPairs pairsAcross(const Frame& frame, const std::vector<int>& pixels, const Side& side, int from, int to, double step) {
  const int w = frame.camera.width, h = frame.camera.height;
  BorderPairs b;
  for (int p : pixels) {
    if (side(p) != from) continue;
    const int u = p % w, v = p / w;
    for (const auto& [du, dv] : kSides) {
      if (u + du < 0 || v + dv < 0 || u + du >= w || v + dv >= h) continue;
      const int q = p + dv * w + du;
      if (side(q) != to) continue;
      ++b.touch;
      b.smooth += std::abs(frame.depth[static_cast<size_t>(p)] - frame.depth[static_cast<size_t>(q)]) <= step;
    }
  }
  return b;
}

// A border smooth in depth (SegmentationOptions::smooth_step): at least `pairs` and at least
// `share` of its pixel pairs smooth.
bool smoothBorder(const BorderPairs& b, double share, int pairs) { return b.smooth >= pairs && b.smooth >= share * b.touch; }

// Points seen from above fit max_length by max_width in some turn: the longer side of the
// smallest such box over 1-degree turns (INFINITY: none fits).
double fitInSomeTurn(const std::vector<Vec2>& a, const std::vector<Vec2>& b, double max_length, double max_width) {
  double best = INFINITY;
  for (int degrees = 0; degrees < 90; ++degrees) {
    const double t = degrees * M_PI / 180;
    const Vec2 x(std::cos(t), std::sin(t)), y(-x.y(), x.x());
    const Vec2 spans = spansAlong(a, b, Vec2::Zero(), x, y);
    const double longer = spans.maxCoeff(), shorter = spans.minCoeff();
    if (longer <= max_length && shorter <= max_width) best = std::min(best, longer);
  }
  return best;
}

// The region's points in the camera's frame (the supervoxels' single-camera transform expects them
// so), each with its pixel; only the pixels through which the region can be seen (rect).
struct RegionCloud {
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  std::vector<int> pixel_of;
  PixelRect rect;
};

RegionCloud regionCloud(const Frame& frame, const SegmentationOptions& o) {
  const CameraModel& cam = frame.camera;
  const Pose T_region_camera = o.T_world_region.inverse() * cam.T_world_camera;
  RegionCloud rc;
  const Vec3 inner(o.region_half.x() - o.wall_margin, o.region_half.y() - o.wall_margin, 0);
  rc.rect = boxPixels(cam, o.T_world_region, Vec3(-inner.x(), -inner.y(), o.floor_margin), Vec3(inner.x(), inner.y(), o.region_height));
  for (int v = rc.rect.v0; v <= rc.rect.v1; ++v)
    for (int u = rc.rect.u0; u <= rc.rect.u1; ++u) {
      const int i = v * cam.width + u;
      const float z = frame.depth[static_cast<size_t>(i)];
      if (!(z > 0)) continue;
      const Vec3 p_cam((u - cam.cx) * z / cam.fx, (v - cam.cy) * z / cam.fy, z);
      if (!insideRegion(T_region_camera * p_cam, o)) continue;
      rc.cloud->push_back(pcl::PointXYZ(static_cast<float>(p_cam.x()), static_cast<float>(p_cam.y()), static_cast<float>(p_cam.z())));
      rc.pixel_of.push_back(i);
    }
  return rc;
}

// PCL's supervoxels of the region's points (voxel, seed, normal importance; no colour), their
// adjacency, and each point's supervoxel (labelled: 0, in none).
struct Supervoxels {
  std::map<std::uint32_t, pcl::Supervoxel<pcl::PointXYZ>::Ptr> clusters;
  std::multimap<std::uint32_t, std::uint32_t> adjacency;
  pcl::PointCloud<pcl::PointXYZL>::Ptr labelled;
};

Supervoxels supervoxelsOf(const RegionCloud& rc, const SegmentationOptions& o) {
  pcl::SupervoxelClustering<pcl::PointXYZ> super(static_cast<float>(o.voxel), static_cast<float>(o.seed));
  super.setUseSingleCameraTransform(true);
  super.setInputCloud(rc.cloud);
  super.setColorImportance(0.0f);
  super.setSpatialImportance(1.0f);
  super.setNormalImportance(static_cast<float>(o.normal_importance));
  Supervoxels sv;
  super.extract(sv.clusters);
  super.getSupervoxelAdjacency(sv.adjacency);
  sv.labelled = super.getLabeledCloud();
  return sv;
}

// The supervoxels by their labels (ascending), each with its pixels (ascending), its points seen
// from above (the region's xy) and its highest point above the floor; the connections between
// neighbouring ones with what the learned merge reads of them (SupervoxelMerge::kLearned).
struct ConnectionGraph {
  std::vector<std::uint32_t> label;
  std::vector<std::vector<int>> pixels;
  std::vector<std::vector<Vec2>> xy;
  std::vector<double> top;
  std::vector<SupervoxelGraph::Connection> connections;
};

// Where two supervoxels meet in the image: the depth steps of the pixel pairs across (4-neighbours,
// right and down), the creases there (the pair's mean depth less that of the pixels 3 out on each
// side, each in its own supervoxel: a valley between two objects is deeper than its sides), and
// the pixels of no depth with both among their 8 neighbours (the line the sensor loses between
// touching solids).
struct Seam {
  std::vector<double> steps, creases;
  int no_depth = 0;
};

ConnectionGraph connectionGraph(const Frame& frame, const RegionCloud& rc, const Supervoxels& sv, const Pose& T_region_camera) {
  ConnectionGraph g;
  std::map<std::uint32_t, int> index;
  for (const auto& [label, cluster] : sv.clusters) index.emplace(label, static_cast<int>(g.label.size())), g.label.push_back(label);
  const size_t n = g.label.size();
  g.pixels.resize(n), g.xy.resize(n), g.top.assign(n, -1e9);
  const int w = frame.camera.width, h = frame.camera.height;
  std::vector<int> sv_at(static_cast<size_t>(w) * static_cast<size_t>(h), -1);
  for (size_t k = 0; k < sv.labelled->size(); ++k) {
    const pcl::PointXYZL& p = (*sv.labelled)[k];
    const auto it = p.label == 0 ? index.end() : index.find(p.label);
    if (it == index.end()) continue;
    const size_t s = static_cast<size_t>(it->second);
    sv_at[static_cast<size_t>(rc.pixel_of[k])] = it->second;
    g.pixels[s].push_back(rc.pixel_of[k]);
    const Vec3 q = T_region_camera * Vec3(p.x, p.y, p.z);
    g.top[s] = std::max(g.top[s], q.z());
    g.xy[s].push_back(q.head<2>());
  }
  std::map<std::pair<int, int>, Seam> seams;
  auto depth = [&](int i) { return static_cast<double>(frame.depth[static_cast<size_t>(i)]); };
  for (int v = std::max(1, rc.rect.v0 - 1); v <= std::min(h - 2, rc.rect.v1 + 1); ++v)
    for (int u = std::max(1, rc.rect.u0 - 1); u <= std::min(w - 2, rc.rect.u1 + 1); ++u) {
      const int i = v * w + u;
      const int a = sv_at[static_cast<size_t>(i)];
      if (a >= 0) {
        for (const auto& [du, dv] : {std::pair{1, 0}, std::pair{0, 1}}) {
          const int step = dv * w + du;
          const int b = sv_at[static_cast<size_t>(i + step)];
          if (b < 0 || b == a) continue;
          Seam& seam = seams[std::minmax(a, b)];
          seam.steps.push_back(std::abs(depth(i) - depth(i + step)));
          const int out_a = i - 3 * step, out_b = i + 4 * step;
          if (out_a >= 0 && out_b < w * h && (du == 0 || (u - 3 >= 0 && u + 4 < w)) && sv_at[static_cast<size_t>(out_a)] == a &&
              sv_at[static_cast<size_t>(out_b)] == b)
            seam.creases.push_back((depth(i) + depth(i + step)) / 2 - (depth(out_a) + depth(out_b)) / 2);
        }
      } else if (!(frame.depth[static_cast<size_t>(i)] > 0)) {
        std::array<int, 8> seen{};
        int kinds = 0;
        for (int dv = -1; dv <= 1; ++dv)
          for (int du = -1; du <= 1; ++du) {
            const int b = sv_at[static_cast<size_t>(i + dv * w + du)];
            if (b < 0 || std::find(seen.begin(), seen.begin() + kinds, b) != seen.begin() + kinds) continue;
            seen[static_cast<size_t>(kinds++)] = b;
          }
        for (int x = 0; x < kinds; ++x)
          for (int y = x + 1; y < kinds; ++y) ++seams[std::minmax(seen[static_cast<size_t>(x)], seen[static_cast<size_t>(y)])].no_depth;
      }
    }
  std::set<std::pair<int, int>> pairs;
  for (const auto& [a, b] : sv.adjacency) {
    const auto ia = index.find(a), ib = index.find(b);
    if (ia != index.end() && ib != index.end() && ia->second != ib->second) pairs.insert(std::minmax(ia->second, ib->second));
  }
  const Mat3 R = T_region_camera.linear();
  const Seam none;
  for (const auto& [a, b] : pairs) {
    const pcl::Supervoxel<pcl::PointXYZ>& A = *sv.clusters.at(g.label[static_cast<size_t>(a)]);
    const pcl::Supervoxel<pcl::PointXYZ>& B = *sv.clusters.at(g.label[static_cast<size_t>(b)]);
    const Eigen::Vector3f na = A.normal_.getNormalVector3fMap().normalized(), nb = B.normal_.getNormalVector3fMap().normalized();
    const Eigen::Vector3f d = A.centroid_.getVector3fMap() - B.centroid_.getVector3fMap();
    const double normal_angle = angle(na, nb);
    const double convexity = angle(d, na) - angle(d, nb);  // LCCP's: convex at or below 0
    const double intersection = angle(na.cross(nb), d);
    const auto it = seams.find({a, b});
    const Seam& seam = it == seams.end() ? none : it->second;
    std::vector<double> steps = seam.steps;
    int within2 = 0, within4 = 0, within8 = 0;
    for (double s : steps) within2 += s <= 0.002, within4 += s <= 0.004, within8 += s <= 0.008;
    double median_step = 0.03;
    if (!steps.empty()) {
      std::nth_element(steps.begin(), steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2), steps.end());
      median_step = std::min(0.03, steps[steps.size() / 2]);
    }
    const double touch = static_cast<double>(steps.size());
    const Vec3 d_region = R * d.cast<double>();
    const double size_a = static_cast<double>(g.pixels[static_cast<size_t>(a)].size()), size_b = static_cast<double>(g.pixels[static_cast<size_t>(b)].size());
    SupervoxelGraph::Connection c;
    c.a = a, c.b = b;
    ConnectionFeatures& f = c.features;
    f[0] = 1;
    f[1] = normal_angle / 90;
    f[2] = convexity / 90;
    f[3] = convexity > 0 ? normal_angle / 90 : 0;
    f[4] = convexity <= 0 ? normal_angle / 90 : 0;
    f[5] = std::min(intersection, 180 - intersection) / 90;  // LCCP's sanity criterion's angle
    const double off_a = std::abs(d.dot(nb)), off_b = std::abs(d.dot(na));  // [m] one centroid off the other's plane
    f[6] = 100 * std::max(off_a, off_b);  // [cm]
    f[7] = 100 * std::min(off_a, off_b);
    f[8] = std::log1p(touch);
    f[9] = steps.empty() ? 0 : within4 / touch;
    f[10] = 100 * median_step;  // [cm]
    f[11] = std::log1p(seam.no_depth);
    f[12] = std::log1p(std::min(size_a, size_b));
    f[13] = std::log1p(std::max(size_a, size_b));
    f[14] = 100 * std::abs(d_region.z());  // [cm]
    f[15] = 100 * d_region.head<2>().norm();
    f[16] = std::min(std::abs((R * na.cast<double>()).z()), std::abs((R * nb.cast<double>()).z()));
    f[17] = 100 * std::abs(g.top[static_cast<size_t>(a)] - g.top[static_cast<size_t>(b)]);
    f[18] = steps.empty() ? 0 : within2 / touch;
    f[19] = steps.empty() ? 0 : within8 / touch;
    f[20] = steps.empty() ? 1 : 0;
    f[21] = seam.no_depth / (1 + touch);
    if (seam.creases.size() >= 3) {
      std::vector<double> creases = seam.creases;
      std::sort(creases.begin(), creases.end());
      f[22] = std::clamp(1000 * creases[creases.size() / 2], -10.0, 10.0);  // [mm]
      f[23] = std::clamp(1000 * creases[creases.size() * 3 / 4], -10.0, 10.0);
      f[24] = std::log1p(static_cast<double>(creases.size()));
    }
    g.connections.push_back(c);
  }
  return g;
}

// SupervoxelMerge::kLearned: each supervoxel's segment (the index of one of its supervoxels), by
// greedy additive edge contraction on the connections' scores (SegmentationOptions::merge). A
// connection with a measure not finite (a supervoxel PCL gave no normal; one of the 66,814 of the
// training piles) scores NaN, and its two segments are never joined, as LCCP judges it concave.
std::vector<int> joinByScore(ConnectionGraph& g, const SegmentationOptions& o) {
  const size_t n = g.label.size();
  std::vector<std::map<int, double>> between(n);  // segment -> its neighbours' summed scores
  for (const SupervoxelGraph::Connection& c : g.connections) {
    double z = o.merge_bias;
    for (int k = 0; k < kConnectionFeatures; ++k) z += kConnectionWeights[static_cast<size_t>(k)] * c.features[static_cast<size_t>(k)];
    between[static_cast<size_t>(c.a)][c.b] += z, between[static_cast<size_t>(c.b)][c.a] += z;
  }
  std::vector<int> into(n);
  for (size_t i = 0; i < n; ++i) into[i] = static_cast<int>(i);
  const bool sized = o.max_object_length > 0 && o.max_object_width > 0;
  constexpr double kNever = -1e9;
  for (;;) {
    double best = 0;
    int a = -1, b = -1;
    for (size_t i = 0; i < n; ++i)
      for (const auto& [j, z] : between[i])
        if (static_cast<int>(i) < j && z > best) best = z, a = static_cast<int>(i), b = j;
    if (a < 0) break;
    const size_t ua = static_cast<size_t>(a), ub = static_cast<size_t>(b);
    if (sized && !std::isfinite(fitInSomeTurn(g.xy[ua], g.xy[ub], o.max_object_length, o.max_object_width))) {
      between[ua][b] = between[ub][a] = kNever;
      continue;
    }
    for (const auto& [j, z] : between[ub]) {
      if (j == a) continue;
      between[ua][j] += z, between[static_cast<size_t>(j)][a] += z;
      between[static_cast<size_t>(j)].erase(b);
    }
    between[ua].erase(b);
    between[ub].clear();
    g.xy[ua].insert(g.xy[ua].end(), g.xy[ub].begin(), g.xy[ub].end());
    g.xy[ub].clear();
    into[ub] = a;
  }
  for (size_t i = 0; i < n; ++i) {
    int r = static_cast<int>(i);
    while (into[static_cast<size_t>(r)] != r) r = into[static_cast<size_t>(r)];
    into[i] = r;
  }
  return into;
}

// Which pairs a join by size takes (SegmentationOptions): any pair (kSize), pairs one of which is
// a crumb (kCrumbs), pairs whose border in the image is smooth (kSmoothBorder).
enum class JoinOf { kSize, kCrumbs, kSmoothBorder };

// Neighbouring segments (`near`, by index) whose points together still fit what an object can
// measure seen from above (o.max_object_length by o.max_object_width) are joined: of the pairs
// that fit, the one whose union is shortest first (then the first pair), until none fits. LCCP
// cuts an object where its surface turns concave (a bar's bend, a stack's ledge, a cup's rim from
// its inside); its pieces together are mostly one object's size, where two touching objects
// together are mostly larger (two small ones that together fit are joined all the same). The
// extents are the points' spread along their principal axis and across it.
// kCrumbs: only pairs of which the smaller is a crumb: fewer pixels than o.crumb_pixels, its own
// principal extents at least o.crumb_aspect to one; the two segments' tops within
// o.crumb_top_step of each other (where that is above 0); and the union fits in some turn
// (fitInSomeTurn), not along its principal axes.
// kSmoothBorder: only pairs whose border in `frame` is smooth: of the pixel pairs where they touch
// (4-neighbours), at least o.smooth_pairs and at least o.smooth_share of them differ in depth by
// at most o.smooth_step; and the union fits in some turn.
void joinWithinObjectSize(std::vector<Segment>& segments, std::vector<std::set<int>>& near, const Pose& T_region_world,
                          const SegmentationOptions& o, JoinOf of, const Frame& frame) {
  const size_t n = segments.size();
  const double max_length = o.max_object_length, max_width = o.max_object_width;
  const bool smooth = of == JoinOf::kSmoothBorder;
  // kSmoothBorder: each pixel's segment (-1: none) over the segments' bounding rectangle (every
  // pixel outside it is none's).
  const int cols = frame.camera.width;
  int u0 = cols, v0 = std::numeric_limits<int>::max(), u1 = -1, v1 = -1;
  std::vector<int> owner;
  if (smooth) {
    for (const Segment& s : segments)
      for (int p : s.pixels) u0 = std::min(u0, p % cols), u1 = std::max(u1, p % cols), v0 = std::min(v0, p / cols), v1 = std::max(v1, p / cols);
    if (u1 >= u0) owner.assign(static_cast<size_t>(u1 - u0 + 1) * static_cast<size_t>(v1 - v0 + 1), -1);
  }
  const auto cellOf = [&](int p) { return static_cast<size_t>((p / cols - v0) * (u1 - u0 + 1) + (p % cols - u0)); };
  const auto inRect = [&](int p) { return p % cols >= u0 && p % cols <= u1 && p / cols >= v0 && p / cols <= v1; };
  for (size_t i = 0; i < n && smooth; ++i)
    for (int p : segments[i].pixels) owner[cellOf(p)] = static_cast<int>(i);
  auto smoothJoin = [&](size_t i, size_t j) {
    const auto owned = [&](int p) { return inRect(p) ? owner[cellOf(p)] : -1; };
    return smoothBorder(pairsAcross(frame, segments[i].pixels, owned, static_cast<int>(i), static_cast<int>(j), o.smooth_step), o.smooth_share,
                        o.smooth_pairs);
  };
  std::vector<std::vector<Vec2>> xy(n);
  for (size_t i = 0; i < n; ++i)
    for (const Vec3& p : segments[i].points) xy[i].push_back((T_region_world * p).head<2>());
  // A crumb: small, and elongated seen from above.
  auto crumb = [&](size_t i) {
    if (static_cast<int>(segments[i].pixels.size()) >= o.crumb_pixels) return false;
    const auto [length, width] = extentsFromAbove(xy[i], {});
    return length >= o.crumb_aspect * width;
  };
  // A pair's union's length where it fits (INFINITY where not), until either changes.
  std::map<std::pair<int, int>, double> fit;
  for (;;) {
    double best = INFINITY;
    int bi = -1, bj = -1;
    for (size_t i = 0; i < n; ++i) {
      if (xy[i].empty()) continue;
      for (int j : near[i]) {
        const size_t uj = static_cast<size_t>(j);
        if (j <= static_cast<int>(i) || xy[uj].empty()) continue;
        auto it = fit.find({static_cast<int>(i), j});
        if (it == fit.end()) {
          double length = INFINITY;
          if (smooth) {
            if (smoothJoin(i, uj)) length = fitInSomeTurn(xy[i], xy[uj], max_length, max_width);
          } else if (of == JoinOf::kSize) {
            const auto [l, w] = extentsFromAbove(xy[i], xy[uj]);
            if (l <= max_length && w <= max_width) length = l;
          } else if (crumb(segments[i].pixels.size() <= segments[uj].pixels.size() ? i : uj) &&
                     (o.crumb_top_step <= 0 || std::abs(segments[i].top - segments[uj].top) <= o.crumb_top_step)) {
            length = fitInSomeTurn(xy[i], xy[uj], max_length, max_width);
          }
          it = fit.emplace(std::pair{static_cast<int>(i), j}, length).first;
        }
        if (it->second < best) best = it->second, bi = static_cast<int>(i), bj = j;
      }
    }
    if (bi < 0) return;
    const size_t a = static_cast<size_t>(bi), b = static_cast<size_t>(bj);
    // b into a: the pixels kept ascending, each with its point.
    if (smooth)
      for (int p : segments[b].pixels) owner[cellOf(p)] = bi;
    std::vector<std::pair<int, Vec3>> merged;
    for (size_t s : {a, b})
      for (size_t k = 0; k < segments[s].pixels.size(); ++k) merged.emplace_back(segments[s].pixels[k], segments[s].points[k]);
    std::sort(merged.begin(), merged.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
    Segment joined;
    joined.top = std::max(segments[a].top, segments[b].top);
    for (const auto& [pixel, point] : merged) joined.pixels.push_back(pixel), joined.points.push_back(point);
    segments[a] = std::move(joined);
    segments[b] = Segment{};
    xy[a].insert(xy[a].end(), xy[b].begin(), xy[b].end());
    xy[b].clear();
    for (auto it = fit.begin(); it != fit.end();)
      it = it->first.first == bi || it->first.second == bi || it->first.first == bj || it->first.second == bj ? fit.erase(it) : std::next(it);
    for (int k : near[b]) {
      near[static_cast<size_t>(k)].erase(bj);
      if (k != bi) near[static_cast<size_t>(k)].insert(bi), near[a].insert(k);
    }
    near[a].erase(bj);
    near[b].clear();
  }
}

// A segment whose own pixels fall apart in the image (4-connected) is cut into its pieces. The
// camera measured no depth between them: where two objects touch, the sensor loses the pixels
// along the edge between them, and the 4 mm voxels of the supervoxels reach across such a line.
// One object's pieces parted so (a ring's arcs, a bent bar's faces seen edge on) are put back by
// the join by size, which runs after. Pieces of at least min_pixels are segments, in the order of
// their first pixel; smaller ones stay with the largest (then the first). Each piece has its
// segment's neighbours (through the supervoxels); pieces of one segment are neighbours where their
// masks touch, as any two segments.
void splitUnconnected(int width, std::vector<Segment>& segments, std::vector<std::set<int>>& near, int min_pixels,
                      const Pose& T_region_world) {
  std::vector<Segment> pieces;
  std::vector<std::vector<int>> pieces_of(segments.size());
  for (size_t s = 0; s < segments.size(); ++s) {
    const Segment& seg = segments[s];
    const std::vector<int>& px = seg.pixels;  // ascending
    const size_t m = px.size();
    // Union-find over the segment's pixels: each joined to its left and upper neighbours in it.
    std::vector<int> parent(m);
    for (size_t k = 0; k < m; ++k) parent[k] = static_cast<int>(k);
    auto find = [&](int x) {
      while (parent[static_cast<size_t>(x)] != x) x = parent[static_cast<size_t>(x)] = parent[static_cast<size_t>(parent[static_cast<size_t>(x)])];
      return x;
    };
    auto unite = [&](int a, int b) {
      a = find(a), b = find(b);
      if (a != b) parent[static_cast<size_t>(std::max(a, b))] = std::min(a, b);
    };
    for (size_t k = 0; k < m; ++k) {
      const int p = px[k];
      if (k > 0 && px[k - 1] == p - 1 && p % width != 0) unite(static_cast<int>(k - 1), static_cast<int>(k));
      const auto up = std::lower_bound(px.begin(), px.begin() + static_cast<std::ptrdiff_t>(k), p - width);
      if (up != px.begin() + static_cast<std::ptrdiff_t>(k) && *up == p - width) unite(static_cast<int>(up - px.begin()), static_cast<int>(k));
    }
    // The pieces by their first pixel (a root is its piece's first pixel), their sizes.
    std::map<int, int> size;  // root -> pixels
    for (size_t k = 0; k < m; ++k) ++size[find(static_cast<int>(k))];
    int largest = size.empty() ? 0 : size.begin()->first;
    for (const auto& [r, n] : size)
      if (n > size[largest]) largest = r;
    std::map<int, int> piece_of;  // root -> index in pieces
    for (const auto& [r, n] : size) {
      if (r != largest && n < min_pixels) continue;
      piece_of[r] = static_cast<int>(pieces.size());
      pieces_of[s].push_back(static_cast<int>(pieces.size()));
      pieces.emplace_back();
    }
    for (size_t k = 0; k < m; ++k) {
      const auto it = piece_of.find(find(static_cast<int>(k)));
      Segment& to = pieces[static_cast<size_t>(it == piece_of.end() ? piece_of.at(largest) : it->second)];
      to.pixels.push_back(px[k]);
      to.points.push_back(seg.points[k]);
      to.top = std::max(to.top, (T_region_world * seg.points[k]).z());
    }
  }
  std::vector<std::set<int>> near_pieces(pieces.size());
  for (size_t s = 0; s < segments.size(); ++s)
    for (int t : near[s])
      for (int a : pieces_of[s])
        for (int b : pieces_of[static_cast<size_t>(t)]) near_pieces[static_cast<size_t>(a)].insert(b);
  segments = std::move(pieces);
  near = std::move(near_pieces);
}

// A segment's points' mean distance along the camera's axis (T_camera_world: the world in the
// camera's frame).
double meanDepth(const Segment& seg, const Pose& T_camera_world) {
  double z = 0;
  for (const Vec3& p : seg.points) z += (T_camera_world * p).z();
  return z / static_cast<double>(seg.points.size());
}

// A segment that holds two objects side by side (LCCP took the valley between them for convex, or
// the join by size put them together) often shows it in its outline: seen from above, each solid
// is convex, and where they touch the outline narrows to a waist between two concavities. Each
// segment of at least twice min_pixels whose instance mask fills at least waist_fill of the pixels
// its outer contour encloses (a speckled mask's ragged outline has notches as deep as a waist):
// that contour, its convex hull's defects at least `depth_px` deep (OpenCV), and of every pair of
// their deepest points the line between them that parts the segment's pixels into two of at least
// min_pixels each, the one shortest against the square root of its smaller part (the waist of two
// blobs, not a cut across one); kept under `ratio`. With waist_smooth, that cut is not made where
// the pixel pairs across it are smooth in depth as the smooth join reads a border (smooth_step,
// smooth_share, smooth_pairs): one surface narrowing, a bent bar at its bend, not two objects side
// by side. The segment is cut along that line: its pixels (each with its point) by their side of
// it; the second part is added after the others, not cut again.
// OpenCV's contour and hull functions run on this thread.
void splitAtWaists(const Frame& frame, std::vector<Segment>& segments, const SegmentationOptions& o, const Pose& T_region_world) {
  const CameraModel& cam = frame.camera;
  const int w = cam.width;
  const size_t n = segments.size();
  const Pose T_camera_world = cam.T_world_camera.inverse();
  for (size_t s = 0; s < n; ++s) {
    Segment& seg = segments[s];
    if (static_cast<int>(seg.pixels.size()) < 2 * o.min_pixels) continue;
    // The concavity's depth in pixels at the segment's mean distance along the camera's axis.
    const double z = meanDepth(seg, T_camera_world);
    if (!(z > 0)) continue;
    const double depth_px = o.waist_depth * cam.fx / z;
    const std::vector<int> mask = segmentMasks(frame, {seg}).front();
    int u0 = w, v0 = cam.height, u1 = -1, v1 = -1;
    for (int p : mask) u0 = std::min(u0, p % w), u1 = std::max(u1, p % w), v0 = std::min(v0, p / w), v1 = std::max(v1, p / w);
    cv::Mat image = cv::Mat::zeros(v1 - v0 + 3, u1 - u0 + 3, CV_8U);  // a pixel of margin all round
    for (int p : mask) image.at<unsigned char>(p / w - v0 + 1, p % w - u0 + 1) = 255;
    std::vector<std::vector<cv::Point>> contours;
    cv::findContours(image, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
    if (contours.empty()) continue;
    size_t outer = 0;  // the longest (then the first)
    for (size_t k = 1; k < contours.size(); ++k)
      if (contours[k].size() > contours[outer].size()) outer = k;
    const std::vector<cv::Point>& contour = contours[outer];
    if (contour.size() < 8) continue;
    std::vector<int> hull;
    cv::convexHull(contour, hull, false, false);
    if (hull.size() < 4) continue;
    std::sort(hull.begin(), hull.end());  // convexityDefects wants the hull's indices monotonic
    std::vector<cv::Vec4i> defects;
    try {
      cv::convexityDefects(contour, hull, defects);
    } catch (const cv::Exception&) {  // a self-intersecting contour (a one-pixel neck): no cut
      continue;
    }
    std::vector<cv::Point> deepest;
    for (const cv::Vec4i& d : defects)
      if (d[3] / 256.0 >= depth_px) deepest.push_back(contour[static_cast<size_t>(d[2])]);
    if (deepest.size() < 2) continue;
    if (o.waist_fill > 0) {  // the mask's share of the pixels its outline encloses
      cv::Mat inside = cv::Mat::zeros(image.size(), CV_8U);
      cv::drawContours(inside, contours, static_cast<int>(outer), cv::Scalar(255), cv::FILLED);
      const int enclosed = cv::countNonZero(inside);
      if (cv::countNonZero(image & inside) < o.waist_fill * enclosed) continue;
    }
    // Which side of the line a -> b a pixel is on (in the image's frame of the contour).
    auto side = [&](int p, const cv::Point& a, const cv::Point& b) {
      const long x = p % w - u0 + 1 - a.x, y = p / w - v0 + 1 - a.y;
      return static_cast<long>(b.x - a.x) * y - static_cast<long>(b.y - a.y) * x > 0;
    };
    double best = o.waist_ratio;
    int bi = -1, bj = -1;
    for (size_t i = 0; i < deepest.size(); ++i)
      for (size_t j = i + 1; j < deepest.size(); ++j) {
        const double length = std::hypot(deepest[j].x - deepest[i].x, deepest[j].y - deepest[i].y);
        if (length < 1) continue;
        int left = 0;
        for (int p : seg.pixels) left += side(p, deepest[i], deepest[j]);
        const int smaller = std::min(left, static_cast<int>(seg.pixels.size()) - left);
        if (smaller < o.min_pixels) continue;
        const double ratio = length / std::sqrt(static_cast<double>(smaller));
        if (ratio < best) best = ratio, bi = static_cast<int>(i), bj = static_cast<int>(j);
      }
    if (bi < 0) continue;
    const cv::Point& a = deepest[static_cast<size_t>(bi)];
    const cv::Point& b = deepest[static_cast<size_t>(bj)];
    if (o.waist_smooth && o.smooth_step > 0) {
      // Each pixel's side (1, 2; 0: not the segment's) over the mask's rectangle with its margin
      // (every neighbour in the image of a pixel of the rectangle is in it).
      const int rw = image.cols;
      std::vector<unsigned char> part(static_cast<size_t>(rw * image.rows), 0);
      auto cell = [&](int p) { return static_cast<size_t>((p / w - v0 + 1) * rw + (p % w - u0 + 1)); };
      for (int p : seg.pixels) part[cell(p)] = side(p, a, b) ? 1 : 2;
      const auto partOf = [&](int p) { return static_cast<int>(part[cell(p)]); };
      if (smoothBorder(pairsAcross(frame, seg.pixels, partOf, 1, 2, o.smooth_step), o.smooth_share, o.smooth_pairs)) continue;
    }
    Segment one, two;
    for (size_t k = 0; k < seg.pixels.size(); ++k) {
      Segment& to = side(seg.pixels[k], a, b) ? one : two;
      to.pixels.push_back(seg.pixels[k]);
      to.points.push_back(seg.points[k]);
      to.top = std::max(to.top, (T_region_world * seg.points[k]).z());
    }
    seg = std::move(one);
    segments.push_back(std::move(two));
  }
}

// Two objects side by side whose tops meet at about one height: the camera loses the pixels along
// the line where they touch, all but for a few, and the segment's pixels hang together by a
// narrow bridge (splitUnconnected cuts only where none is left). Each segment of at least twice
// min_pixels: its own pixels eroded by a diamond of radius r (half bridge_width at the segment's
// mean depth, at least one pixel); the eroded pixels' 4-connected components of at least the core
// area are its cores. With two cores or more, each of its pixels goes to the nearest core through
// its pixels (breadth first from all cores at once, 4-connected; a pixel no core reaches to the
// largest part). The cut is kept where every part has min_pixels and the line between them is of
// no depth: the pixels of no depth with two parts within 2r of them (in the (4r+1)^2 window), at
// least bridge_gap times the neighbouring pixel pairs of two parts. A neck of one object (a
// blend's two parts, a bar's bend) is parted mostly by its outline, not by such a line. The parts
// after the first are added after the others and not cut again.
void splitAtBridges(const Frame& frame, std::vector<Segment>& segments, const SegmentationOptions& o, const Pose& T_region_world) {
  const CameraModel& cam = frame.camera;
  const int w = cam.width, h = cam.height;
  const Pose T_camera_world = cam.T_world_camera.inverse();
  const size_t n = segments.size();
  for (size_t s = 0; s < n; ++s) {
    Segment& seg = segments[s];
    const size_t m = seg.pixels.size();
    if (static_cast<int>(m) < 2 * o.min_pixels) continue;
    const double z = meanDepth(seg, T_camera_world);
    if (!(z > 0)) continue;
    const double px_per_m = cam.fx / z;
    const int r = std::max(1, static_cast<int>(std::lround(o.bridge_width / 2 * px_per_m)));
    const double min_core = o.bridge_core_area * px_per_m * px_per_m;
    // The segment's box, 2r wider all round: its pixels' places in it.
    int u0 = w, v0 = h, u1 = -1, v1 = -1;
    for (int p : seg.pixels) u0 = std::min(u0, p % w), u1 = std::max(u1, p % w), v0 = std::min(v0, p / w), v1 = std::max(v1, p / w);
    const int pad = 2 * r, bw = u1 - u0 + 1 + 2 * pad, bh = v1 - v0 + 1 + 2 * pad;
    const size_t cells = static_cast<size_t>(bw) * static_cast<size_t>(bh);
    auto cellOf = [&](int p) { return static_cast<size_t>((p / w - v0 + pad) * bw + (p % w - u0 + pad)); };
    std::vector<char> in(cells, 0);
    for (int p : seg.pixels) in[cellOf(p)] = 1;
    std::vector<char> core(cells, 0);
    for (int y = pad; y < bh - pad; ++y)
      for (int x = pad; x < bw - pad; ++x) {
        bool all = in[static_cast<size_t>(y * bw + x)];
        for (int dy = -r; dy <= r && all; ++dy)
          for (int dx = std::abs(dy) - r; dx <= r - std::abs(dy) && all; ++dx) all = in[static_cast<size_t>((y + dy) * bw + x + dx)];
        core[static_cast<size_t>(y * bw + x)] = all;
      }
    // The cores' components, in the box's order; those large enough numbered as parts (a smaller
    // one's pixels marked kSeen: below 0, as every pixel of no part).
    constexpr int kSeen = -2;
    std::vector<int> part(cells, -1);
    std::vector<size_t> queue;
    int parts = 0;
    for (size_t i = 0; i < cells; ++i) {
      if (!core[i] || part[i] != -1) continue;
      const size_t first = queue.size();
      part[i] = parts, queue.push_back(i);
      for (size_t k = first; k < queue.size(); ++k) {
        const int x = static_cast<int>(queue[k] % static_cast<size_t>(bw)), y = static_cast<int>(queue[k] / static_cast<size_t>(bw));
        for (const auto& [dx, dy] : kSides) {
          const size_t q = static_cast<size_t>((y + dy) * bw + x + dx);  // within the box: a core is 2r inside it
          if (core[q] && part[q] == -1) part[q] = parts, queue.push_back(q);
        }
      }
      if (static_cast<double>(queue.size() - first) >= min_core) {
        ++parts;
      } else {
        for (size_t k = first; k < queue.size(); ++k) part[queue[k]] = kSeen;
        queue.resize(first);
      }
    }
    if (parts < 2) continue;
    // Every pixel to the nearest core through the segment's pixels.
    for (size_t k = 0; k < queue.size(); ++k) {
      const int x = static_cast<int>(queue[k] % static_cast<size_t>(bw)), y = static_cast<int>(queue[k] / static_cast<size_t>(bw));
      for (const auto& [dx, dy] : kSides) {
        const int xx = x + dx, yy = y + dy;
        if (xx < 0 || yy < 0 || xx >= bw || yy >= bh) continue;
        const size_t q = static_cast<size_t>(yy * bw + xx);
        if (in[q] && part[q] < 0) part[q] = part[queue[k]], queue.push_back(q);
      }
    }
    // The line between the parts: of no depth, or the parts' own outlines?
    auto partAt = [&](int x, int y) { return x < 0 || y < 0 || x >= bw || y >= bh ? -1 : part[static_cast<size_t>(y * bw + x)]; };
    long touching = 0, gap = 0;
    for (int y = 0; y < bh; ++y)
      for (int x = 0; x < bw; ++x) {
        const int here = partAt(x, y);
        if (here >= 0) {
          touching += (partAt(x + 1, y) >= 0 && partAt(x + 1, y) != here) + (partAt(x, y + 1) >= 0 && partAt(x, y + 1) != here);
          continue;
        }
        const int u = x - pad + u0, v = y - pad + v0;
        if (u < 0 || v < 0 || u >= w || v >= h || frame.depth[static_cast<size_t>(v * w + u)] > 0) continue;
        int first = -1;
        bool two = false;
        for (int dy = -2 * r; dy <= 2 * r && !two; ++dy)
          for (int dx = -2 * r; dx <= 2 * r && !two; ++dx) {
            const int q = partAt(x + dx, y + dy);
            if (q < 0) continue;
            if (first < 0) first = q;
            two = q != first;
          }
        gap += two;
      }
    if (static_cast<double>(gap) < o.bridge_gap * static_cast<double>(touching)) continue;
    std::vector<int> count(static_cast<size_t>(parts), 0);
    for (int p : seg.pixels)
      if (part[cellOf(p)] >= 0) ++count[static_cast<size_t>(part[cellOf(p)])];
    if (*std::min_element(count.begin(), count.end()) < o.min_pixels) continue;
    const int largest = static_cast<int>(std::max_element(count.begin(), count.end()) - count.begin());
    std::vector<Segment> out(static_cast<size_t>(parts));
    for (size_t k = 0; k < m; ++k) {
      const int to = part[cellOf(seg.pixels[k])];
      Segment& into = out[static_cast<size_t>(to >= 0 ? to : largest)];
      into.pixels.push_back(seg.pixels[k]);
      into.points.push_back(seg.points[k]);
      into.top = std::max(into.top, (T_region_world * seg.points[k]).z());
    }
    seg = std::move(out[0]);
    for (size_t k = 1; k < out.size(); ++k) segments.push_back(std::move(out[k]));
  }
}

// The segments as objects (min_pixels or more, covering min_area or more), as pieces too small to
// be objects but rising above the floor's noise (Segmentation::small), or dropped; each list by
// its first pixel.
void keepSegments(std::vector<Segment>& segments, const SegmentationOptions& o, const CameraModel& cam, Segmentation& out) {
  const Pose T_camera_world = cam.T_world_camera.inverse();
  for (Segment& s : segments) {
    const int size = static_cast<int>(s.pixels.size());
    if (size == 0 || size < o.min_obstacle_pixels) continue;  // merged away, or the depth's noise
    for (const Vec3& p : s.points) s.centroid += p;
    s.centroid /= static_cast<double>(s.points.size());
    bool object = size >= o.min_pixels;
    if (object) {
      double area = 0;  // each pixel's footprint at its point's depth along the camera's axis
      for (const Vec3& p : s.points) {
        const double z = (T_camera_world * p).z();
        area += (z / cam.fx) * (z / cam.fy);
      }
      object = area >= o.min_area;
    }
    if (object)
      out.segments.push_back(std::move(s));
    else if (s.top >= o.min_obstacle_height)
      out.small.push_back(std::move(s));
  }
  for (auto* list : {&out.segments, &out.small})
    std::sort(list->begin(), list->end(), [](const Segment& a, const Segment& b) { return a.pixels[0] < b.pixels[0]; });
}

}  // namespace

Segmentation segmentDepth(const Frame& frame, const SegmentationOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  Segmentation out;
  const CameraModel& cam = frame.camera;
  const Pose T_region_world = o.T_world_region.inverse();
  const Pose T_region_camera = T_region_world * cam.T_world_camera;
  const RegionCloud rc = regionCloud(frame, o);
  const auto& cloud = rc.cloud;
  const std::vector<int>& pixel_of = rc.pixel_of;
  const PixelRect& rect = rc.rect;
  out.points = static_cast<int>(pixel_of.size());
  // The cloud's point k into segment s: its pixel, its point in the world, the segment's top.
  auto addPoint = [&](Segment& s, size_t k) {
    const pcl::PointXYZ& p = (*cloud)[k];
    const Vec3 p_world = cam.T_world_camera * Vec3(p.x, p.y, p.z);
    s.pixels.push_back(pixel_of[k]);
    s.points.push_back(p_world);
    s.top = std::max(s.top, (T_region_world * p_world).z());
  };
  if (cloud->empty()) {
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return out;
  }

  if (o.method != SegmentationMethod::kLccp) {
    // The alternatives the issue asks LCCP to be measured against: region growing on the points'
    // normals and curvature (PCL's RegionGrowing), or clustering by distance and normals (PCL's
    // ConditionalEuclideanClustering). Normals from the k nearest points, towards the camera.
    auto tree = std::make_shared<pcl::search::KdTree<pcl::PointXYZ>>();
    tree->setInputCloud(cloud);
    auto normals = std::make_shared<pcl::PointCloud<pcl::Normal>>();
    pcl::NormalEstimation<pcl::PointXYZ, pcl::Normal> ne;
    ne.setInputCloud(cloud);
    ne.setSearchMethod(tree);
    const bool grow = o.method == SegmentationMethod::kRegionGrowing;
    ne.setKSearch(grow ? o.grow_neighbours : o.cluster_neighbours);
    ne.setViewPoint(0, 0, 0);
    ne.compute(*normals);
    std::vector<pcl::PointIndices> clusters;
    if (grow) {
      pcl::RegionGrowing<pcl::PointXYZ, pcl::Normal> rg;
      rg.setMinClusterSize(1);
      rg.setMaxClusterSize(std::numeric_limits<int>::max());
      rg.setSearchMethod(tree);
      rg.setNumberOfNeighbours(o.grow_neighbours);
      rg.setInputCloud(cloud);
      rg.setInputNormals(normals);
      rg.setSmoothnessThreshold(static_cast<float>(o.grow_angle * M_PI / 180));
      rg.setCurvatureThreshold(static_cast<float>(o.grow_curvature));
      rg.extract(clusters);
    } else {
      auto with_normals = std::make_shared<pcl::PointCloud<pcl::PointNormal>>();
      pcl::concatenateFields(*cloud, *normals, *with_normals);
      const float cos_max = static_cast<float>(std::cos(o.cluster_angle * M_PI / 180));
      pcl::ConditionalEuclideanClustering<pcl::PointNormal> cec;
      cec.setInputCloud(with_normals);
      cec.setConditionFunction([cos_max](const pcl::PointNormal& a, const pcl::PointNormal& b, float) {
        return a.getNormalVector3fMap().dot(b.getNormalVector3fMap()) >= cos_max;
      });
      cec.setClusterTolerance(static_cast<float>(o.cluster_tolerance));
      cec.setMinClusterSize(1);
      cec.setMaxClusterSize(std::numeric_limits<int>::max());
      cec.segment(clusters);
    }
    std::vector<Segment> segments(clusters.size());
    for (size_t c = 0; c < clusters.size(); ++c) {
      std::vector<int> idx(clusters[c].indices.begin(), clusters[c].indices.end());
      std::sort(idx.begin(), idx.end());  // pixel_of ascends with the index
      for (int k : idx) addPoint(segments[c], static_cast<size_t>(k));
    }
    keepSegments(segments, o, cam, out);
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return out;
  }

  const Supervoxels voxels = supervoxelsOf(rc, o);
  const auto& clusters = voxels.clusters;
  const auto& adjacency = voxels.adjacency;
  const pcl::PointCloud<pcl::PointXYZL>::Ptr& labelled = voxels.labelled;
  out.supervoxels = static_cast<int>(clusters.size());

  // Each point's supervoxel (0: in none), then each supervoxel's segment.
  std::map<std::uint32_t, std::uint32_t> segment_of;  // supervoxel -> its segment's label
  if (!clusters.empty() && o.merge == SupervoxelMerge::kLearned) {
    ConnectionGraph g = connectionGraph(frame, rc, voxels, T_region_camera);
    const std::vector<int> root = joinByScore(g, o);
    for (size_t i = 0; i < g.label.size(); ++i) segment_of[g.label[i]] = g.label[static_cast<size_t>(root[i])];
  } else if (!clusters.empty()) {
    pcl::LCCPSegmentation<pcl::PointXYZ> lccp;
    lccp.setConcavityToleranceThreshold(static_cast<float>(o.concavity_tolerance));
    lccp.setSanityCheck(true);
    lccp.setSmoothnessCheck(o.smoothness > 0, static_cast<float>(o.voxel), static_cast<float>(o.seed),
                            static_cast<float>(o.smoothness));
    lccp.setKFactor(static_cast<std::uint32_t>(o.k_factor));
    // LCCP's own merging of small segments is off: it visits the supervoxels in the order of
    // their addresses (its graph keeps vertices in a boost::setS), so which neighbour took a small
    // segment changed from run to run. The grouping itself (connected components over the convex
    // edges, each judged by its two supervoxels alone) does not depend on the order; the merging
    // is done below, in an order of our own.
    lccp.setMinSegmentSize(0);
    lccp.setInputSupervoxels(clusters, adjacency);
    lccp.segment();
    lccp.getSupervoxelToSegmentMap(segment_of);
    if (o.sanity_join > 0) joinSanityRefused(clusters, adjacency, o, segment_of);
    if (o.recut_tolerance > 0 && o.max_object_length > 0 && o.max_object_width > 0)
      recutOversized(clusters, adjacency, o, T_region_camera, segment_of);
  }

  // Segments numbered by their first pixel (PCL's labels depend on its visiting order).
  std::map<std::uint32_t, int> id_of;  // LCCP's label -> ours
  std::vector<int> sv_count;
  std::vector<int> seg_of_point(labelled->size(), -1);
  for (size_t k = 0; k < labelled->size(); ++k) {
    const std::uint32_t sv = (*labelled)[k].label;
    const auto it = sv == 0 ? segment_of.end() : segment_of.find(sv);
    if (it == segment_of.end()) continue;  // in no supervoxel
    seg_of_point[k] = id_of.try_emplace(it->second, static_cast<int>(id_of.size())).first->second;
  }
  for (const auto& [sv, seg] : segment_of) id_of.try_emplace(seg, static_cast<int>(id_of.size()));  // segments without a pixel
  const int n = static_cast<int>(id_of.size());
  // Neighbouring segments (through their supervoxels), and each segment's size in supervoxels.
  sv_count.assign(static_cast<size_t>(n), 0);
  std::vector<std::set<int>> near(static_cast<size_t>(n));
  for (const auto& [sv, seg] : segment_of) ++sv_count[static_cast<size_t>(id_of.at(seg))];
  for (const auto& [a, b] : adjacency) {
    const auto ia = segment_of.find(a), ib = segment_of.find(b);
    if (ia == segment_of.end() || ib == segment_of.end()) continue;
    const int sa = id_of.at(ia->second), sb = id_of.at(ib->second);
    if (sa != sb) near[static_cast<size_t>(sa)].insert(sb), near[static_cast<size_t>(sb)].insert(sa);
  }
  // LCCP's rule for small segments, in a fixed order: the smallest segment (then the first) of at
  // most min_supervoxels joins its largest neighbour (then the first), until none is left.
  std::vector<int> into(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) into[static_cast<size_t>(i)] = i;
  for (;;) {
    int small = -1;
    for (int i = 0; i < n; ++i) {
      const size_t u = static_cast<size_t>(i);
      if (into[u] != i || near[u].empty() || sv_count[u] > o.min_supervoxels) continue;
      if (small < 0 || sv_count[u] < sv_count[static_cast<size_t>(small)]) small = i;
    }
    if (small < 0) break;
    const size_t us = static_cast<size_t>(small);
    int big = -1;
    for (int j : near[us])
      if (big < 0 || sv_count[static_cast<size_t>(j)] > sv_count[static_cast<size_t>(big)]) big = j;
    const size_t ub = static_cast<size_t>(big);
    into[us] = big;
    sv_count[ub] += sv_count[us];
    for (int j : near[us]) {
      near[static_cast<size_t>(j)].erase(small);
      if (j != big) near[static_cast<size_t>(j)].insert(big), near[ub].insert(j);
    }
    near[us].clear();
  }
  auto root = [&](int i) {
    while (into[static_cast<size_t>(i)] != i) i = into[static_cast<size_t>(i)];
    return i;
  };

  // The segments' pixels and points, in the order of their first pixel.
  std::vector<Segment> segments(static_cast<size_t>(n));
  for (size_t k = 0; k < labelled->size(); ++k) {
    if (seg_of_point[k] < 0) continue;
    addPoint(segments[static_cast<size_t>(root(seg_of_point[k]))], k);
  }
  if (o.split_unconnected && o.max_object_length > 0 && o.max_object_width > 0)
    splitUnconnected(cam.width, segments, near, o.min_pixels, T_region_world);
  if (o.max_object_length > 0 && o.max_object_width > 0) {
    // Neighbours in the image too: segments whose instance masks touch (one object's pieces are
    // often parted by pixels the camera measured no depth at, and share no supervoxel).
    // The masks' labels over the bin's pixels (rect: every point lies in it; a mask's pixels of
    // no depth may reach past it, and are left out).
    const std::vector<std::vector<int>> masks = segmentMasks(frame, segments);
    const int rw = rect.u1 - rect.u0 + 1, rh = rect.v1 - rect.v0 + 1;
    std::vector<int> at(static_cast<size_t>(rw) * static_cast<size_t>(rh), -1);
    auto inside = [&](int u, int v) { return u >= rect.u0 && u <= rect.u1 && v >= rect.v0 && v <= rect.v1; };
    auto index = [&](int u, int v) { return static_cast<size_t>((v - rect.v0) * rw + u - rect.u0); };
    for (size_t k = 0; k < masks.size(); ++k)
      for (int p : masks[k])
        if (inside(p % cam.width, p / cam.width)) at[index(p % cam.width, p / cam.width)] = static_cast<int>(k);
    for (size_t k = 0; k < masks.size(); ++k)
      for (int p : masks[k]) {
        const int u = p % cam.width, v = p / cam.width;
        for (const auto& [du, dv] : {std::pair{1, 0}, std::pair{0, 1}}) {
          if (!inside(u, v) || !inside(u + du, v + dv)) continue;
          const int l = at[index(u + du, v + dv)];
          if (l >= 0 && l != static_cast<int>(k)) near[k].insert(l), near[static_cast<size_t>(l)].insert(static_cast<int>(k));
        }
      }
    joinWithinObjectSize(segments, near, T_region_world, o, JoinOf::kSize, frame);
    if (o.crumb_pixels > 0) joinWithinObjectSize(segments, near, T_region_world, o, JoinOf::kCrumbs, frame);
    if (o.smooth_step > 0) joinWithinObjectSize(segments, near, T_region_world, o, JoinOf::kSmoothBorder, frame);
    if (o.waist_depth > 0) splitAtWaists(frame, segments, o, T_region_world);
    if (o.bridge_width > 0) splitAtBridges(frame, segments, o, T_region_world);
  }
  keepSegments(segments, o, cam, out);
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

// Fitted by logistic regression (L2 1e-2, Newton's method) on 66813 connections between
// supervoxels of one object or of two, labelled by the renderer's labels: the piles of seeds
// 17-32 (40 each; the training set, never an evaluation's), as
// PileSegmentation.DISABLED_FitsTheConnectionModel prints them (docs/measurements/perception.md).
const ConnectionFeatures kConnectionWeights{{
    13.0502, -1.09608, -4.20476, -0.925046, -0.171035,
    1.30298, -1.14662, 0.126809, 1.88196, -0.00767897,
    -0.365344, -1.88631, -0.436014, -1.2559, -0.691916,
    -0.683215, -2.33588, -0.558797, 0.0662785, 0.205539,
    1.00476, 0.522588, -0.0866714, -0.197906, 1.00415,
}};

SupervoxelGraph supervoxelGraph(const Frame& frame, const SegmentationOptions& o) {
  SupervoxelGraph out;
  const RegionCloud rc = regionCloud(frame, o);
  if (rc.cloud->empty()) return out;
  const Supervoxels sv = supervoxelsOf(rc, o);
  ConnectionGraph g = connectionGraph(frame, rc, sv, o.T_world_region.inverse() * frame.camera.T_world_camera);
  out.pixels = std::move(g.pixels);
  out.connections = std::move(g.connections);
  return out;
}

Segmentation segmentLabels(const Frame& frame, const SegmentationOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  Segmentation out;
  const CameraModel& cam = frame.camera;
  const size_t n = static_cast<size_t>(cam.width) * static_cast<size_t>(cam.height);
  if (frame.segmentation.size() != n) throw std::logic_error("segmentLabels: the frame has no segmentation image");
  const Pose T_region_world = o.T_world_region.inverse();
  std::map<int, Segment> by_label;  // an object's label (2 + k) -> its pixels
  for (int v = 0; v < cam.height; ++v)
    for (int u = 0; u < cam.width; ++u) {
      const int i = v * cam.width + u;
      const float z = frame.depth[static_cast<size_t>(i)];
      const int label = frame.segmentation[static_cast<size_t>(i)];
      if (!(z > 0) || label < kFirstObjectLabel || label == kObstacleLabel) continue;
      const Vec3 p = cam.unproject(u, v, z), q = T_region_world * p;
      if (!insideRegion(q, o)) continue;
      Segment& s = by_label[label];
      s.pixels.push_back(i);
      s.points.push_back(p);
      s.top = std::max(s.top, q.z());
      ++out.points;
    }
  std::vector<Segment> segments;
  for (auto& [label, s] : by_label) segments.push_back(std::move(s));
  keepSegments(segments, o, cam, out);
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

std::vector<std::vector<int>> segmentMasks(const Frame& frame, const std::vector<Segment>& segments, int passes) {
  std::vector<std::vector<int>> masks;
  for (const Segment& s : segments) masks.push_back(s.pixels);
  const int w = frame.camera.width, h = frame.camera.height;
  if (segments.empty() || passes <= 0 || w <= 0 || h <= 0 || frame.depth.size() != static_cast<size_t>(w) * static_cast<size_t>(h)) return masks;
  passes = std::min(passes, std::max(w, h));  // no pass past the image's size takes a pixel
  const int n_pixels = w * h;
  bool any = false;
  for (const Segment& s : segments)
    for (int p : s.pixels) {
      if (p < 0 || p >= n_pixels) throw std::invalid_argument("segmentMasks: a segment's pixel is outside the image");
      any = true;
    }
  if (!any) return masks;
  // The labels over the segments' bounding rectangle, passes + 1 wider (no pass takes a pixel
  // further out, and every pixel a pass may take has its neighbours inside):
  // a segment's index, kNone (depth, in no segment) or kUnknown (no depth, not yet taken).
  constexpr int kNone = -1, kUnknown = -2;
  int u0 = w, v0 = h, u1 = -1, v1 = -1;
  for (const Segment& s : segments)
    for (int p : s.pixels) u0 = std::min(u0, p % w), u1 = std::max(u1, p % w), v0 = std::min(v0, p / w), v1 = std::max(v1, p / w);
  u0 = std::max(0, u0 - passes - 1), v0 = std::max(0, v0 - passes - 1), u1 = std::min(w - 1, u1 + passes + 1), v1 = std::min(h - 1, v1 + passes + 1);
  const int bw = u1 - u0 + 1, bh = v1 - v0 + 1;
  std::vector<int> label(static_cast<size_t>(bw) * static_cast<size_t>(bh));
  for (int v = v0; v <= v1; ++v)
    for (int u = u0; u <= u1; ++u)
      label[static_cast<size_t>((v - v0) * bw + (u - u0))] = frame.depth[static_cast<size_t>(v * w + u)] > 0 ? kNone : kUnknown;
  for (size_t k = 0; k < segments.size(); ++k)
    for (int p : segments[k].pixels) label[static_cast<size_t>((p / w - v0) * bw + (p % w - u0))] = static_cast<int>(k);
  for (int pass = 0; pass < passes; ++pass) {
    std::vector<std::pair<int, int>> taken;  // (pixel in the rectangle, segment), applied after the pass
    for (int y = 0; y < bh; ++y)
      for (int x = 0; x < bw; ++x) {
        if (label[static_cast<size_t>(y * bw + x)] != kUnknown) continue;
        std::array<int, 9> seen{}, count{};
        int kinds = 0;
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const int xx = x + dx, yy = y + dy;
            if (xx < 0 || yy < 0 || xx >= bw || yy >= bh) continue;
            const int l = label[static_cast<size_t>(yy * bw + xx)];
            if (l == kUnknown) continue;
            int i = 0;
            while (i < kinds && seen[static_cast<size_t>(i)] != l) ++i;
            if (i == kinds) seen[static_cast<size_t>(kinds++)] = l;
            ++count[static_cast<size_t>(i)];
          }
        int best = kUnknown, most = 0;
        for (int i = 0; i < kinds; ++i) {
          const int l = seen[static_cast<size_t>(i)], c = count[static_cast<size_t>(i)];
          if (c > most || (c == most && l < best)) best = l, most = c;  // ties: none (-1), then the first segment
        }
        if (best >= 0) taken.emplace_back(y * bw + x, best);
      }
    if (taken.empty()) break;
    for (const auto& [i, k] : taken) {
      label[static_cast<size_t>(i)] = k;
      masks[static_cast<size_t>(k)].push_back((v0 + i / bw) * w + u0 + i % bw);
    }
  }
  for (std::vector<int>& m : masks) std::sort(m.begin(), m.end());
  return masks;
}

ObjectState segmentObject(const Segment& s, const Pose& T_world_region, double cell, double step) {
  ObjectState object;
  object.shape = ObjectShape::kMesh;
  if (s.points.empty()) return object;
  const Pose T_region_world = T_world_region.inverse();
  std::vector<Vec3> q;  // the points in the region's frame
  q.reserve(s.points.size());
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const Vec3& p : s.points) q.push_back(T_region_world * p), mean += q.back().head<2>();
  mean /= static_cast<double>(q.size());
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
  for (const Vec3& p : q) cov += (p.head<2>() - mean) * (p.head<2>() - mean).transpose();
  Eigen::Vector2d major = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(cov).eigenvectors().col(1);  // the larger eigenvalue's
  if (major.x() < 0 || (major.x() == 0 && major.y() < 0)) major = -major;  // one of the two, always the same
  const Eigen::Vector2d minor(-major.y(), major.x());
  // The points in the principal axes (a along the major, b across it), and their extent.
  std::vector<Eigen::Vector3d> abz;
  abz.reserve(q.size());
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(INFINITY), hi = -lo;
  double top = 1e-3;
  for (const Vec3& p : q) {
    const Eigen::Vector2d d = p.head<2>() - mean;
    abz.emplace_back(major.dot(d), minor.dot(d), p.z());
    lo = lo.cwiseMin(abz.back().head<2>()), hi = hi.cwiseMax(abz.back().head<2>());
    top = std::max(top, p.z());
  }
  // Each cell's highest point (cells across are 5/6 as wide, so no column is square: a square
  // column's box would have no preferred axes).
  const double ca = cell, cb = cell * 5 / 6;
  const int na = std::max(1, static_cast<int>(std::ceil((hi.x() - lo.x()) / ca))), nb = std::max(1, static_cast<int>(std::ceil((hi.y() - lo.y()) / cb)));
  // Each cell's highest point and the extent of its points (a column hugs its points, not the
  // whole cell: the cells of two touching segments overlap, their points do not).
  std::vector<double> height(static_cast<size_t>(na * nb), -1);
  std::vector<Eigen::Vector4d> extent(static_cast<size_t>(na * nb), Eigen::Vector4d(INFINITY, -INFINITY, INFINITY, -INFINITY));
  for (const Eigen::Vector3d& p : abz) {
    const int i = std::clamp(static_cast<int>((p.x() - lo.x()) / ca), 0, na - 1), j = std::clamp(static_cast<int>((p.y() - lo.y()) / cb), 0, nb - 1);
    const size_t k = static_cast<size_t>(j * na + i);
    height[k] = std::max(height[k], p.z());
    Eigen::Vector4d& e = extent[k];
    e[0] = std::min(e[0], p.x()), e[1] = std::max(e[1], p.x()), e[2] = std::min(e[2], p.y()), e[3] = std::max(e[3], p.y());
  }
  // The object's frame: the middle of the bounding box, on the principal axes, z up.
  const Eigen::Vector2d mid_ab = (lo + hi) / 2;
  const Eigen::Vector2d mid = mean + major * mid_ab.x() + minor * mid_ab.y();
  Mat3 R = Mat3::Identity();
  R.col(0) << major.x(), major.y(), 0;
  R.col(1) << minor.x(), minor.y(), 0;
  object.T_world_object = T_world_region * makePose(Vec3(mid.x(), mid.y(), top / 2), R);
  object.half_size = Vec3(std::max((hi.x() - lo.x()) / 2, 1e-3), std::max((hi.y() - lo.y()) / 2, 1e-3), top / 2);
  auto pieces = std::make_shared<std::vector<ConvexPiece>>();
  auto column = [&](int i0, int i1, int j, double h) {
    Eigen::Vector4d e(INFINITY, -INFINITY, INFINITY, -INFINITY);
    for (int i = i0; i <= i1; ++i) {
      const Eigen::Vector4d& c = extent[static_cast<size_t>(j * na + i)];
      e[0] = std::min(e[0], c[0]), e[1] = std::max(e[1], c[1]), e[2] = std::min(e[2], c[2]), e[3] = std::max(e[3], c[3]);
    }
    const double a0 = e[0] - mid_ab.x(), a1 = e[1] - mid_ab.x(), b0 = e[2] - mid_ab.y(), b1 = e[3] - mid_ab.y();
    const Vec3 c0(a0, b0, -top / 2), c1(std::max(a1, a0 + 1e-3), std::max(b1, b0 + 1e-3), h - top / 2);
    ConvexPiece piece;
    for (int k = 0; k < 8; ++k) piece.vertices.emplace_back(k & 1 ? c1.x() : c0.x(), k & 2 ? c1.y() : c0.y(), k & 4 ? c1.z() : c0.z());
    for (int axis = 0; axis < 3; ++axis) {
      const Vec3 n = Vec3::Unit(axis);
      piece.planes.push_back({n, c1[axis]});
      piece.planes.push_back({-n, -c0[axis]});
    }
    pieces->push_back(std::move(piece));
  };
  for (int j = 0; j < nb; ++j)
    for (int i = 0; i < na;) {
      const double h0 = height[static_cast<size_t>(j * na + i)];
      if (h0 < 0) {
        ++i;
        continue;
      }
      double lo_h = h0, hi_h = h0;
      int end = i;
      while (end + 1 < na) {
        const double h = height[static_cast<size_t>(j * na + end + 1)];
        if (h < 0 || std::max(hi_h, h) - std::min(lo_h, h) > step) break;
        lo_h = std::min(lo_h, h), hi_h = std::max(hi_h, h), ++end;
      }
      column(i, end, j, hi_h);
      i = end + 1;
    }
  object.pieces = std::move(pieces);
  return object;
}

}  // namespace mm
