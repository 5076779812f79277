// The object catalogue and per-trial composition: a trial's model holds exactly the objects in
// play (nothing parked out of play unless a benchmark asks for the old pool), and bad catalogues,
// kinds and scenes that still hold objects are exit 2 naming the file.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <set>
#include <sstream>

#include "../campaign/cli_helpers.h"
#include "core/error.h"
#include "core/rng.h"
#include "sim/scene_sampler.h"
#include "sim/sim_world.h"

namespace mm {
namespace {

using ::testing::HasSubstr;
using testing_cli::runMinimanip;
using testing_cli::TempDir;

const RobotModel& panda() {
  static const RobotModel robot = RobotModel::load("robots/panda/panda.yaml");
  return robot;
}

TEST(ObjectCatalogue, TheComposedModelHoldsExactlyTheObjectsInPlay) {
  auto w = SimWorld::load("scenes/bin_table.xml", panda());
  EXPECT_EQ(w->numObjects(), 0);
  const auto [T_bin, half] = w->site("bin_region");
  SpawnOptions o;  // quickstart's: 1 to 3 cubes
  o.resolve("(test)");
  std::set<size_t> counts;
  for (uint64_t trial = 0; trial < 12; ++trial) {
    Rng rng = Rng::stream(1, trial, Purpose::kScene);
    const SpawnResult r = spawnObjects(*w, panda(), T_bin, half, rng, o);
    ASSERT_TRUE(r.ok) << r.reason;
    EXPECT_EQ(static_cast<size_t>(w->numObjects()), r.active.size()) << "trial " << trial;
    for (int i : r.active) {  // every object in the model is in the bin
      const Vec3 local = T_bin.inverse() * w->object(i).T_world_object.translation();
      EXPECT_LT(std::abs(local.x()), half.x());
      EXPECT_LT(std::abs(local.y()), half.y());
    }
    counts.insert(r.active.size());
  }
  EXPECT_EQ(counts.size(), 3u) << "seed 1 draws 1, 2 and 3 objects in its first trials";
  EXPECT_EQ(w->modelsCompiled(), 4) << "the empty model it was loaded with, then one per object list, kept";

  // The old parked pool, kept for benchmarks: six objects, those out of play resting at object_park.
  o.pool = 6;
  Rng rng = Rng::stream(1, 0, Purpose::kScene);
  const SpawnResult r = spawnObjects(*w, panda(), T_bin, half, rng, o);
  ASSERT_TRUE(r.ok);
  ASSERT_EQ(w->numObjects(), 6);
  const auto [T_park, park_size] = w->site("object_park");
  for (int i = static_cast<int>(r.active.size()); i < 6; ++i) {
    const Vec3 p = w->object(i).T_world_object.translation();
    EXPECT_NEAR(p.z(), T_park.translation().z() + 0.025, 0.002) << "object " << i << " rests on the floor";
    EXPECT_LT((p - T_park.translation()).head<2>().norm(), 0.6) << "object " << i;
  }
}

TEST(ObjectCatalogue, ObjectsTakeTheirKindsSizeMassAndThePalettesColours) {
  TempDir d;
  const std::string file = d.file("objects.yaml",
                                  "kinds:\n  slab:\n    shape: box\n    size: [0.06, 0.04, 0.02]\n    mass: 0.25\n"
                                  "    friction: [0.7, 0.01, 0.0001]\n    condim: 3\npalette:\n  - [1, 0, 0, 1]\n  - [0, 0, 1, 1]\n");
  const ObjectCatalogue c = loadObjectCatalogue(file);
  ASSERT_EQ(c.names(), std::vector<std::string>{"slab"});
  const ObjectKind second = c.asObject(*c.find("slab"), 3);
  EXPECT_EQ(second.rgba[2], 1.0) << "object 3 takes palette colour 3 mod 2";
  auto w = SimWorld::load("scenes/bin_table.xml", panda(), {c.asObject(*c.find("slab"), 0), second});
  ASSERT_EQ(w->numObjects(), 2);
  EXPECT_TRUE(w->object(1).half_size.isApprox(Vec3(0.03, 0.02, 0.01)));
}

// A cylinder kind becomes a MuJoCo cylinder geom, read back as a cylinder with its bounding half sizes.
TEST(ObjectCatalogue, ACylinderKindIsSimulatedAsACylinder) {
  TempDir d;
  const std::string file = d.file("can.yaml", "kinds:\n  can:\n    shape: cylinder\n    size: [0.05, 0.05, 0.12]\n    mass: 0.2\n");
  const ObjectCatalogue c = loadObjectCatalogue(file);
  ASSERT_EQ(c.kinds.size(), 1u);
  EXPECT_EQ(c.kinds[0].shape, ObjectShape::kCylinder);
  auto w = SimWorld::load("scenes/bin_table.xml", panda(), {c.asObject(c.kinds[0], 0)});
  const ObjectState o = w->object(0);
  EXPECT_EQ(o.shape, ObjectShape::kCylinder);
  EXPECT_TRUE(o.half_size.isApprox(Vec3(0.025, 0.025, 0.06)));
  EXPECT_NEAR(o.mass, 0.2, 1e-12);
}

TEST(ObjectCatalogue, BadCataloguesKindsAndScenesAreExitTwoNamingTheFile) {
  TempDir d;
  const std::string ball = d.file("ball.yaml", "kinds:\n  ball:\n    shape: sphere\n    size: [0.05, 0.05, 0.05]\n    mass: 0.2\n");
  try {
    loadObjectCatalogue(ball);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr(ball + ":3:"));
    EXPECT_THAT(e.what(), HasSubstr("expected box, cylinder, mesh or urdf"));
  }
  const std::string oval = d.file("oval.yaml", "kinds:\n  can:\n    shape: cylinder\n    size: [0.05, 0.04, 0.1]\n    mass: 0.2\n");
  try {
    loadObjectCatalogue(oval);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr(oval + ":4:"));
    EXPECT_THAT(e.what(), HasSubstr("[diameter, diameter, height]"));
  }
  const std::string neg = d.file("neg.yaml", "kinds:\n  c:\n    shape: box\n    size: [0.05, -0.05, 0.05]\n    mass: 0.2\n");
  EXPECT_THROW(loadObjectCatalogue(neg), InputError);
  const std::string typo = d.file("typo.yaml", "kinds:\n  c:\n    shape: box\n    size: [0.05, 0.05, 0.05]\n    mas: 0.2\n");
  EXPECT_THROW(loadObjectCatalogue(typo), InputError);

  const std::string exp = std::string(MINIMANIP_SOURCE_DIR) + "/experiments/quickstart.yaml --trials 1 --set hardware=mock --out " +
                          (d.path() / "o").string();
  testing_cli::RunResult r = runMinimanip("run " + exp + " --set objects.kinds=cube_5cm,sphere");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_THAT(r.out, HasSubstr("'sphere' is not in the catalogue"));
  r = runMinimanip("run " + exp + " --set objects.catalogue=" + ball);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_THAT(r.out, HasSubstr(ball + ":3:"));

  // A scene that still holds an object pool.
  std::stringstream s;
  s << std::ifstream("scenes/bin_table.xml").rdbuf();
  std::string xml = s.str();
  xml.replace(xml.find("</worldbody>"), 12,
              "<body name=\"object_0\"><freejoint/><geom type=\"box\" size=\"0.02 0.02 0.02\"/></body>\n</worldbody>");
  const std::string scene = d.file("pool.xml", xml);
  try {
    SimWorld::load(scene, panda());
    FAIL();
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr(scene + ":"));
    EXPECT_THAT(e.what(), HasSubstr("objects come from the object catalogue"));
  }
}

}  // namespace
}  // namespace mm
