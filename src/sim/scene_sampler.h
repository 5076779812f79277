// Seeded object placement: 1..N objects in the bin region without overlap, settled by the physics
// (MuJoCo hardware) or set at rest (mock). A spawn that interpenetrates, tips over or leaves the
// bin is rejected and resampled from the same stream. Or, dropped (`drop`): the objects fall into
// the bin from above in random orientations, in layers, and settle touching, leaning and stacked;
// a drop is rejected when an object comes to rest outside the bin or still moving.
#pragma once
#include <string>
#include <vector>

#include "core/config.h"
#include "core/rng.h"
#include "sim/object_catalogue.h"
#include "sim/object_generator.h"
#include "sim/sim_world.h"

namespace mm {

struct SpawnOptions {
  /// Keys count_min, count_max, catalogue, kinds, pool, wall_margin, min_spacing, min_gap, settle_time, drop,
  /// generated.* (section "objects").
  void declare(ConfigArchive& a);
  /// Loads `catalogue` (a relative path: against the project root) and checks `kinds` against it;
  /// throws InputError naming `file` (the experiment) for an unknown kind.
  void resolve(const std::string& file);
  int count_min = 1, count_max = 3;
  std::string catalogue = "scenes/objects.yaml";  ///< the object catalogue
  std::vector<std::string> kinds{"cube_5cm"};      ///< the catalogue's kinds a trial draws from
  ObjectSetOptions generated;                      ///< unknown objects generated per trial instead (when it has grades)
  int pool = 0;  ///< objects in the model, at least: out-of-play ones parked (today's pool, for benchmarks)
  ObjectCatalogue loaded;  ///< `catalogue` as read by resolve()
  bool drop = false;           ///< dropped from above in random orientations (physics only; mock: placed as without)
  double wall_margin = 0.07;   ///< [m] object centers keep this far from the region's edges
  double min_spacing = 0.11;   ///< [m] between object centers
  double min_gap = 0.0;        ///< [m] between the objects' outlines seen from above (0: min_spacing only)
  double settle_time = 0.3;    ///< [s] simulated settling (physics only)
  int max_attempts = 50;
  bool physics = true;
  double max_penetration = 0.002;  ///< [m] after settling
};

struct SpawnResult {
  bool ok = false;
  std::vector<int> active;  ///< object indices in play
  std::vector<std::string> grades;  ///< generated objects: each one's shape grade, by index (else empty)
  int attempts = 0;
  std::string reason;
};

/// The gap [m] between two upright objects' outlines seen from above (0 if they touch or overlap).
double outlineGap(ObjectShape shape_a, const Vec3& half_a, const Pose& T_a, ObjectShape shape_b, const Vec3& half_b, const Pose& T_b);

/// Draws the trial's objects (count, and kinds when there are several), makes the world's model hold
/// exactly those (SimWorld::setObjects; `pool` adds parked ones), resets it (arm at home) and places
/// them in `region` (a box site on the bin floor). Unresolved options are resolved on a copy.
SpawnResult spawnObjects(SimWorld& world, const RobotModel& robot, const Pose& T_region, const Vec3& region_half,
                         Rng& rng, const SpawnOptions& options);

}  // namespace mm
