#include "sim/object_catalogue.h"

#include <cmath>
#include <filesystem>

#include "robot/mesh.h"
#include "robot/solid_mesh.h"
#include "robot/spec_reader.h"

namespace mm {

const ObjectKind* ObjectCatalogue::find(const std::string& name) const {
  for (const ObjectKind& k : kinds)
    if (k.name == name) return &k;
  return nullptr;
}

std::vector<std::string> ObjectCatalogue::names() const {
  std::vector<std::string> out;
  for (const ObjectKind& k : kinds) out.push_back(k.name);
  return out;
}

ObjectKind ObjectCatalogue::asObject(const ObjectKind& kind, int k) const {
  ObjectKind o = kind;
  if (!o.has_rgba && !palette.empty()) o.rgba = palette[static_cast<size_t>(k) % palette.size()];
  return o;
}

namespace {

std::array<double, 4> readRgba(const spec_io::Reader& r, const YAML::Node& n) {
  if (!n.IsSequence() || n.size() != 4) throw InputError(r.at(n), "a colour expects 4 numbers in [0, 1] (r g b a)");
  std::array<double, 4> c{};
  for (size_t i = 0; i < 4; ++i) {
    try {
      c[i] = n[i].as<double>();
    } catch (const YAML::Exception&) {
      throw InputError(r.at(n[i]), "a colour expects numbers in [0, 1]");
    }
    if (!(c[i] >= 0 && c[i] <= 1)) throw InputError(r.at(n[i]), "a colour's components must be in [0, 1]");
  }
  return c;
}

// Hull vertices MuJoCo 2.2 is given per convex piece (it has no cap of its own; contacts with a
// hull cost with its vertex count).
constexpr int kDefaultHullVertices = 64;

// A mesh kind's solid: every part of the file must be a closed, outward-oriented solid of a sane
// size (MuJoCo 2.2 would load anything, and compute nonsense or crash on it); it collides as the
// capped convex hull of each part (an OBJ's groups are its convex pieces; one part: its hull); the
// mass properties are the parts' (MuJoCo 2.2's own mesh inertia is unreliable), at uniform density.
std::shared_ptr<const ObjectSolid> readSolid(const std::string& file, const Vec3& scale, int hull_vertices, double& mass, double density,
                                             const std::string& what) {
  const std::vector<TriangleMesh> parts = readMeshParts(file, scale);
  auto solid = std::make_shared<ObjectSolid>();
  double volume = 0;
  Vec3 moment = Vec3::Zero();
  Mat3 second = Mat3::Zero();  // about the file's origin, unit density
  for (const TriangleMesh& part : parts) {
    checkSolid(part, file + (part.part.empty() ? "" : " (part '" + part.part + "')"));
    const MassProperties mp = massProperties(part);
    volume += mp.volume;
    moment += mp.volume * mp.centroid;
    // Parallel axis to the file's origin: I_o = I_c + V (|c|^2 1 - c c^T).
    second += mp.inertia + mp.volume * (mp.centroid.squaredNorm() * Mat3::Identity() - mp.centroid * mp.centroid.transpose());
    const int base = static_cast<int>(solid->visual_vertices.size());
    for (const Vec3& v : part.vertices) solid->visual_vertices.push_back(v);
    for (const auto& f : part.faces) solid->visual_faces.push_back({f[0] + base, f[1] + base, f[2] + base});
  }
  std::vector<ConvexHull> hulls;
  for (const TriangleMesh& part : parts) hulls.push_back(cappedHull(part.vertices, hull_vertices, file + (part.part.empty() ? "" : " (part '" + part.part + "')")));
  Vec3 lower = hulls.front().lower, upper = hulls.front().upper;
  for (const ConvexHull& h : hulls) lower = lower.cwiseMin(h.lower), upper = upper.cwiseMax(h.upper);
  const Vec3 centre = (lower + upper) / 2;
  const Vec3 com_file = moment / volume;
  Mat3 inertia = second - volume * (com_file.squaredNorm() * Mat3::Identity() - com_file * com_file.transpose());
  if (mass <= 0) mass = density * volume;
  if (!(mass > 0 && mass < 100)) throw InputError(what, "a mass of " + std::to_string(mass) + " kg from the density and the mesh's volume is not sane");
  solid->volume = volume;
  solid->com = com_file - centre;
  solid->inertia = inertia * (mass / volume);
  for (Vec3& v : solid->visual_vertices) v -= centre;
  std::vector<ConvexPiece> pieces;
  for (const ConvexHull& hull : hulls) {
    ConvexPiece piece;
    for (const Vec3& v : hull.vertices) piece.vertices.push_back(v - centre);
    for (const auto& f : hull.faces) {
      const Vec3 a = piece.vertices[static_cast<size_t>(f[0])], b = piece.vertices[static_cast<size_t>(f[1])], c = piece.vertices[static_cast<size_t>(f[2])];
      const Vec3 n = (b - a).cross(c - a);
      if (n.norm() < 1e-15) continue;
      piece.planes.push_back({n.normalized(), n.normalized().dot(a)});
    }
    pieces.push_back(std::move(piece));
  }
  solid->pieces = std::make_shared<const std::vector<ConvexPiece>>(std::move(pieces));
  return solid;
}

}  // namespace

ObjectCatalogue loadObjectCatalogue(const std::string& path) {
  const spec_io::Reader r{path};
  const YAML::Node root = spec_io::loadYaml(path, "an object catalogue (kinds: name: {shape, size, mass, ...})");
  ObjectCatalogue c;
  c.file = path;
  const YAML::Node kinds = r.require(root, "kinds", root);
  if (!kinds.IsMap() || kinds.size() == 0) throw InputError(r.at(kinds), "'kinds' expects a map of object kinds by name");
  for (const auto& entry : kinds) {
    const YAML::Node& n = entry.second;
    ObjectKind k;
    k.name = entry.first.Scalar();
    if (!n.IsMap()) throw InputError(r.at(n), "object kind '" + k.name + "' expects a map (shape, size, mass, ...)");
    for (const auto& field : n) {
      const std::string key = field.first.Scalar();
      if (key != "shape" && key != "size" && key != "mass" && key != "friction" && key != "condim" && key != "rgba" && key != "mesh" &&
          key != "scale" && key != "density" && key != "hull_vertices")
        throw InputError(r.at(field.first), "object kind '" + k.name + "': unknown key '" + key +
                                                "' (expected shape, size, mass, friction, condim, rgba; a mesh: mesh, scale, mass or density, hull_vertices)");
    }
    const std::string shape = r.text(n, "shape");
    if (shape == "cylinder") k.shape = ObjectShape::kCylinder;
    else if (shape == "mesh") k.shape = ObjectShape::kMesh;
    else if (shape != "box") throw InputError(r.at(n["shape"]), "object kind '" + k.name + "': shape '" + shape + "' is not supported (expected box, cylinder or mesh)");
    for (const char* key : {"mesh", "scale", "density", "hull_vertices"})
      if (n[key] && k.shape != ObjectShape::kMesh)
        throw InputError(r.at(n[key]), "object kind '" + k.name + "': '" + key + "' belongs to a mesh kind (shape: mesh)");
    if (k.shape == ObjectShape::kMesh) {
      if (n["size"]) throw InputError(r.at(n["size"]), "object kind '" + k.name + "': a mesh kind's size comes from its file (use scale)");
      if (n["mass"].IsDefined() == n["density"].IsDefined())
        throw InputError(r.at(n), "object kind '" + k.name + "': a mesh kind expects either mass [kg] or density [kg/m^3]");
      const std::filesystem::path file = r.text(n, "mesh");
      k.mesh = (file.is_absolute() ? file : std::filesystem::path(path).parent_path() / file).lexically_normal().string();
      if (const YAML::Node sc = n["scale"]) {
        if (sc.IsSequence()) {
          const auto v = r.vec3(n, "scale");
          k.scale = Vec3(v[0], v[1], v[2]);
        } else {
          k.scale = Vec3::Constant(r.positive(n, "scale"));
        }
        for (int i = 0; i < 3; ++i)
          if (!(k.scale[i] > 0)) throw InputError(r.at(sc), "object kind '" + k.name + "': scale expects numbers > 0");
      }
      int hull_vertices = kDefaultHullVertices;
      if (n["hull_vertices"]) {
        const double h = r.number(n, "hull_vertices");
        if (!(h >= 8 && h <= 1000 && h == std::floor(h))) throw InputError(r.at(n["hull_vertices"]), "object kind '" + k.name + "': hull_vertices expects a whole number in [8, 1000]");
        hull_vertices = static_cast<int>(h);
      }
      k.mass = n["mass"] ? r.positive(n, "mass") : 0;
      const double density = n["density"] ? r.positive(n, "density") : 0;
      try {
        k.solid = readSolid(k.mesh, k.scale, hull_vertices, k.mass, density, k.mesh);
      } catch (const InputError& e) {  // the mesh's fault, and where the catalogue names it
        throw InputError(r.at(n["mesh"]), "object kind '" + k.name + "': " + e.what());
      }
      Vec3 lo = Vec3::Constant(INFINITY), hi = -lo;
      for (const ConvexPiece& piece : *k.solid->pieces)
        for (const Vec3& v : piece.vertices) lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
      k.half_size = (hi - lo) / 2;
    } else {
      const auto size = r.vec3(n, "size");
      for (int i = 0; i < 3; ++i) {
        if (!(size[i] > 0 && size[i] <= 1)) throw InputError(r.at(n["size"]), "object kind '" + k.name + "': size expects edge lengths in (0, 1] m");
        k.half_size[i] = size[i] / 2;
      }
      if (k.shape == ObjectShape::kCylinder && size[0] != size[1])
        throw InputError(r.at(n["size"]), "object kind '" + k.name + "': a cylinder's size is [diameter, diameter, height]");
      k.mass = r.positive(n, "mass");
    }
    if (n["friction"]) {
      k.friction = r.vec3(n, "friction");
      for (double f : k.friction)
        if (f < 0) throw InputError(r.at(n["friction"]), "object kind '" + k.name + "': friction must be >= 0");
    }
    if (n["condim"]) {
      const double d = r.number(n, "condim");
      if (d != 1 && d != 3 && d != 4 && d != 6) throw InputError(r.at(n["condim"]), "object kind '" + k.name + "': condim expects 1, 3, 4 or 6");
      k.condim = static_cast<int>(d);
    }
    if (n["rgba"]) {
      k.rgba = readRgba(r, n["rgba"]);
      k.has_rgba = true;
    }
    c.kinds.push_back(k);
  }
  if (const YAML::Node p = root["palette"]) {
    if (!p.IsSequence()) throw InputError(r.at(p), "'palette' expects a list of colours (r g b a)");
    for (const auto& colour : p) c.palette.push_back(readRgba(r, colour));
  }
  for (const auto& entry : root) {
    const std::string key = entry.first.Scalar();
    if (key != "kinds" && key != "palette") throw InputError(r.at(entry.first), "unknown key '" + key + "' (expected kinds, palette)");
  }
  return c;
}

}  // namespace mm
