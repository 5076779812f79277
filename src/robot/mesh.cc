#include "robot/mesh.h"

extern "C" {
#include <libqhull_r/qhull_ra.h>
}

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <cstring>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>

#include "core/error.h"

namespace mm {
namespace {

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// STL: binary (80-byte header, triangle count, 50 bytes a triangle) unless the file is ASCII
// ("solid" and the size a binary file of its count would not have).
std::vector<Vec3> readStl(const std::string& path, const std::string& bytes) {
  std::vector<Vec3> v;
  const bool ascii_header = bytes.size() >= 5 && lower(bytes.substr(0, 5)) == "solid";
  uint32_t n = 0;
  if (binaryStl(bytes, n)) {
    for (uint32_t t = 0; t < n; ++t)
      for (int k = 0; k < 3; ++k) {
        float xyz[3];
        std::memcpy(xyz, bytes.data() + 84 + 50ull * t + 12 + 12 * k, 12);
        v.emplace_back(xyz[0], xyz[1], xyz[2]);
      }
    return v;
  }
  if (!ascii_header) throw InputError(path, "not an STL file (neither a binary STL of its size nor ASCII 'solid')");
  std::istringstream in(bytes);
  std::string word;
  while (in >> word) {
    if (word != "vertex") continue;
    double x, y, z;
    if (!(in >> x >> y >> z)) throw InputError(path, "ASCII STL: expected three numbers after 'vertex'");
    v.emplace_back(x, y, z);
  }
  return v;
}

// OBJ: the 'v x y z' lines (faces do not change a hull).
std::vector<Vec3> readObj(const std::string& path, const std::string& bytes) {
  std::vector<Vec3> v;
  std::istringstream in(bytes);
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.size() < 2 || line[0] != 'v' || (line[1] != ' ' && line[1] != '\t')) continue;
    std::istringstream l(line.substr(2));
    double x, y, z;
    if (!(l >> x >> y >> z)) throw InputError(path + ":" + std::to_string(number), "OBJ: expected 'v x y z'");
    v.emplace_back(x, y, z);
  }
  return v;
}

}  // namespace

bool binaryStl(const std::string& bytes, uint32_t& triangles) {
  triangles = 0;
  if (bytes.size() < 84) return false;
  std::memcpy(&triangles, bytes.data() + 80, 4);
  return bytes.size() == 84 + 50ull * triangles;
}

std::vector<Vec3> readMeshVertices(const std::string& path, const Vec3& scale) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw InputError(path, "cannot read the mesh file");
  std::stringstream ss;
  ss << f.rdbuf();
  const std::string bytes = ss.str();
  const std::string ext = lower(path.size() >= 4 ? path.substr(path.size() - 4) : path);
  std::vector<Vec3> v;
  if (ext == ".stl") v = readStl(path, bytes);
  else if (ext == ".obj") v = readObj(path, bytes);
  else throw InputError(path, "a collision mesh must be STL or OBJ (what MuJoCo 2.2 reads of the usual formats)");
  if (v.empty()) throw InputError(path, "the mesh has no vertices");
  for (Vec3& p : v) {
    if (!p.allFinite()) throw InputError(path, "the mesh has a vertex that is not a finite number");
    p = p.cwiseProduct(scale);
  }
  return v;
}

ConvexHull convexHull(const std::vector<Vec3>& points, const std::string& what) {
  if (points.size() < 4) throw InputError(what, "a convex hull needs at least four points, the mesh has " + std::to_string(points.size()));
  std::vector<coordT> coords;
  coords.reserve(3 * points.size());
  for (const Vec3& p : points) coords.insert(coords.end(), {p.x(), p.y(), p.z()});
  qhT qh_storage;
  qhT* qh = &qh_storage;
  QHULL_LIB_CHECK
  qh_zero(qh, nullptr);
  // Qt: triangulated output. No output file; errors to /dev/null (the exit code says it).
  FILE* null = std::fopen("/dev/null", "w");
  char options[] = "qhull Qt";
  const int code = qh_new_qhull(qh, 3, static_cast<int>(points.size()), coords.data(), False, options, nullptr, null);
  ConvexHull h;
  if (code == 0) {
    std::map<int, int> index;  // qhull point id -> hull vertex
    vertexT* vertex;
    FORALLvertices {
      const int id = qh_pointid(qh, vertex->point);
      index[id] = static_cast<int>(h.vertices.size());
      h.vertices.push_back(points[static_cast<size_t>(id)]);
    }
    facetT* facet;
    FORALLfacets {
      std::array<int, 3> tri{};
      int k = 0;
      vertexT** vertexp;
      FOREACHvertex_(facet->vertices) if (k < 3) tri[k++] = index[qh_pointid(qh, vertex->point)];
      if (k != 3) continue;
      // Outward: the facet's normal against the triangle's winding.
      const Vec3 a = h.vertices[tri[0]], b = h.vertices[tri[1]], c = h.vertices[tri[2]];
      const Vec3 n(facet->normal[0], facet->normal[1], facet->normal[2]);
      if ((b - a).cross(c - a).dot(n) < 0) std::swap(tri[1], tri[2]);
      h.faces.push_back(tri);
    }
  }
  qh_freeqhull(qh, !qh_ALL);
  int curlong, totlong;
  qh_memfreeshort(qh, &curlong, &totlong);
  if (null) std::fclose(null);
  if (code != 0 || h.faces.size() < 4) throw InputError(what, "the mesh spans no volume (its points lie on a plane or a line)");
  h.lower = h.upper = h.vertices.front();
  for (const Vec3& p : h.vertices) h.lower = h.lower.cwiseMin(p), h.upper = h.upper.cwiseMax(p);
  return h;
}

std::string meshCacheFile(const std::vector<Vec3>& vertices) {
  std::string text = "# vertices of a collision mesh held in memory (minimanip)\n";
  char line[96];
  for (const Vec3& v : vertices) {
    std::snprintf(line, sizeof line, "v %.17g %.17g %.17g\n", v.x(), v.y(), v.z());
    text += line;
  }
  uint64_t h = 1469598103934665603ull;  // FNV-1a
  for (unsigned char c : text) h = (h ^ c) * 1099511628211ull;
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "minimanip-meshes";
  char name[40];
  std::snprintf(name, sizeof name, "%016llx.obj", static_cast<unsigned long long>(h));
  const std::filesystem::path path = dir / name;
  if (!std::filesystem::exists(path)) {
    std::filesystem::create_directories(dir);
    const std::filesystem::path tmp = dir / (std::string(name) + "." + std::to_string(::getpid()) + ".tmp");
    std::ofstream(tmp) << text;
    std::filesystem::rename(tmp, path);
  }
  return path.string();
}

std::shared_ptr<const ConvexHull> meshHull(const std::string& path, const Vec3& scale) {
  static std::mutex mutex;
  static std::map<std::string, std::shared_ptr<const ConvexHull>> cache;
  char key[96];  // "|" and three %.17g of up to 24 characters each
  std::snprintf(key, sizeof key, "|%.17g %.17g %.17g", scale.x(), scale.y(), scale.z());
  std::lock_guard<std::mutex> lock(mutex);
  auto& slot = cache[path + key];
  if (!slot) slot = std::make_shared<const ConvexHull>(convexHull(readMeshVertices(path, scale), path));
  return slot;
}

}  // namespace mm
