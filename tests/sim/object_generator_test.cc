// Unknown objects: the generator's sets are reproducible from their seed, every grade in equal
// shares, every object a solid a parallel gripper can hold, built from pieces that only touch;
// generated objects settle in the bin (piled or upright) and bad parameters are exit 2.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <map>
#include <set>

#include <Eigen/Eigenvalues>

#include "../campaign/cli_helpers.h"
#include "core/rng.h"
#include "sim/object_generator.h"
#include "sim/scene_sampler.h"
#include "sim/sim_world.h"

namespace mm {
namespace {

using ::testing::HasSubstr;
using testing_cli::runMinimanip;
using testing_cli::TempDir;

ObjectSetOptions allGrades() {
  ObjectSetOptions o;
  o.grades = shapeGrades();
  return o;
}

// The least width of a convex piece: over directions, the extent of its vertices along it.
double leastWidth(const ConvexPiece& p) {
  double least = INFINITY;
  for (int i = 0; i < 24; ++i)
    for (int j = 0; j <= 12; ++j) {
      const double az = M_PI * i / 24, el = M_PI / 2 * j / 12;
      const Vec3 d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
      double lo = INFINITY, hi = -INFINITY;
      for (const Vec3& v : p.vertices) lo = std::min(lo, v.dot(d)), hi = std::max(hi, v.dot(d));
      least = std::min(least, hi - lo);
    }
  return least;
}

TEST(ObjectGenerator, ASetIsItsSeed) {
  const ObjectSetOptions o = allGrades();
  const std::vector<ObjectKind> a = generateObjectSet(7, 8, o), b = generateObjectSet(7, 8, o), c = generateObjectSet(8, 8, o);
  ASSERT_EQ(a.size(), 8u);
  int differ = 0;
  for (size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].name, b[k].name);
    EXPECT_EQ(a[k].solid->visual_vertices, b[k].solid->visual_vertices) << k;
    EXPECT_EQ(a[k].mass, b[k].mass);
    differ += a[k].solid->visual_vertices != c[k].solid->visual_vertices;
  }
  EXPECT_EQ(differ, 8) << "another seed, another set";
}

TEST(ObjectGenerator, EveryGradeInEqualSharesEveryRound) {
  const ObjectSetOptions o = allGrades();
  std::map<std::string, int> total;
  for (uint64_t seed = 1; seed <= 40; ++seed) {
    const int count = 5 + static_cast<int>(seed % 6);
    std::map<std::string, int> round;
    for (const ObjectKind& k : generateObjectSet(seed, count, o)) ++round[k.grade], ++total[k.grade];
    for (const std::string& g : shapeGrades()) {
      EXPECT_GE(round[g], count / 4) << seed;
      EXPECT_LE(round[g], (count + 3) / 4) << seed;
    }
  }
  for (const std::string& g : shapeGrades()) EXPECT_GT(total[g], 60) << g;
}

TEST(ObjectGenerator, EveryObjectIsASolidTheGripperCanHold) {
  ObjectSetOptions o = allGrades();
  std::map<std::string, std::set<std::string>> recipes;
  for (uint64_t seed = 1; seed <= 150; ++seed)
    for (const ObjectKind& k : generateObjectSet(seed, 8, o)) {
      SCOPED_TRACE(k.name + " of seed " + std::to_string(seed));
      recipes[k.grade].insert(k.name);
      ASSERT_EQ(k.shape, ObjectShape::kMesh);
      EXPECT_LE(2 * k.half_size.maxCoeff(), o.max_extent + 1e-9);
      EXPECT_GE(2 * k.half_size.minCoeff(), 0.004);
      EXPECT_NEAR(k.mass, o.density * k.solid->volume, 1e-12);
      EXPECT_GT(k.mass, 0.003);
      EXPECT_EQ(k.rgba, (std::array<double, 4>{0.55, 0.55, 0.58, 1}));
      const size_t pieces = k.solid->pieces->size();
      if (k.grade == "convex") {
        EXPECT_EQ(pieces, 1u);
      } else if (k.grade == "blend") {
        EXPECT_TRUE(pieces == 2 || pieces == 3);
      } else if (k.grade == "bent") {
        EXPECT_TRUE(pieces >= 2 && pieces <= 3);
      } else {
        EXPECT_EQ(k.grade, "hollow");
        EXPECT_GE(pieces, 3u);
      }
      double least = INFINITY;
      for (const ConvexPiece& p : *k.solid->pieces) least = std::min(least, leastWidth(p));
      EXPECT_LE(least, o.max_width + 1e-9) << "a piece the fingers can close across";
      // Inertia: positive definite, the triangle inequality of principal moments.
      const Eigen::Vector3d e = Eigen::SelfAdjointEigenSolver<Mat3>(k.solid->inertia).eigenvalues();
      EXPECT_GT(e(0), 0);
      EXPECT_LE(e(2), e(0) + e(1) + 1e-15);
    }
  EXPECT_EQ(recipes["convex"], (std::set<std::string>{"convex_box", "convex_frustum", "convex_pebble", "convex_prism"}));
  EXPECT_EQ(recipes["blend"], (std::set<std::string>{"blend_stack2", "blend_stack3"}));
  EXPECT_EQ(recipes["bent"], (std::set<std::string>{"bent_l", "bent_u", "bent_zigzag"}));
  EXPECT_EQ(recipes["hollow"], (std::set<std::string>{"hollow_channel", "hollow_cup", "hollow_ring"}));
}

const RobotModel& panda() {
  static const RobotModel robot = RobotModel::load("robots/panda/panda.yaml");
  return robot;
}

TEST(ObjectGenerator, RoundsSettleInTheBinPiledAndPacked) {
  auto w = SimWorld::load("scenes/bin_clearing.xml", panda());
  const auto [T_bin, half] = w->site("bin_region");
  for (const bool drop : {true, false}) {
    SpawnOptions o;
    o.generated = allGrades();
    o.count_min = 5, o.count_max = 10;
    o.drop = drop;
    o.settle_time = 2.0;
    o.wall_margin = drop ? 0.06 : 0.0;
    o.min_spacing = 0.05, o.min_gap = 0.008;
    for (int trial = 0; trial < 4; ++trial) {
      SCOPED_TRACE((drop ? "pile, trial " : "packed, trial ") + std::to_string(trial));
      Rng rng = Rng::stream(1, trial, Purpose::kScene);
      const SpawnResult r = spawnObjects(*w, panda(), T_bin, half, rng, o);
      ASSERT_TRUE(r.ok) << r.reason;
      EXPECT_GE(r.active.size(), 5u);
      EXPECT_LE(r.active.size(), 10u);
      for (int i : r.active) EXPECT_FALSE(w->object(i).pieces == nullptr) << "a mesh object: its pieces are its model";
    }
  }
}

TEST(ObjectGenerator, BadParametersAreExit2) {
  TempDir dir;
  for (const auto& [set, expect] : {std::pair<std::string, std::string>{"objects.generated.grades=convex,spiky", "spiky"},
                                    {"objects.generated.max_width=0.2", "max_width"},
                                    {"objects.generated.density=-1", "density"},
                                    {"objects.generated.grades=convex --set objects.generated.max_width=0.06 --set objects.generated.max_extent=0.05",
                                     "less than max_width"}}) {
    const auto r = runMinimanip("run experiments/quickstart.yaml --trials 1 --set progress=none --set " + set + " --out " +
                                (dir.path() / "x").string());
    EXPECT_EQ(r.code, 2) << set << "\n" << r.out;
    EXPECT_THAT(r.out, HasSubstr(expect)) << set;
  }
}

}  // namespace
}  // namespace mm
