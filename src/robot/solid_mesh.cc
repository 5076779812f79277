#include "robot/solid_mesh.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <string_view>
#include <utility>

#include "core/error.h"

namespace mm {
namespace {

std::string lowerCase(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string num(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%.4g", x);
  return b;
}

std::string point(const Vec3& p) { return "(" + num(p.x()) + ", " + num(p.y()) + ", " + num(p.z()) + ")"; }

bool isSpace(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

// The whitespace-separated words of a line.
std::vector<std::string_view> words(std::string_view line) {
  std::vector<std::string_view> w;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && isSpace(line[i])) ++i;
    const size_t start = i;
    while (i < line.size() && !isSpace(line[i])) ++i;
    if (i > start) w.push_back(line.substr(start, i - start));
  }
  return w;
}

// A decimal number (a leading '+' allowed) filling the word: false when it is not one. "nan",
// "inf" and overflowing numbers parse, as not finite (the caller says so); underflowing ones as 0.
bool parseNumber(std::string_view s, double& x) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), x);
  if (end != s.data() + s.size()) return false;
  if (ec == std::errc::result_out_of_range) {
    x = std::strtod(std::string(s).c_str(), nullptr);  // +-HUGE_VAL or (nearly) 0
    return true;
  }
  return ec == std::errc();
}

// The parts being read: faces over file-global vertex indices.
struct RawPart {
  std::string name;
  std::vector<std::array<int, 3>> faces;
};

std::vector<TriangleMesh> finishParts(const std::vector<Vec3>& vertices, std::vector<RawPart>& raw, const std::string& path) {
  std::vector<TriangleMesh> parts;
  for (RawPart& r : raw) {
    if (r.faces.empty()) continue;
    std::vector<int> index(vertices.size(), -1);
    for (const auto& f : r.faces)
      for (int v : f) index[static_cast<size_t>(v)] = 0;
    TriangleMesh m;
    m.part = r.name;
    for (size_t v = 0; v < vertices.size(); ++v)
      if (index[v] == 0) {
        index[v] = static_cast<int>(m.vertices.size());
        m.vertices.push_back(vertices[v]);
      }
    m.faces.reserve(r.faces.size());
    for (const auto& f : r.faces) m.faces.push_back({index[static_cast<size_t>(f[0])], index[static_cast<size_t>(f[1])], index[static_cast<size_t>(f[2])]});
    parts.push_back(std::move(m));
  }
  if (parts.empty()) throw InputError(path, "the mesh has no faces");
  return parts;
}

// OBJ: 'v' lines are the vertices, 'f' lines the faces, 'o' and 'g' lines start parts.
std::vector<TriangleMesh> readObjParts(const std::string& path, const std::string& bytes, const Vec3& scale) {
  std::vector<Vec3> vertices;
  std::vector<RawPart> raw(1);  // raw[0]: faces before any 'o' or 'g'
  std::map<std::string, size_t> by_name{{"", 0}};
  size_t current = 0;
  struct Pending {  // a positive index may name a vertex further down the file: checked at the end
    int index, line;
  };
  std::vector<Pending> pending;
  size_t pos = 0;
  int number = 0;
  std::string logical;
  while (pos < bytes.size()) {
    size_t end = bytes.find('\n', pos);
    if (end == std::string::npos) end = bytes.size();
    std::string_view line(bytes.data() + pos, end - pos);
    pos = end + 1;
    ++number;
    const int first_line = number;
    logical.assign(line);
    // A backslash at the end of a line continues it on the next.
    while (true) {
      while (!logical.empty() && isSpace(logical.back())) logical.pop_back();
      if (logical.empty() || logical.back() != '\\' || pos >= bytes.size()) break;
      logical.pop_back();
      end = bytes.find('\n', pos);
      if (end == std::string::npos) end = bytes.size();
      logical += ' ';
      logical.append(bytes, pos, end - pos);
      pos = end + 1;
      ++number;
    }
    const size_t hash = logical.find('#');
    if (hash != std::string::npos) logical.resize(hash);
    const std::vector<std::string_view> w = words(logical);
    if (w.empty()) continue;
    const std::string where = path + ":" + std::to_string(first_line);
    if (w[0] == "v") {
      double xyz[3];
      if (w.size() < 4) throw InputError(where, "OBJ: expected 'v x y z'");
      for (int k = 0; k < 3; ++k) {
        if (!parseNumber(w[static_cast<size_t>(k) + 1], xyz[k])) throw InputError(where, "OBJ: '" + std::string(w[static_cast<size_t>(k) + 1]) + "' is not a number");
        if (!std::isfinite(xyz[k])) throw InputError(where, "OBJ: a vertex coordinate that is not a finite number");
      }
      vertices.push_back(Vec3(xyz[0], xyz[1], xyz[2]).cwiseProduct(scale));
      if (!vertices.back().allFinite()) throw InputError(where, "OBJ: the scaled vertex is not a finite number");
    } else if (w[0] == "o" || w[0] == "g") {
      // The name: the rest of the line (a 'g' may list several groups: taken together as one name).
      std::string name;
      for (size_t k = 1; k < w.size(); ++k) name += (k > 1 ? " " : "") + std::string(w[k]);
      auto [it, added] = by_name.emplace(name, raw.size());
      if (added) raw.push_back(RawPart{name, {}});
      current = it->second;
    } else if (w[0] == "f") {
      if (w.size() < 4) throw InputError(where, "OBJ: a face needs at least three vertices, this one has " + std::to_string(w.size() - 1));
      std::vector<int> f;
      for (size_t k = 1; k < w.size(); ++k) {
        const std::string_view ref = w[k].substr(0, w[k].find('/'));
        long long i = 0;
        const auto [e, ec] = std::from_chars(ref.data(), ref.data() + ref.size(), i);
        if (ec != std::errc() || e != ref.data() + ref.size() || i == 0)
          throw InputError(where, "OBJ: '" + std::string(w[k]) + "' is not a vertex reference (a nonzero index, then optionally /texture/normal)");
        const long long n = static_cast<long long>(vertices.size());
        if (i < 0) {
          if (n + i < 0) throw InputError(where, "OBJ: vertex index " + std::to_string(i) + " is out of range (" + std::to_string(n) + " vertices read so far)");
          f.push_back(static_cast<int>(n + i));
        } else {
          if (i > INT32_MAX) throw InputError(where, "OBJ: vertex index " + std::to_string(i) + " is out of range");
          f.push_back(static_cast<int>(i - 1));
          if (i > n) pending.push_back({static_cast<int>(i - 1), first_line});
        }
      }
      for (size_t k = 1; k + 1 < f.size(); ++k) raw[current].faces.push_back({f[0], f[k], f[k + 1]});
    }
    // Everything else (vt, vn, usemtl, mtllib, s, l, p, ...) does not shape a solid.
  }
  for (const Pending& p : pending)
    if (static_cast<size_t>(p.index) >= vertices.size())
      throw InputError(path + ":" + std::to_string(p.line), "OBJ: vertex index " + std::to_string(p.index + 1) + " is out of range (the file has " + std::to_string(vertices.size()) + " vertices)");
  return finishParts(vertices, raw, path);
}

// STL, binary (80-byte header, triangle count, 50 bytes a triangle) unless the file is ASCII
// ("solid" and not the size a binary file of its count has): one part, vertices welded by position.
std::vector<TriangleMesh> readStlParts(const std::string& path, const std::string& bytes, const Vec3& scale) {
  std::vector<Vec3> vertices;
  std::vector<RawPart> raw(1);
  std::map<std::array<double, 3>, int> weld;  // -0 and 0 compare equal: welded
  auto vertex = [&](double x, double y, double z, const std::string& where) {
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) throw InputError(where, "STL: a vertex coordinate that is not a finite number");
    auto [it, added] = weld.emplace(std::array<double, 3>{x, y, z}, static_cast<int>(vertices.size()));
    if (added) {
      vertices.push_back(Vec3(x, y, z).cwiseProduct(scale));
      if (!vertices.back().allFinite()) throw InputError(where, "STL: the scaled vertex is not a finite number");
    }
    return it->second;
  };
  const bool ascii_header = bytes.size() >= 5 && lowerCase(bytes.substr(0, 5)) == "solid";
  uint32_t n = 0;
  if (binaryStl(bytes, n)) {
    for (uint32_t t = 0; t < n; ++t) {
      std::array<int, 3> f{};
      for (int k = 0; k < 3; ++k) {
        float xyz[3];
        std::memcpy(xyz, bytes.data() + 84 + 50ull * t + 12 + 12 * k, 12);
        f[static_cast<size_t>(k)] = vertex(xyz[0], xyz[1], xyz[2], path);
      }
      raw[0].faces.push_back(f);
    }
    return finishParts(vertices, raw, path);
  }
  if (!ascii_header) throw InputError(path, "not an STL file (neither a binary STL of its size nor ASCII 'solid')");
  // ASCII: the 'vertex x y z' of each 'outer loop' ... 'endloop' (a loop of more than three: fanned).
  std::istringstream in(bytes);
  std::string line;
  int number = 0;
  std::vector<int> loop;
  bool in_loop = false;
  while (std::getline(in, line)) {
    ++number;
    const std::vector<std::string_view> w = words(line);
    if (w.empty()) continue;
    const std::string where = path + ":" + std::to_string(number);
    const std::string key = lowerCase(std::string(w[0]));
    if (key == "outer") {
      in_loop = true;
      loop.clear();
    } else if (key == "vertex") {
      double xyz[3];
      if (w.size() != 4) throw InputError(where, "ASCII STL: expected 'vertex x y z'");
      for (int k = 0; k < 3; ++k)
        if (!parseNumber(w[static_cast<size_t>(k) + 1], xyz[k])) throw InputError(where, "ASCII STL: '" + std::string(w[static_cast<size_t>(k) + 1]) + "' is not a number");
      if (!in_loop) throw InputError(where, "ASCII STL: 'vertex' outside 'outer loop' ... 'endloop'");
      loop.push_back(vertex(xyz[0], xyz[1], xyz[2], where));
    } else if (key == "endloop") {
      if (!in_loop) throw InputError(where, "ASCII STL: 'endloop' without its 'outer loop'");
      if (loop.size() < 3) throw InputError(where, "ASCII STL: a facet needs three vertices, this one has " + std::to_string(loop.size()));
      for (size_t k = 1; k + 1 < loop.size(); ++k) raw[0].faces.push_back({loop[0], loop[k], loop[k + 1]});
      in_loop = false;
    }
  }
  if (in_loop) throw InputError(path, "ASCII STL: the file ends inside a facet's 'outer loop'");
  return finishParts(vertices, raw, path);
}

}  // namespace

std::vector<TriangleMesh> readMeshParts(const std::string& path, const Vec3& scale) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw InputError(path, "cannot read the mesh file");
  std::stringstream ss;
  ss << f.rdbuf();
  if (f.bad()) throw InputError(path, "cannot read the mesh file");
  const std::string bytes = ss.str();
  if (!scale.allFinite()) throw InputError(path, "the mesh's scale is not a finite number");
  const std::string ext = lowerCase(path.size() >= 4 ? path.substr(path.size() - 4) : path);
  if (ext == ".stl") return readStlParts(path, bytes, scale);
  if (ext == ".obj") return readObjParts(path, bytes, scale);
  throw InputError(path, "a mesh must be an STL or OBJ file");
}

// Mass properties by the divergence theorem, as in B. Mirtich, "Fast and Accurate Computation of
// Polyhedral Mass Properties", Journal of Graphics Tools 1(2), 1996, and D. Eberly, "Polyhedral Mass
// Properties (Revisited)", Geometric Tools, 2002: a volume integral of a polynomial is a sum of
// integrals over the boundary's faces. Here each face's integral is taken in closed form as that of
// the signed tetrahedron spanned by the face and a reference point r (the bounding box's centre, to
// keep the numbers small): with a, b, c the face's corners relative to r and v = a.(b x c)/6,
//   integral of 1 = v,  of x = v (a+b+c)/4,  of x x^T = v/20 (a a^T + b b^T + c c^T + s s^T), s = a+b+c.
// Summed over a closed surface the parts outside the solid cancel; an outward winding gives v > 0.
MassProperties massProperties(const TriangleMesh& m) {
  MassProperties p;
  if (m.vertices.empty()) return p;
  Vec3 lo = m.vertices.front(), hi = lo;
  for (const Vec3& v : m.vertices) lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
  const Vec3 r = (lo + hi) / 2;
  double volume = 0;
  Vec3 first = Vec3::Zero();
  Mat3 second = Mat3::Zero();
  for (const auto& f : m.faces) {
    const Vec3 a = m.vertices[static_cast<size_t>(f[0])] - r, b = m.vertices[static_cast<size_t>(f[1])] - r,
               c = m.vertices[static_cast<size_t>(f[2])] - r;
    const double v = a.dot(b.cross(c)) / 6;
    const Vec3 s = a + b + c;
    volume += v;
    first += v / 4 * s;
    second += v / 20 * (a * a.transpose() + b * b.transpose() + c * c.transpose() + s * s.transpose());
  }
  p.volume = volume;
  if (volume == 0) {
    p.centroid = r;
    return p;
  }
  const Vec3 d = first / volume;  // the centroid relative to r
  p.centroid = r + d;
  const Mat3 about_centroid = second - volume * d * d.transpose();
  p.inertia = about_centroid.trace() * Mat3::Identity() - about_centroid;
  return p;
}

void checkSolid(const TriangleMesh& m, const std::string& what, double min_extent, double max_extent) {
  const size_t nv = m.vertices.size(), nf = m.faces.size();
  if (nv < 4 || nf < 4)
    throw InputError(what, "a solid needs at least 4 vertices and 4 faces, the mesh has " + std::to_string(nv) + " vertices and " + std::to_string(nf) + " faces");
  for (size_t v = 0; v < nv; ++v)
    if (!m.vertices[v].allFinite()) throw InputError(what, "vertex " + std::to_string(v) + " is not a finite number");
  for (size_t f = 0; f < nf; ++f)
    for (int v : m.faces[f])
      if (v < 0 || static_cast<size_t>(v) >= nv)
        throw InputError(what, "face " + std::to_string(f) + " refers to vertex " + std::to_string(v) + ", the mesh has " + std::to_string(nv));

  // Size: a file in millimetres read as metres is the usual mistake.
  Vec3 lo = m.vertices.front(), hi = lo;
  for (const Vec3& v : m.vertices) lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
  const double extent = (hi - lo).maxCoeff();
  if (extent < min_extent || extent > max_extent) {
    std::string msg = num(extent) + " m wide (its bounding box's largest side) is too " + (extent > max_extent ? "large" : "small") +
                      " for an object: expected " + num(min_extent) + " to " + num(max_extent) + " m";
    auto fits = [&](double x) { return x >= min_extent && x <= max_extent; };
    if (extent > max_extent && fits(extent * 0.001))
      msg += "; did you mean scale 0.001 (a file in millimetres)? It would be " + num(extent * 0.001) + " m wide";
    else if (extent < min_extent && extent > 0 && fits(extent * 1000))
      msg += "; at 1000 times the scale it would be " + num(extent * 1000) + " m wide (a file in metres given a millimetre scale?)";
    throw InputError(what, msg);
  }

  // Degenerate triangles: an area below (1e-6 of the size)^2, far below any face a solid needs and
  // above rounding (corners exactly on a line or repeated give zero up to that).
  const double min_area = 1e-12 * extent * extent;
  for (size_t f = 0; f < nf; ++f) {
    const auto& t = m.faces[f];
    const Vec3 &a = m.vertices[static_cast<size_t>(t[0])], &b = m.vertices[static_cast<size_t>(t[1])], &c = m.vertices[static_cast<size_t>(t[2])];
    const double area = (b - a).cross(c - a).norm() / 2;
    if (!(area >= min_area))
      throw InputError(what, "degenerate: face " + std::to_string(f) + " (vertices " + std::to_string(t[0]) + ", " + std::to_string(t[1]) + ", " +
                                 std::to_string(t[2]) + ") has no area (" + num(area) + " m^2; its corners lie on a line)");
  }

  // Edges: each undirected one in exactly two faces, each directed one in exactly one.
  std::map<std::pair<int, int>, std::vector<int>> edges;  // (low, high) -> faces
  std::map<std::pair<int, int>, int> directed;           // (from, to) -> first face
  for (size_t f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = m.faces[f][static_cast<size_t>(k)], b = m.faces[f][static_cast<size_t>((k + 1) % 3)];
      edges[{std::min(a, b), std::max(a, b)}].push_back(static_cast<int>(f));
    }
  auto edgeName = [&](int a, int b) {
    return "edge between vertices " + std::to_string(a) + " " + point(m.vertices[static_cast<size_t>(a)]) + " and " + std::to_string(b) + " " +
           point(m.vertices[static_cast<size_t>(b)]);
  };
  auto others = [](size_t count, const std::string& kind) {
    return count > 1 ? " (and " + std::to_string(count - 1) + " more " + kind + ")" : std::string();
  };
  std::pair<int, int> open_edge{-1, -1}, crowded_edge{-1, -1};
  size_t open_count = 0, crowded_count = 0, crowded_faces = 0;
  for (const auto& [e, faces] : edges) {
    if (faces.size() == 1 && open_count++ == 0) open_edge = e;
    if (faces.size() > 2 && crowded_count++ == 0) {
      crowded_edge = e;
      crowded_faces = faces.size();
    }
  }
  if (crowded_count > 0)
    throw InputError(what, "non-manifold: " + edgeName(crowded_edge.first, crowded_edge.second) + " belongs to " + std::to_string(crowded_faces) +
                               " faces" + others(crowded_count, "such edges") + "; a solid's every edge joins exactly two faces");
  if (open_count > 0)
    throw InputError(what, "open: " + edgeName(open_edge.first, open_edge.second) + " belongs to 1 face" + others(open_count, "such edges") +
                               "; a solid's surface is closed (every edge joins exactly two faces)");
  for (size_t f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = m.faces[f][static_cast<size_t>(k)], b = m.faces[f][static_cast<size_t>((k + 1) % 3)];
      const auto [it, added] = directed.emplace(std::make_pair(a, b), static_cast<int>(f));
      if (!added)
        throw InputError(what, "inconsistently oriented: faces " + std::to_string(it->second) + " and " + std::to_string(f) + " both run from vertex " +
                                   std::to_string(a) + " to " + std::to_string(b) + " (one of them is flipped; neighbouring faces wind the same way)");
    }

  const MassProperties p = massProperties(m);
  if (p.volume < 0)
    throw InputError(what, "inside out: the faces wind clockwise seen from outside (volume " + num(p.volume) +
                               " m^3); reverse every face's vertex order");
  if (!(p.volume > 1e-9 * extent * extent * extent))
    throw InputError(what, "the closed surface spans no volume (" + num(p.volume) + " m^3)");
}

ConvexHull cappedHull(const std::vector<Vec3>& points, int max_vertices, const std::string& what) {
  if (max_vertices < 4) throw InputError(what, "a convex hull has at least 4 vertices, the cap is " + std::to_string(max_vertices));
  ConvexHull full = convexHull(points, what);
  if (full.vertices.size() <= static_cast<size_t>(max_vertices)) return full;
  // The hull's vertices as indices into `points` (the first of equal ones), ascending: the result
  // depends on the points only, not on the order qhull lists its vertices in.
  std::map<std::array<double, 3>, int> first_index;
  for (size_t i = 0; i < points.size(); ++i) first_index.emplace(std::array<double, 3>{points[i].x(), points[i].y(), points[i].z()}, static_cast<int>(i));
  std::vector<int> candidates;
  for (const Vec3& v : full.vertices) candidates.push_back(first_index.at({v.x(), v.y(), v.z()}));
  std::sort(candidates.begin(), candidates.end());
  candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());
  // Farthest-point sampling: start at the largest x, then repeatedly the candidate farthest from
  // those kept (ties: the first, i.e. the lower index).
  size_t start = 0;
  for (size_t k = 1; k < candidates.size(); ++k)
    if (points[static_cast<size_t>(candidates[k])].x() > points[static_cast<size_t>(candidates[start])].x()) start = k;
  std::vector<double> distance(candidates.size(), HUGE_VAL);  // squared, to the nearest kept
  std::vector<Vec3> kept;
  size_t next = start;
  while (kept.size() < static_cast<size_t>(max_vertices)) {
    const Vec3 q = points[static_cast<size_t>(candidates[next])];
    kept.push_back(q);
    size_t far = 0;
    for (size_t k = 0; k < candidates.size(); ++k) {
      distance[k] = std::min(distance[k], (points[static_cast<size_t>(candidates[k])] - q).squaredNorm());
      if (distance[k] > distance[far]) far = k;
    }
    next = far;
  }
  return convexHull(kept, what);
}

Mat3 inertiaWithMass(const MassProperties& p, double mass) {
  MM_DEMAND(p.volume > 0);
  return p.inertia * (mass / p.volume);
}

}  // namespace mm
