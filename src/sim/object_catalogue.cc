#include "sim/object_catalogue.h"

#include <cmath>
#include <cstdio>
#include <filesystem>

#include "robot/mesh.h"
#include "robot/solid_mesh.h"
#include "robot/urdf_object.h"
#include "robot/spec_reader.h"
#include "core/symmetry.h"

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

// Volume, centre of mass and unit-density inertia (about the centre of mass) of solids together.
MassProperties combined(const std::vector<MassProperties>& parts) {
  MassProperties all;
  Vec3 moment = Vec3::Zero();
  Mat3 second = Mat3::Zero();  // about the origin
  for (const MassProperties& mp : parts) {
    all.volume += mp.volume;
    moment += mp.volume * mp.centroid;
    // Parallel axis to the origin: I_o = I_c + V (|c|^2 1 - c c^T).
    second += mp.inertia + mp.volume * (mp.centroid.squaredNorm() * Mat3::Identity() - mp.centroid * mp.centroid.transpose());
  }
  all.centroid = moment / all.volume;
  all.inertia = second - all.volume * (all.centroid.squaredNorm() * Mat3::Identity() - all.centroid * all.centroid.transpose());
  return all;
}

// Mass properties summed over pieces count an overlap twice: pieces must only touch (as a convex
// decomposition's do). A vertex of one strictly inside another (deeper than 0.1 mm) is an overlap.
void checkNoOverlap(const std::vector<ConvexHull>& hulls, const std::vector<std::string>& names) {
  for (size_t i = 0; i < hulls.size(); ++i)
    for (size_t j = 0; j < hulls.size(); ++j) {
      if (i == j) continue;
      std::vector<std::pair<Vec3, double>> planes;
      for (const auto& f : hulls[j].faces) {
        const Vec3 a = hulls[j].vertices[static_cast<size_t>(f[0])], b = hulls[j].vertices[static_cast<size_t>(f[1])],
                   c = hulls[j].vertices[static_cast<size_t>(f[2])];
        const Vec3 n = (b - a).cross(c - a);
        if (n.norm() > 1e-15) planes.push_back({n.normalized(), n.normalized().dot(a)});
      }
      for (const Vec3& v : hulls[i].vertices) {
        double worst = -INFINITY;
        for (const auto& [n, d] : planes) worst = std::max(worst, n.dot(v) - d);
        if (worst < -1e-4)
          throw InputError(names[i], "overlaps " + names[j] + " by " + std::to_string(-1000 * worst) +
                                         " mm: convex pieces must only touch, or their volume counts twice (give the mass "
                                         "properties instead: a URDF's <inertial>)");
      }
    }
}

// The solid MuJoCo is given: the collision hulls as convex pieces and the visual mesh, all moved
// so that the hulls' bounding box is centred on the object's frame; the mass properties (centre
// of mass in the file's frame, inertia about it for the kind's mass) moved along.
std::shared_ptr<const ObjectSolid> makeSolid(const std::vector<ConvexHull>& hulls, const std::vector<TriangleMesh>& visual, double volume,
                                             const Vec3& com, const Mat3& inertia) {
  auto solid = std::make_shared<ObjectSolid>();
  Vec3 lower = hulls.front().lower, upper = hulls.front().upper;
  for (const ConvexHull& h : hulls) lower = lower.cwiseMin(h.lower), upper = upper.cwiseMax(h.upper);
  const Vec3 centre = (lower + upper) / 2;
  for (const TriangleMesh& part : visual) {
    const int base = static_cast<int>(solid->visual_vertices.size());
    for (const Vec3& v : part.vertices) solid->visual_vertices.push_back(v - centre);
    for (const auto& f : part.faces) solid->visual_faces.push_back({f[0] + base, f[1] + base, f[2] + base});
  }
  solid->volume = volume;
  solid->com = com - centre;
  solid->inertia = inertia;
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

void checkMass(double mass, const std::string& what) {
  if (!(mass > 0 && mass < 100)) throw InputError(what, "a mass of " + std::to_string(mass) + " kg from the density and the volume is not sane");
}

// A mesh kind's solid: every part of the file must be a closed, outward-oriented solid of a sane
// size (MuJoCo 2.2 would load anything, and compute nonsense or crash on it); it collides as the
// capped convex hull of each part (an OBJ's groups are its convex pieces; one part: its hull); the
// mass properties are the parts' (MuJoCo 2.2's own mesh inertia is unreliable), at uniform density.
std::shared_ptr<const ObjectSolid> readSolid(const std::string& file, const Vec3& scale, int hull_vertices, double& mass, double density,
                                             const std::string& what) {
  return solidFromParts(readMeshParts(file, scale), hull_vertices, mass, density, what);
}

// A URDF kind's solid: its collision elements' capped hulls as the convex pieces; its visual
// meshes drawn (none: the hulls); its <inertial> as the maker gives it, else the hulls' at uniform
// density with the catalogue's mass or density.
std::shared_ptr<const ObjectSolid> urdfSolid(const UrdfObject& u, int hull_vertices, double& mass, double density, const std::string& what) {
  std::vector<ConvexHull> hulls;
  std::vector<TriangleMesh> as_meshes;
  std::vector<MassProperties> props;
  for (size_t k = 0; k < u.collision.size(); ++k) {
    hulls.push_back(cappedHull(u.collision[k], hull_vertices, u.collision_what[k]));
    TriangleMesh t;
    t.vertices = hulls.back().vertices;
    t.faces = hulls.back().faces;
    checkSolid(t, u.collision_what[k]);  // its size sane, its hull a solid
    props.push_back(massProperties(t));
    as_meshes.push_back(std::move(t));
  }
  const MassProperties all = combined(props);
  if (u.has_inertial) return makeSolid(hulls, u.visual.empty() ? as_meshes : u.visual, all.volume, u.com, u.inertia);
  checkNoOverlap(hulls, u.collision_what);
  if (mass <= 0) mass = density * all.volume;
  checkMass(mass, what);
  return makeSolid(hulls, u.visual.empty() ? as_meshes : u.visual, all.volume, all.centroid, all.inertia * (mass / all.volume));
}


// A file a catalogue names: relative to the catalogue's folder unless absolute.
std::string besideCatalogue(const std::string& catalogue, const std::filesystem::path& file) {
  return (file.is_absolute() ? file : std::filesystem::path(catalogue).parent_path() / file).lexically_normal().string();
}

}  // namespace

std::shared_ptr<const ObjectSolid> solidFromParts(const std::vector<TriangleMesh>& parts, int hull_vertices, double& mass,
                                                  double density, const std::string& what) {
  std::vector<MassProperties> props;
  std::vector<ConvexHull> hulls;
  std::vector<std::string> names;
  for (const TriangleMesh& part : parts) {
    names.push_back(what + (part.part.empty() ? "" : " (part '" + part.part + "')"));
    checkSolid(part, names.back());
    props.push_back(massProperties(part));
    hulls.push_back(cappedHull(part.vertices, hull_vertices, names.back()));
  }
  checkNoOverlap(hulls, names);
  const MassProperties all = combined(props);
  if (mass <= 0) mass = density * all.volume;
  checkMass(mass, what);
  return makeSolid(hulls, parts, all.volume, all.centroid, all.inertia * (mass / all.volume));
}

Vec3 boundingHalfSize(const ObjectSolid& solid) {
  Vec3 lo = Vec3::Constant(INFINITY), hi = -lo;
  for (const ConvexPiece& piece : *solid.pieces)
    for (const Vec3& v : piece.vertices) lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
  return (hi - lo) / 2;
}

// A mesh kind's declared symmetries: a list of {axis: [x, y, z], degrees: d}, each a rotation of
// the object's frame (its axes as the file's, its origin at the hull's bounding box's centre) that
// maps its visual mesh onto itself; closed into their group, every element checked against the
// mesh (each turned vertex within 0.1% of the object's size of a vertex).
std::vector<Mat3> readSymmetries(const spec_io::Reader& r, const YAML::Node& list, const ObjectKind& k) {
  const std::string what = "object kind '" + k.name + "': symmetries";
  if (!list.IsSequence() || list.size() == 0)
    throw InputError(r.at(list), what + " expects a list of rotations {axis: [x, y, z], degrees: d} that map the mesh onto itself");
  std::vector<Mat3> generators;
  for (const YAML::Node& g : list) {
    if (!g.IsMap() || !g["axis"] || !g["degrees"] || g.size() != 2)
      throw InputError(r.at(g), what + ": each entry expects {axis: [x, y, z], degrees: d}");
    const auto a = r.vec3(g, "axis");
    const Vec3 axis(a[0], a[1], a[2]);
    const double degrees = r.number(g, "degrees");
    if (!(axis.norm() > 1e-9) || !axis.allFinite()) throw InputError(r.at(g["axis"]), what + ": an axis expects a non-zero vector");
    if (!(degrees > 0 && degrees <= 180)) throw InputError(r.at(g["degrees"]), what + ": degrees expects an angle in (0, 180]");
    generators.push_back(Eigen::AngleAxisd(degrees * M_PI / 180, axis.normalized()).toRotationMatrix());
  }
  constexpr size_t kMaxGroup = 128;
  const std::vector<Mat3> group = symmetryGroup(generators, kMaxGroup + 1);
  if (group.size() > kMaxGroup)
    throw InputError(r.at(list), what + " generate more than " + std::to_string(kMaxGroup) + " rotations (expected a finite group: "
                                        "angles that divide a turn)");
  const double size = 2 * k.half_size.norm();
  for (const Mat3& S : group) {
    const double off = symmetryResidual(k.solid->visual_vertices, S);
    if (off > 1e-3 * size) {
      const Eigen::AngleAxisd aa(S);
      char buf[200];
      std::snprintf(buf, sizeof buf, ": the turn of %.1f degrees about (%.3f, %.3f, %.3f) does not map the mesh onto itself "
                    "(a vertex lands %.2f mm from any other)", aa.angle() * 180 / M_PI, aa.axis().x(), aa.axis().y(), aa.axis().z(), 1e3 * off);
      throw InputError(r.at(list), what + buf);
    }
  }
  return group;
}

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
          key != "scale" && key != "density" && key != "hull_vertices" && key != "urdf" && key != "symmetries")
        throw InputError(r.at(field.first), "object kind '" + k.name + "': unknown key '" + key +
                                                "' (expected shape, size, mass, friction, condim, rgba; a mesh: mesh, scale, mass or density, "
                                                "hull_vertices, symmetries; a URDF: urdf, hull_vertices, symmetries, and mass or density if it has no <inertial>)");
    }
    const std::string shape = r.text(n, "shape");
    const bool urdf = shape == "urdf";
    if (shape == "cylinder") k.shape = ObjectShape::kCylinder;
    else if (shape == "mesh" || urdf) k.shape = ObjectShape::kMesh;
    else if (shape != "box") throw InputError(r.at(n["shape"]), "object kind '" + k.name + "': shape '" + shape + "' is not supported (expected box, cylinder, mesh or urdf)");
    for (const char* key : {"mesh", "scale", "density", "hull_vertices", "symmetries"})
      if (n[key] && k.shape != ObjectShape::kMesh)
        throw InputError(r.at(n[key]), "object kind '" + k.name + "': '" + key + "' belongs to a mesh kind (shape: mesh)");
    for (const char* key : {"mesh", "scale"})
      if (n[key] && urdf) throw InputError(r.at(n[key]), "object kind '" + k.name + "': '" + key + "' comes from the URDF (its <mesh> elements)");
    if (n["urdf"] && !urdf) throw InputError(r.at(n["urdf"]), "object kind '" + k.name + "': 'urdf' belongs to a URDF kind (shape: urdf)");
    int hull_vertices = kDefaultHullVertices;
    if (n["hull_vertices"]) {
      const double h = r.number(n, "hull_vertices");
      if (!(h >= 8 && h <= 1000 && h == std::floor(h)))
        throw InputError(r.at(n["hull_vertices"]), "object kind '" + k.name + "': hull_vertices expects a whole number in [8, 1000]");
      hull_vertices = static_cast<int>(h);
    }
    if (urdf) {
      if (n["size"]) throw InputError(r.at(n["size"]), "object kind '" + k.name + "': a URDF kind's size comes from its file");
      k.mesh = besideCatalogue(path, r.text(n, "urdf"));
      try {
        const UrdfObject u = loadUrdfObject(k.mesh);
        if (u.has_inertial && (n["mass"] || n["density"]))
          throw InputError(k.mesh, "gives its own <inertial> (mass " + std::to_string(u.mass) + " kg): the catalogue gives no mass or density for it");
        if (!u.has_inertial && n["mass"].IsDefined() == n["density"].IsDefined())
          throw InputError(k.mesh, "has no <inertial>: the catalogue must give either mass [kg] or density [kg/m^3]");
        k.mass = u.has_inertial ? u.mass : n["mass"] ? r.positive(n, "mass") : 0;
        k.solid = urdfSolid(u, hull_vertices, k.mass, n["density"] ? r.positive(n, "density") : 0, k.mesh);
        k.sources.push_back(k.mesh);
        k.sources.insert(k.sources.end(), u.files.begin(), u.files.end());
      } catch (const InputError& e) {  // the URDF's fault, and where the catalogue names it
        throw InputError(r.at(n["urdf"]), "object kind '" + k.name + "': " + e.what());
      }
      k.half_size = boundingHalfSize(*k.solid);
    } else if (k.shape == ObjectShape::kMesh) {
      if (n["size"]) throw InputError(r.at(n["size"]), "object kind '" + k.name + "': a mesh kind's size comes from its file (use scale)");
      if (n["mass"].IsDefined() == n["density"].IsDefined())
        throw InputError(r.at(n), "object kind '" + k.name + "': a mesh kind expects either mass [kg] or density [kg/m^3]");
      k.mesh = besideCatalogue(path, r.text(n, "mesh"));
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
      k.mass = n["mass"] ? r.positive(n, "mass") : 0;
      const double density = n["density"] ? r.positive(n, "density") : 0;
      try {
        k.solid = readSolid(k.mesh, k.scale, hull_vertices, k.mass, density, k.mesh);
        k.sources = {k.mesh};
      } catch (const InputError& e) {  // the mesh's fault, and where the catalogue names it
        throw InputError(r.at(n["mesh"]), "object kind '" + k.name + "': " + e.what());
      }
      k.half_size = boundingHalfSize(*k.solid);
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
    if (const YAML::Node sym = n["symmetries"]) k.symmetries = readSymmetries(r, sym, k);
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
