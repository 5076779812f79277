// Unknown objects: a seeded procedural generator of solids a parallel gripper can hold, in grades
// of shape complexity (in the spirit of EGAD, Morrison et al. 2020: a set graded from simple convex
// solids to shapes that are hard to grasp), so that a campaign's objects are a set no one has seen
// (a seed no one has used) and yet reproducible from its seed. Every solid is built from convex
// pieces that only touch (collision as those pieces, mass properties exact), in the object's frame
// with z up and its flat base down (an "upright" object rests on it):
//   convex  one convex piece: a prism or a frustum on an irregular polygon, a box, or a pebble (an
//           ellipsoid's hull, its bottom cut flat)
//   blend   two or three convex pieces stacked, each on an irregular polygon, offset and turned
//   bent    a bar bent in its plane, its pieces mitred at the bends: an L, a U or a zigzag
//   hollow  a ring, a cup (a ring on a floor) or a channel (a floor with two walls)
// Every object is the same colour (depth, not colour, tells them apart); it has a piece at most
// max_width wide in some direction (the fingers close across it), and fits a place slot
// (max_extent).
#pragma once
#include <string>
#include <vector>

#include "core/config.h"
#include "core/rng.h"
#include "sim/object_catalogue.h"

namespace mm {

/// The grades, simplest first.
const std::vector<std::string>& shapeGrades();

struct ObjectSetOptions {
  /// Keys grades, density, max_width, max_extent (section "objects.generated").
  void declare(ConfigArchive& a);
  std::vector<std::string> grades;  ///< the grades a round draws from in equal shares; empty: the catalogue's kinds
  double density = 600;             ///< [kg/m^3]
  double max_width = 0.05;          ///< [m] every object has a piece at most this wide in some direction
  double max_extent = 0.08;         ///< [m] no side of its bounding box longer
  bool enabled() const { return !grades.empty(); }
};

/// One object of `grade` (one of shapeGrades()), its shape drawn from `rng`. Its kind's name is
/// "<grade>_<recipe>" (e.g. "bent_u"); ObjectKind::grade is the grade.
ObjectKind generateObject(const std::string& grade, Rng& rng, const ObjectSetOptions& options);

/// A round's `count` objects: the grades in turn from one drawn at random (equal shares over a
/// round, to within one), each object's shape drawn from its own stream of `seed`.
std::vector<ObjectKind> generateObjectSet(uint64_t seed, int count, const ObjectSetOptions& options);

}  // namespace mm
