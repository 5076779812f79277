// Objects from mesh files: read, checked, composed into the trial's model (hull to collide, the
// file's mesh to draw, mass properties computed), simulated where their geometry says, grasped and
// placed; bad mesh kinds are exit 2 naming the file.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "../campaign/cli_helpers.h"
#include "../render/test_renderer.h"
#include "core/error.h"
#include "core/rng.h"
#include "render/renderer.h"
#include "sim/object_catalogue.h"
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

TEST(MeshObjects, CatalogueReadsTheirSolids) {
  const ObjectCatalogue c = loadObjectCatalogue("scenes/objects.yaml");
  const ObjectKind* hex = c.find("hex_prism");
  ASSERT_NE(hex, nullptr);
  ASSERT_EQ(hex->shape, ObjectShape::kMesh);
  // 45 mm across flats, 50 mm high: across corners (along y) 51.96 mm; the frame at the box's centre.
  EXPECT_NEAR(2 * hex->half_size.x(), 0.045, 1e-6);
  EXPECT_NEAR(2 * hex->half_size.y(), 0.045 / std::cos(M_PI / 6), 1e-6);
  EXPECT_NEAR(2 * hex->half_size.z(), 0.050, 1e-6);
  EXPECT_NEAR(hex->solid->volume, 6 * (0.045 / 2) * (0.045 / 2) * std::tan(M_PI / 6) * 0.050, 1e-9);
  EXPECT_LT(hex->solid->com.norm(), 1e-9) << "a prism's centre of mass is its box's centre";
  // The prism's inertia about its axis: m (5/12) a^2 for a regular hexagon of side a... checked
  // against the box-free formula for a hexagonal plate: Izz = (5/8) m R^2 (R: circumradius).
  const double R = 0.045 / 2 / std::cos(M_PI / 6);
  EXPECT_NEAR(hex->solid->inertia(2, 2), 5.0 / 12 * hex->mass * R * R, 1e-9);
  const ObjectKind* block = c.find("chamfered_block");
  ASSERT_NE(block, nullptr);
  EXPECT_NEAR(block->mass, 600 * block->solid->volume, 1e-12) << "its mass from its density";
  EXPECT_LT(block->solid->com.z(), 0) << "chamfered at the top: its centre of mass below its box's centre";
  const ObjectKind* wedge = c.find("wedge");
  ASSERT_NE(wedge, nullptr);
  EXPECT_NEAR(2 * wedge->half_size.x(), 0.070, 1e-6);
  EXPECT_EQ(wedge->solid->pieces->front().vertices.size(), 8u) << "a wedge's hull: its eight corners";
}

TEST(MeshObjects, RestOnTheFloorWhereTheirGeometrySays) {
  auto w = SimWorld::load("scenes/bin_large.xml", panda());
  const auto [T_bin, half] = w->site("bin_region");
  SpawnOptions o;
  o.kinds = {"hex_prism", "wedge", "chamfered_block"};
  o.count_min = o.count_max = 4;
  o.min_spacing = 0.05;
  o.min_gap = 0.06;
  o.resolve("(test)");
  Rng rng = Rng::stream(1, 0, Purpose::kScene);
  const SpawnResult r = spawnObjects(*w, panda(), T_bin, half, rng, o);
  ASSERT_TRUE(r.ok) << r.reason;
  const double floor = w->surfaceBelow(T_bin.translation() + Vec3(0, 0, 0.5), -1);
  for (int i : r.active) {
    const ObjectState s = w->object(i);
    ASSERT_EQ(s.shape, ObjectShape::kMesh);
    ASSERT_TRUE(s.pieces);
    // Upright on its flat bottom: the frame (its box's centre) half its height above the floor.
    EXPECT_NEAR(s.T_world_object.translation().z() - floor, s.half_size.z(), 0.002) << s.name;
    EXPECT_GT(s.T_world_object.linear()(2, 2), std::cos(2 * M_PI / 180)) << s.name;
    EXPECT_LT(w->objectVelocity(i).norm(), 1e-3) << s.name << " rocks on its face";
  }
  // Drawn where it collides, labelled as the object: the top face's centre (the prism's and the
  // block's tops are flat there) is the object's pixel, at the depth of the top; the wedge's
  // frame centre is inside it (so the pixel above it is the wedge's).
  w->updateKinematics();
  const CameraModel cam = testing_render::renderer().camera(*w, "overhead_camera", 640, 480, "(test)");
  const Frame f = testing_render::renderer().render(*w, cam, kDepth | kSegmentation);
  const ObjectCatalogue c = loadObjectCatalogue("scenes/objects.yaml");
  int checked = 0;
  for (int i : r.active) {
    const ObjectState s = w->object(i);
    const bool flat_top = std::abs(s.half_size.x() - c.find("wedge")->half_size.x()) > 1e-9;
    const Vec3 top = s.T_world_object * Vec3(0, 0, flat_top ? s.half_size.z() : 0.0);
    const Vec3 px = cam.project(top);
    const size_t at = static_cast<size_t>(std::lround(px.y())) * static_cast<size_t>(cam.width) + static_cast<size_t>(std::lround(px.x()));
    EXPECT_EQ(f.segmentation.at(at), 2 + i) << s.name;
    if (flat_top) {
      EXPECT_NEAR(f.depth.at(at), px.z(), 0.002) << s.name;
      ++checked;
    }
  }
  EXPECT_GE(checked, 1);
}

// An OBJ's groups are the convex pieces it collides as: a cube set on the lower half of a step
// block, against the step, rests there flat, 25 mm up (the block's hull fills the step with a
// slope: the cube would start 2 cm deep in it and be thrown out).
TEST(MeshObjects, CollideAsTheirConvexPieces) {
  const ObjectCatalogue c = loadObjectCatalogue("scenes/objects.yaml");
  const ObjectKind* step = c.find("step_block");
  ASSERT_NE(step, nullptr);
  ASSERT_EQ(step->solid->pieces->size(), 2u);
  EXPECT_NEAR(step->solid->volume, 0.06 * 0.04 * 0.025 + 0.03 * 0.04 * 0.025, 1e-12);
  EXPECT_NEAR(step->solid->com.x(), -(0.03 * 0.04 * 0.025 * 0.015) / step->solid->volume, 1e-9) << "the step's mass on the -x half";
  auto w = SimWorld::load("scenes/bin_large.xml", panda());
  const auto [T_bin, half] = w->site("bin_region");
  w->setObjects({c.asObject(*step, 0), c.asObject(*c.find("cube_5cm"), 1)});
  const double floor = T_bin.translation().z();
  const Vec3 centre = T_bin.translation();
  w->setObjectPose(0, makePose(centre + Vec3(0, 0, 0.025), Mat3::Identity()));
  w->setObjectPose(1, makePose(centre + Vec3(0.0255, 0, 0.025 + 0.025 + 0.0005), Mat3::Identity()));
  EXPECT_LT(w->objectPenetration(1), 1e-9) << "set down clear of the step";
  const VecX q = w->armPositions();
  for (int s = 0; s < 750; ++s) w->stepServo(q, VecX::Zero(q.size()), VecX::Zero(q.size()), 0.04, 0);
  const ObjectState cube = w->object(1), block = w->object(0);
  // MuJoCo 2.2's own convex collider gives a box on a mesh one contact point, and the cube sank
  // 2.6 mm in. With the contacts spread over the face they share it sits 0.7 mm low: 0.25 mm the
  // block in the floor, the rest its soft contacts, the edge nearer its centre of mass bearing more.
  EXPECT_NEAR(cube.T_world_object.translation().z(), floor + 0.025 + 0.025, 0.001) << "the cube rests on the lower step";
  EXPECT_NEAR(cube.T_world_object.translation().x(), centre.x() + 0.0255, 0.001) << "where it was set";
  EXPECT_GT(cube.T_world_object.linear()(2, 2), std::cos(2 * M_PI / 180)) << "flat";
  EXPECT_NEAR(block.T_world_object.translation().z(), floor + 0.025, 0.001);
  EXPECT_LT(w->objectPenetration(1), 0.0005);
}

// A URDF object: the maker's inertial used as given, its mesh collided and drawn; primitives
// (box, cylinder, sphere) as convex pieces; bad object URDFs are exit 2 naming the file.
TEST(MeshObjects, UrdfObjectsAsTheirMakersGiveThem) {
  const ObjectCatalogue c = loadObjectCatalogue("scenes/objects.yaml");
  const ObjectKind* bar = c.find("hex_bar_urdf");
  const ObjectKind* prism = c.find("hex_prism");
  ASSERT_NE(bar, nullptr);
  EXPECT_EQ(bar->shape, ObjectShape::kMesh);
  EXPECT_DOUBLE_EQ(bar->mass, 0.08);
  EXPECT_NEAR(bar->solid->inertia(2, 2), 2.25e-5, 1e-12) << "the URDF's, as given";
  EXPECT_TRUE(bar->half_size.isApprox(prism->half_size, 1e-9)) << "the same solid as the mesh kind";
  EXPECT_LT(bar->solid->com.norm(), 1e-9) << "its inertial's origin (25 mm up) is its box's centre";
  EXPECT_EQ(bar->sources.size(), 3u) << "the URDF and its two mesh references";
  auto w = SimWorld::load("scenes/bin_large.xml", panda());
  const auto [T_bin, half] = w->site("bin_region");
  w->setObjects({c.asObject(*bar, 0)});
  w->setObjectPose(0, makePose(T_bin.translation() + Vec3(0, 0, bar->half_size.z() + 0.001), Mat3::Identity()));
  const VecX q = w->armPositions();
  for (int s = 0; s < 300; ++s) w->stepServo(q, VecX::Zero(q.size()), VecX::Zero(q.size()), 0.04, 0);
  EXPECT_NEAR(w->object(0).T_world_object.translation().z() - T_bin.translation().z(), bar->half_size.z(), 0.001);
  EXPECT_NEAR(w->object(0).mass, 0.08, 1e-12);

  TempDir d;
  const std::string dir = d.path().string();
  auto urdf = [&](const std::string& name, const std::string& body) {
    std::ofstream(dir + "/" + name) << "<robot name=\"o\">" << body << "</robot>\n";
  };
  auto catalogue = [&](const std::string& kind) {
    std::ofstream(dir + "/objects.yaml") << "kinds:\n  thing:\n    shape: urdf\n" << kind;
    return loadObjectCatalogue(dir + "/objects.yaml");
  };
  // Primitives, no inertial: a can (cylinder) with a box lid, its mass from a density.
  urdf("can.urdf", "<link name=\"can\"><collision><geometry><cylinder radius=\"0.03\" length=\"0.08\"/></geometry></collision>"
                   "<collision><origin xyz=\"0 0 0.045\"/><geometry><box size=\"0.02 0.02 0.01\"/></geometry></collision></link>");
  const ObjectCatalogue cans = catalogue("    urdf: can.urdf\n    density: 1000\n");
  const ObjectKind& can = cans.kinds.front();
  ASSERT_EQ(can.solid->pieces->size(), 2u);
  EXPECT_NEAR(can.mass, 1000 * (M_PI * 0.03 * 0.03 * 0.08 * std::sin(M_PI / 16) * 16 / M_PI + 0.02 * 0.02 * 0.01), 1e-6)
      << "a 32-gon prism and the lid";
  EXPECT_NEAR(2 * can.half_size.z(), 0.08 / 2 + 0.045 + 0.005, 1e-9);
  auto rejected = [&](const std::string& kind, const std::string& says) {
    try {
      catalogue(kind);
      ADD_FAILURE() << "accepted: " << kind;
    } catch (const InputError& e) {
      EXPECT_THAT(e.what(), HasSubstr(says)) << kind;
    }
  };
  rejected("    urdf: can.urdf\n", "has no <inertial>");
  urdf("two.urdf", "<link name=\"a\"><collision><geometry><box size=\"0.05 0.05 0.05\"/></geometry></collision></link><link name=\"b\"/>"
                   "<joint name=\"j\" type=\"fixed\"><parent link=\"a\"/><child link=\"b\"/></joint>");
  rejected("    urdf: two.urdf\n    mass: 0.1\n", "exactly one link");
  urdf("massless.urdf", "<link name=\"m\"><inertial><mass value=\"0\"/><inertia ixx=\"1e-5\" iyy=\"1e-5\" izz=\"1e-5\" ixy=\"0\" "
                        "ixz=\"0\" iyz=\"0\"/></inertial><collision><geometry><box size=\"0.05 0.05 0.05\"/></geometry></collision></link>");
  rejected("    urdf: massless.urdf\n", "mass must be > 0");
  urdf("lopsided.urdf", "<link name=\"m\"><inertial><mass value=\"0.1\"/><inertia ixx=\"1e-5\" iyy=\"1e-5\" izz=\"5e-5\" ixy=\"0\" "
                        "ixz=\"0\" iyz=\"0\"/></inertial><collision><geometry><box size=\"0.05 0.05 0.05\"/></geometry></collision></link>");
  rejected("    urdf: lopsided.urdf\n", "not a body's");
  urdf("given.urdf", "<link name=\"m\"><inertial><mass value=\"0.1\"/><inertia ixx=\"4e-5\" iyy=\"4e-5\" izz=\"4e-5\" ixy=\"0\" "
                     "ixz=\"0\" iyz=\"0\"/></inertial><collision><geometry><box size=\"0.05 0.05 0.05\"/></geometry></collision></link>");
  EXPECT_DOUBLE_EQ(catalogue("    urdf: given.urdf\n").kinds.front().mass, 0.1);
  rejected("    urdf: given.urdf\n    mass: 0.2\n", "gives its own <inertial>");
  urdf("nomesh.urdf", "<link name=\"m\"><collision><geometry><mesh filename=\"package://nowhere/x.stl\"/></geometry></collision></link>");
  rejected("    urdf: nomesh.urdf\n    mass: 0.1\n", "cannot resolve 'package://nowhere/x.stl'");
  urdf("huge.urdf", "<link name=\"m\"><collision><geometry><box size=\"5 5 5\"/></geometry></collision></link>");
  rejected("    urdf: huge.urdf\n    mass: 0.1\n", "too large");
  urdf("overlap.urdf", "<link name=\"m\"><collision><geometry><box size=\"0.05 0.05 0.05\"/></geometry></collision>"
                       "<collision><origin xyz=\"0.02 0.01 0.01\"/><geometry><box size=\"0.05 0.05 0.05\"/></geometry></collision></link>");
  rejected("    urdf: overlap.urdf\n    density: 500\n", "overlaps");
}

TEST(MeshObjects, BadMeshKindsAreExitTwoNamingTheFile) {
  TempDir d;
  const std::string dir = d.path().string();
  // A cube with its top face missing: open.
  std::ofstream(dir + "/open.obj") << "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
                                      "f 1 4 3 2\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
  auto run = [&](const std::string& kind) {
    std::ofstream(dir + "/objects.yaml") << "kinds:\n  thing:\n" << kind;
    return runMinimanip("run experiments/mesh_objects.yaml --trials 1 --set progress=none --set objects.catalogue=" + dir +
                        "/objects.yaml --set objects.kinds=thing --out " + dir + "/out");
  };
  auto r = run("    shape: mesh\n    mesh: open.obj\n    scale: 0.05\n    mass: 0.1\n");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_THAT(r.out, HasSubstr("open.obj"));
  EXPECT_THAT(r.out, HasSubstr("open: edge"));
  r = run("    shape: mesh\n    mesh: missing.stl\n    mass: 0.1\n");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_THAT(r.out, HasSubstr("missing.stl"));
  r = run("    shape: mesh\n    mesh: " + std::string(std::filesystem::current_path() / "scenes/meshes/hex_prism.obj") + "\n    mass: 0.1\n");
  EXPECT_EQ(r.code, 2) << r.out;  // millimetres read as metres: 52 m across
  EXPECT_THAT(r.out, HasSubstr("0.001"));
  r = run("    shape: mesh\n    mesh: open.obj\n    mass: 0.1\n    density: 500\n");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_THAT(r.out, HasSubstr("either mass"));
  r = run("    shape: mesh\n    mesh: open.obj\n    size: [0.05, 0.05, 0.05]\n    mass: 0.1\n");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_THAT(r.out, HasSubstr("from its file"));
  // Declared symmetries the mesh does not have, or that generate no finite group.
  const std::string hex = std::string(std::filesystem::current_path() / "scenes/meshes/hex_prism.obj");
  r = run("    shape: mesh\n    mesh: " + hex + "\n    scale: 0.001\n    mass: 0.1\n    symmetries: [{axis: [0, 0, 1], degrees: 45}]\n");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_THAT(r.out, HasSubstr("objects.yaml:"));
  EXPECT_THAT(r.out, HasSubstr("does not map the mesh onto itself"));
  r = run("    shape: mesh\n    mesh: " + hex + "\n    scale: 0.001\n    mass: 0.1\n    symmetries: [{axis: [0, 0, 1], degrees: 59}]\n");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_THAT(r.out, HasSubstr("more than 128"));
  r = run("    shape: mesh\n    mesh: " + hex + "\n    scale: 0.001\n    mass: 0.1\n    symmetries: [{axis: [0, 0, 0], degrees: 60}]\n");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_THAT(r.out, HasSubstr("non-zero"));
}

}  // namespace
}  // namespace mm
namespace mm {
namespace {

// The campaign on mesh objects: picked and set down at the target's orientation, a yaw-offset
// grasp's included (its solid squared on the pads when they close on two parallel faces).
TEST(MeshObjects, PickedAndPlacedSquareInACampaign) {
  TempDir d;
  const testing_cli::RunResult r = runMinimanip("run experiments/mesh_objects.yaml --trials 8 --only 0,1,7 --set progress=none --out " +
                                                (d.path() / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  const auto trials = testing_cli::readTrials(d.path() / "out");
  ASSERT_EQ(trials.size(), 3u);
  int offset = 0;
  for (const auto& t : trials) {
    EXPECT_TRUE(t["success"].get<bool>()) << t.dump();
    EXPECT_EQ(t["grasps"].at(0)["shape"], "mesh");
    for (const auto& p : t["picks"]) {
      offset += p["grasp_candidates_tried"].get<int>() > 4;
      EXPECT_LT(p["orientation_error"].get<double>(), 2 * M_PI / 180) << p.dump();
    }
  }
  EXPECT_GE(offset, 1) << "no yaw-offset grasp in these trials: the test no longer tests it";
}

}  // namespace
}  // namespace mm
