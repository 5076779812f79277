// The object catalogue: the kinds of object a trial may put in the bin (a YAML file, by default
// scenes/objects.yaml). A trial's objects are drawn from the experiment's `objects.kinds` and
// composed into the model for that trial alone (sim/scene_compose.h), so nothing out of play is
// simulated.
#pragma once
#include <array>
#include <string>
#include <vector>

#include "core/geometry.h"

namespace mm {

/// One kind of object: a rigid box or cylinder (along its z) on a free joint.
struct ObjectKind {
  std::string name;
  ObjectShape shape = ObjectShape::kBox;
  Vec3 half_size = Vec3::Constant(0.025);                 ///< [m] box: half sizes; cylinder: (r, r, half height)
  double mass = 0.1;                                      ///< [kg]
  std::array<double, 3> friction{1.0, 0.02, 0.0001};     ///< MuJoCo's sliding, torsional, rolling
  int condim = 4;                                         ///< MuJoCo's contact dimensionality (1, 3, 4 or 6)
  std::array<double, 4> rgba{0.8, 0.8, 0.8, 1};           ///< the kind's colour, or the palette's by object
  bool has_rgba = false;                                  ///< the file gave the kind a colour
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

/// Reads a catalogue; throws InputError naming file:line:column for anything malformed.
ObjectCatalogue loadObjectCatalogue(const std::string& path);

}  // namespace mm
