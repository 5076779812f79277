// The object catalogue: the kinds of object a trial may put in the bin (a YAML file, by default
// scenes/objects.yaml). A trial's objects are drawn from the experiment's `objects.kinds` and
// composed into the model for that trial alone (sim/scene_compose.h), so nothing out of play is
// simulated.
#pragma once
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "core/geometry.h"

namespace mm {

struct TriangleMesh;  // robot/solid_mesh.h

/// A mesh kind's solid, in the object's frame (the file's axes, its origin moved to the centre of
/// the collision hull's bounding box): what MuJoCo is given for it.
struct ObjectSolid {
  std::shared_ptr<const std::vector<ConvexPiece>> pieces;  ///< collision: convex pieces (capped hulls)
  std::vector<Vec3> visual_vertices;                       ///< the visual mesh, as the file gives it
  std::vector<std::array<int, 3>> visual_faces;
  double volume = 0;                                       ///< [m^3] the file's solid
  Vec3 com = Vec3::Zero();                                 ///< [m] centre of mass (uniform density)
  Mat3 inertia = Mat3::Zero();                             ///< [kg m^2] about the centre of mass, for the kind's mass
};

/// One kind of object: a rigid box, cylinder (along its z) or mesh solid on a free joint.
struct ObjectKind {
  std::string name;
  ObjectShape shape = ObjectShape::kBox;
  Vec3 half_size = Vec3::Constant(0.025);                 ///< [m] box: half sizes; cylinder: (r, r, half height)
  double mass = 0.1;                                      ///< [kg]
  std::array<double, 3> friction{1.0, 0.02, 0.0001};     ///< MuJoCo's sliding, torsional, rolling
  int condim = 4;                                         ///< MuJoCo's contact dimensionality (1, 3, 4 or 6)
  std::array<double, 4> rgba{0.8, 0.8, 0.8, 1};           ///< the kind's colour, or the palette's by object
  bool has_rgba = false;                                  ///< the file gave the kind a colour
  std::string mesh;                                       ///< mesh kinds: the OBJ or STL file (its path); URDF kinds: the URDF
  std::vector<std::string> sources;                       ///< mesh and URDF kinds: every file read for it
  Vec3 scale = Vec3::Ones();                              ///< mesh kinds: the file's units to metres, per axis
  std::shared_ptr<const ObjectSolid> solid;               ///< mesh kinds: the solid read from the file
  std::string grade;                                      ///< a generated object's shape grade (sim/object_generator.h); "" for the catalogue's
  /// Mesh and URDF kinds: the rotations about the object's frame that map its visual mesh onto
  /// itself, declared (`symmetries`) and closed into their group, identity first (core/symmetry.h).
  std::vector<Mat3> symmetries{Mat3::Identity()};
};

struct ObjectCatalogue {
  std::string file;
  std::vector<ObjectKind> kinds;
  std::vector<std::array<double, 4>> palette;  ///< colours by object index for kinds without their own
  /// The kind named `name`, or nullptr.
  const ObjectKind* find(const std::string& name) const;
  /// The names of the kinds, in file order.
  std::vector<std::string> names() const;
  /// `kind` as object k of a trial: with the palette's k-th colour unless the kind has its own.
  ObjectKind asObject(const ObjectKind& kind, int k) const;
};

/// Hull vertices MuJoCo 2.2 is given per convex piece by default (it has no cap of its own; contacts
/// with a hull cost with its vertex count).
constexpr int kDefaultHullVertices = 64;

/// A solid from its parts, each a closed solid (checked; InputError naming `what` and the part),
/// colliding as its capped hull; the parts must only touch (their mass properties are summed). The
/// mass: `mass` if > 0, else density times the volume (written back to `mass`).
std::shared_ptr<const ObjectSolid> solidFromParts(const std::vector<TriangleMesh>& parts, int hull_vertices, double& mass,
                                                  double density, const std::string& what);

/// The half sizes of a solid's bounding box (its pieces' vertices, in its frame at their centre).
Vec3 boundingHalfSize(const ObjectSolid& solid);

/// Reads a catalogue; throws InputError naming file:line:column for anything malformed.
ObjectCatalogue loadObjectCatalogue(const std::string& path);

}  // namespace mm
