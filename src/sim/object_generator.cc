#include "sim/object_generator.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "core/error.h"
#include "robot/solid_mesh.h"

namespace mm {

const std::vector<std::string>& shapeGrades() {
  static const std::vector<std::string> grades{"convex", "blend", "bent", "hollow"};
  return grades;
}

void ObjectSetOptions::declare(ConfigArchive& a) {
  a.list("grades", grades, shapeGrades(),
         "generated unknown objects instead of the catalogue's kinds: the shape grades a round draws from, in equal shares "
         "(convex: one convex solid; blend: two or three stacked; bent: an L, U or zigzag bar; hollow: a ring, cup or channel); "
         "empty: objects.kinds");
  a.value("density", density, {50, 3000}, "kg/m^3", "generated objects' density");
  a.value("max_width", max_width, {0.02, 0.07}, "m",
          "every generated object has a piece at most this wide in some direction (the fingers close across it)");
  a.value("max_extent", max_extent, {0.05, 0.15}, "m", "no side of a generated object's bounding box is longer (at least max_width)");
}

namespace {

using Poly = std::vector<Vec2>;

// An irregular convex-ish polygon: n corners about a circle of radius r, each moved by up to
// `jitter` of r along the radius and a fifth of a step around (the pieces are hulls, so a dent is
// filled), turned at random.
Poly polygon(Rng& rng, int n, double r, double jitter) {
  const double turn = rng.uniform(0, 2 * M_PI);
  Poly p;
  for (int k = 0; k < n; ++k) {
    const double a = turn + 2 * M_PI * (k + rng.uniform(-0.2, 0.2)) / n;
    const double rk = r * (1 + rng.uniform(-jitter, jitter));
    p.emplace_back(rk * std::cos(a), rk * std::sin(a));
  }
  return p;
}

Poly transformed(const Poly& p, const Vec2& scale, const Vec2& shift) {
  Poly q;
  for (const Vec2& v : p) q.push_back(v.cwiseProduct(scale) + shift);
  return q;
}

// The convex hull of points as a piece (a closed solid, faces outward).
TriangleMesh hullPiece(const std::vector<Vec3>& points, const std::string& name) {
  const ConvexHull h = convexHull(points, name);
  TriangleMesh m;
  m.part = name;
  m.vertices = h.vertices;
  m.faces = h.faces;
  return m;
}

// The convex piece between a polygon at z0 and another at z1 (a prism, a frustum, a mitred bar).
TriangleMesh piece(const Poly& bottom, double z0, const Poly& top, double z1, const std::string& name) {
  std::vector<Vec3> points;
  for (const Vec2& v : bottom) points.emplace_back(v.x(), v.y(), z0);
  for (const Vec2& v : top) points.emplace_back(v.x(), v.y(), z1);
  return hullPiece(points, name);
}

// The corners of a bar of width w along the polyline p, mitred at its bends (closed: p's last
// point joins its first): for point j, the offset from it to the bar's left edge. Consecutive
// segments' pieces share their mitre face, so they touch and do not overlap.
std::vector<Vec2> mitres(const Poly& p, double w, bool closed) {
  const size_t n = p.size(), segments = closed ? n : n - 1;
  auto normal = [&](size_t s) {
    const Vec2 d = (p[(s + 1) % n] - p[s]).normalized();
    return Vec2(-d.y(), d.x());
  };
  std::vector<Vec2> m(n);
  for (size_t j = 0; j < n; ++j) {
    const bool has_before = closed || j > 0, has_after = closed || j + 1 < n;
    if (!has_before) m[j] = normal(0) * w / 2;
    else if (!has_after) m[j] = normal(segments - 1) * w / 2;
    else {
      const Vec2 a = normal((j + segments - 1) % segments), b = normal(j % segments);
      const Vec2 bis = (a + b).normalized();
      m[j] = bis * (w / 2) / bis.dot(b);
    }
  }
  return m;
}

// The pieces of a bar of width w and height z0..z1 along p, mitred at its bends.
std::vector<TriangleMesh> bar(const Poly& p, double w, double z0, double z1, bool closed, const std::string& name) {
  const std::vector<Vec2> m = mitres(p, w, closed);
  const size_t n = p.size(), segments = closed ? n : n - 1;
  std::vector<TriangleMesh> pieces;
  for (size_t s = 0; s < segments; ++s) {
    const size_t a = s, b = (s + 1) % n;
    const Poly quad{p[a] + m[a], p[b] + m[b], p[b] - m[b], p[a] - m[a]};
    pieces.push_back(piece(quad, z0, quad, z1, name + " piece " + std::to_string(s)));
  }
  return pieces;
}

// Whether a bar's segments keep their mitred quads convex and untangled: each segment's edges on
// both sides longer than `least` after its mitres, and segments that do not share a joint apart.
bool barIsClean(const Poly& p, double w, bool closed, double least) {
  const std::vector<Vec2> m = mitres(p, w, closed);
  const size_t n = p.size(), segments = closed ? n : n - 1;
  for (size_t s = 0; s < segments; ++s) {
    const size_t a = s, b = (s + 1) % n;
    const Vec2 d = (p[b] - p[a]).normalized();
    if ((p[b] + m[b] - p[a] - m[a]).dot(d) < least || (p[b] - m[b] - p[a] + m[a]).dot(d) < least) return false;
  }
  // Segments not next to each other: their centrelines apart by the width and 5 mm (a U's arms).
  auto segmentDistance = [](const Vec2& a0, const Vec2& a1, const Vec2& b0, const Vec2& b1) {
    auto pointSeg = [](const Vec2& q, const Vec2& s0, const Vec2& s1) {
      const Vec2 d = s1 - s0;
      const double t = std::clamp((q - s0).dot(d) / d.squaredNorm(), 0.0, 1.0);
      return (q - s0 - t * d).norm();
    };
    return std::min({pointSeg(a0, b0, b1), pointSeg(a1, b0, b1), pointSeg(b0, a0, a1), pointSeg(b1, a0, a1)});
  };
  for (size_t s = 0; s < segments; ++s)
    for (size_t t = s + 2; t < segments; ++t) {
      if (closed && s == 0 && t == segments - 1) continue;
      if (segmentDistance(p[s], p[(s + 1) % n], p[t], p[(t + 1) % n]) < w + 0.005) return false;
    }
  return true;
}

Vec3 extent(const std::vector<TriangleMesh>& pieces) {
  Vec3 lo = Vec3::Constant(INFINITY), hi = -lo;
  for (const TriangleMesh& t : pieces)
    for (const Vec3& v : t.vertices) lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
  return hi - lo;
}

struct Recipe {
  std::string name;
  std::vector<TriangleMesh> pieces;
};

Recipe convexSolid(Rng& rng, const ObjectSetOptions& o) {
  const double r_max = o.max_width / 2;
  switch (rng.below(4)) {
    case 0: {  // a prism on an irregular polygon, lying on an end or standing
      const int n = 3 + static_cast<int>(rng.below(6));
      const Poly p = polygon(rng, n, rng.uniform(0.6 * r_max, r_max) / 1.15, 0.15);
      return {"prism", {piece(p, 0, p, rng.uniform(0.02, o.max_extent), "prism")}};
    }
    case 1: {  // a frustum: its top smaller, turned a little
      const int n = 4 + static_cast<int>(rng.below(5));
      const Poly p = polygon(rng, n, rng.uniform(0.6 * r_max, r_max) / 1.15, 0.15);
      const double s = rng.uniform(0.35, 0.9);
      return {"frustum", {piece(p, 0, transformed(p, Vec2(s, s), Vec2(rng.uniform(-0.2, 0.2), rng.uniform(-0.2, 0.2)) * (1 - s) * r_max),
                                rng.uniform(0.025, 0.9 * o.max_extent), "frustum")}};
    }
    case 2: {  // a box, one side closable
      const double x = rng.uniform(0.02, o.max_width), y = rng.uniform(0.02, o.max_extent), z = rng.uniform(0.02, 0.8 * o.max_extent);
      const Poly p{{-x / 2, -y / 2}, {x / 2, -y / 2}, {x / 2, y / 2}, {-x / 2, y / 2}};
      return {"box", {piece(p, 0, p, z, "box")}};
    }
    default: {  // a pebble: an ellipsoid's hull, cut flat below
      const double a = rng.uniform(0.6 * r_max, r_max), b = rng.uniform(0.015, o.max_extent / 2), c = rng.uniform(std::min(0.012, r_max), r_max);
      std::vector<Vec3> points;
      const int n = 40;
      for (int k = 0; k < n; ++k) {  // a Fibonacci sphere
        const double z = 1 - 2 * (k + 0.5) / n, rho = std::sqrt(1 - z * z), phi = k * M_PI * (3 - std::sqrt(5.0));
        points.emplace_back(a * rho * std::cos(phi), b * rho * std::sin(phi), std::max(c * z, -0.6 * c));
      }
      return {"pebble", {hullPiece(points, "pebble")}};
    }
  }
}

Recipe blendSolid(Rng& rng, const ObjectSetOptions& o) {
  const int n_pieces = 2 + static_cast<int>(rng.below(2));
  const double r_max = o.max_width / 2;
  Recipe r{"stack" + std::to_string(n_pieces), {}};
  double z = 0;
  Vec2 centre = Vec2::Zero();
  double r_below = 0;
  const double height = rng.uniform(0.04, o.max_extent);
  for (int i = 0; i < n_pieces; ++i) {
    const double radius = rng.uniform(0.45 * r_max, r_max) / 1.15;
    const double stretch = rng.uniform(1.0, std::clamp(o.max_extent / (2 * r_max), 1.0, 1.8));  // longer one way, never wider across
    if (i > 0) {  // offset, but resting on the piece below
      const double reach = 0.4 * std::min(radius, r_below);
      centre += Vec2(rng.uniform(-reach, reach), rng.uniform(-reach, reach));
    }
    const Poly base = polygon(rng, 4 + static_cast<int>(rng.below(5)), radius, 0.15);
    const double turn = rng.uniform(0, M_PI);
    Poly p;
    for (const Vec2& v : base) p.push_back(Eigen::Rotation2Dd(turn) * Vec2(v.x() * stretch, v.y()) + centre);
    const double top_scale = rng.uniform(0.7, 1.0);
    Poly q;
    for (const Vec2& v : p) q.push_back(centre + top_scale * (v - centre));
    const double h = height / n_pieces * rng.uniform(0.7, 1.3);
    r.pieces.push_back(piece(p, z, q, z + h, "piece " + std::to_string(i)));
    z += h;
    r_below = radius * top_scale;
  }
  return r;
}

Recipe bentSolid(Rng& rng, const ObjectSetOptions& o) {
  const double w = rng.uniform(0.014, std::min(0.03, o.max_width)), h = rng.uniform(0.014, std::min(0.035, o.max_width));
  const int recipe = static_cast<int>(rng.below(3));
  const std::string name = recipe == 0 ? "l" : recipe == 1 ? "u" : "zigzag";
  const double sign = rng.below(2) ? -1 : 1;  // which way it bends
  for (int attempt = 0; attempt < 1000; ++attempt) {  // a draw whose arms touch, or whose mitres cross, is drawn again
    std::vector<double> turns;
    if (recipe == 0) turns = {rng.uniform(70, 110)};
    else if (recipe == 1) turns = {rng.uniform(75, 100), rng.uniform(75, 100)};
    else turns = {rng.uniform(40, 75), -rng.uniform(40, 75)};
    Poly p{Vec2::Zero()};
    double heading = 0;
    for (size_t s = 0; s <= turns.size(); ++s) {
      const double length = recipe == 2 ? rng.uniform(0.025, 0.05) : rng.uniform(0.03, 0.06);
      const Vec2 next = p.back() + length * Vec2(std::cos(heading), std::sin(heading));
      p.push_back(next);
      if (s < turns.size()) heading += sign * turns[s] * M_PI / 180;
    }
    if (barIsClean(p, w, false, 0.008)) return {name, bar(p, w, 0, h, false, name)};
  }
  throw std::logic_error("object generator: no clean bent bar in 1000 draws");
}

Recipe hollowSolid(Rng& rng, const ObjectSetOptions& o) {
  const int recipe = static_cast<int>(rng.below(3));
  if (recipe == 2) {  // a channel: a floor and a wall on each end
    const double length = rng.uniform(0.045, o.max_extent), width = rng.uniform(0.02, o.max_width);
    const double floor = rng.uniform(0.004, 0.008), wall = rng.uniform(0.005, 0.01), height = rng.uniform(0.025, 0.06);
    auto rect = [](double x0, double x1, double y0, double y1) { return Poly{{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}}; };
    const Poly base = rect(-length / 2, length / 2, -width / 2, width / 2);
    const Poly left = rect(-length / 2, -length / 2 + wall, -width / 2, width / 2);
    const Poly right = rect(length / 2 - wall, length / 2, -width / 2, width / 2);
    return {"channel", {piece(base, 0, base, floor, "floor"), piece(left, floor, left, height, "wall 0"),
                        piece(right, floor, right, height, "wall 1")}};
  }
  // A ring of n wall pieces about a centreline polygon; a cup stands it on a floor.
  const int n = 6 + static_cast<int>(rng.below(5));
  const double wall = rng.uniform(0.006, 0.012), height = rng.uniform(0.025, 0.06);
  const double outer = rng.uniform(0.045, o.max_extent) / 2;
  const double radius = outer - wall;  // the centreline's corners; the mitred outer corners reach about outer
  Poly centreline;
  for (int k = 0; k < n; ++k) centreline.emplace_back(radius * std::cos(2 * M_PI * k / n), radius * std::sin(2 * M_PI * k / n));
  const bool cup = recipe == 1;
  const double floor = cup ? rng.uniform(0.004, 0.008) : 0.0;
  std::vector<TriangleMesh> pieces = bar(centreline, wall, floor, height, true, cup ? "cup wall" : "ring");
  if (cup) {
    const std::vector<Vec2> m = mitres(centreline, wall, true);
    Poly rim;
    for (int k = 0; k < n; ++k)  // the outer edge: the centreline runs anticlockwise, its left is inside
      rim.push_back(centreline[static_cast<size_t>(k)] - m[static_cast<size_t>(k)]);
    pieces.push_back(piece(rim, 0, rim, floor, "floor"));
  }
  return {cup ? "cup" : "ring", std::move(pieces)};
}

}  // namespace

ObjectKind generateObject(const std::string& grade, Rng& rng, const ObjectSetOptions& options) {
  Recipe r;
  if (grade == "convex") r = convexSolid(rng, options);
  else if (grade == "blend") r = blendSolid(rng, options);
  else if (grade == "bent") r = bentSolid(rng, options);
  else if (grade == "hollow") r = hollowSolid(rng, options);
  else throw InputError("objects.generated.grades", "'" + grade + "' is not a grade (expected convex, blend, bent or hollow)");
  // Too long a way for a place slot: scaled down whole (its pieces still touch, its widths shrink).
  const Vec3 e = extent(r.pieces);
  if (e.maxCoeff() > options.max_extent) {
    const double s = options.max_extent / e.maxCoeff();
    for (TriangleMesh& t : r.pieces)
      for (Vec3& v : t.vertices) v *= s;
  }
  ObjectKind k;
  k.name = grade + "_" + r.name;
  k.grade = grade;
  k.shape = ObjectShape::kMesh;
  k.mass = 0;
  k.solid = solidFromParts(r.pieces, kDefaultHullVertices, k.mass, options.density, "generated " + k.name);
  k.half_size = boundingHalfSize(*k.solid);
  k.rgba = {0.55, 0.55, 0.58, 1};  // every one the same colour
  k.has_rgba = true;
  return k;
}

std::vector<ObjectKind> generateObjectSet(uint64_t seed, int count, const ObjectSetOptions& options) {
  if (!options.enabled()) throw InputError("objects.generated.grades", "expected at least one grade");
  Rng rng(seed);
  const size_t start = rng.below(options.grades.size());
  std::vector<ObjectKind> set;
  for (int k = 0; k < count; ++k) {
    Rng own(mixSeed(seed, static_cast<uint64_t>(k) + 1));
    set.push_back(generateObject(options.grades[(start + static_cast<size_t>(k)) % options.grades.size()], own, options));
  }
  return set;
}

}  // namespace mm
