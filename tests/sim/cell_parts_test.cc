// Static cell parts from URDF files: a scene's <include file="part.urdf"/> in a body welded to the
// world becomes the link's geoms there. The table, bin and tray of scenes/bin_table.xml as URDF
// parts (scenes/bin_table_urdf.xml) make the same cell for MuJoCo and the planner; a campaign runs
// in it; bad parts are exit 2 naming the file.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "../campaign/cli_helpers.h"
#include "core/error.h"
#include "robot/robot_model.h"
#include "robot/urdf_object.h"
#include "sim/sim_world.h"

namespace mm {
namespace {

using ::testing::HasSubstr;
using testing_cli::readTrials;
using testing_cli::runMinimanip;
using testing_cli::TempDir;

const RobotModel& panda() {
  static const RobotModel robot = RobotModel::load("robots/panda/panda.yaml");
  return robot;
}

std::vector<Vec3> corners(const Obstacle& o) {
  std::vector<Vec3> v;
  for (int k = 0; k < 8; ++k)
    v.push_back(o.T_world * Vec3((k & 1) ? o.size.x() : -o.size.x(), (k & 2) ? o.size.y() : -o.size.y(), (k & 4) ? o.size.z() : -o.size.z()));
  return v;
}

// The same box: each corner of one is a corner of the other (whatever their axes' order and signs).
bool sameBox(const Obstacle& a, const Obstacle& b) {
  if (a.type != Obstacle::Type::kBox || b.type != Obstacle::Type::kBox) return false;
  for (const Vec3& p : corners(a)) {
    bool found = false;
    for (const Vec3& q : corners(b)) found = found || (p - q).norm() < 1e-9;
    if (!found) return false;
  }
  return true;
}

std::string sceneText() {
  std::stringstream s;
  s << std::ifstream("scenes/bin_table_urdf.xml").rdbuf();
  return s.str();
}

TEST(CellParts, ATableBinAndTrayFromUrdfMakeTheSameCell) {
  const auto mjcf = SimWorld::load("scenes/bin_table.xml", panda());
  const auto urdf = SimWorld::load("scenes/bin_table_urdf.xml", panda());
  const std::vector<Obstacle> a = mjcf->staticObstacles(), b = urdf->staticObstacles();
  ASSERT_EQ(a.size(), b.size()) << "table, bin floor and walls, tray floor and walls: nothing drawn only";
  for (const Obstacle& o : a) {
    bool found = false;
    for (const Obstacle& p : b) found = found || sameBox(o, p);
    EXPECT_TRUE(found) << o.name << " has no twin among the URDF parts' geoms";
  }
  // The bin's OBJ groups (box-shaped) collide as MuJoCo's boxes, hidden under the drawn mesh.
  const mjModel* m = urdf->mujocoModel();
  for (int j = 0; j < 5; ++j) {
    const int g = mj_name2id(m, mjOBJ_GEOM, ("bin_collision_" + std::to_string(j)).c_str());
    ASSERT_GE(g, 0) << j;
    EXPECT_EQ(m->geom_type[g], mjGEOM_BOX) << j;
    EXPECT_EQ(m->geom_group[g], 3) << j;
    EXPECT_DOUBLE_EQ(m->geom_friction[3 * g], 0.5) << "the enclosing body's childclass 'bin'";
  }
  const int drawn = mj_name2id(m, mjOBJ_GEOM, "bin_visual_0");
  ASSERT_GE(drawn, 0);
  EXPECT_EQ(m->geom_type[drawn], mjGEOM_MESH);
  EXPECT_EQ(m->geom_contype[drawn] | m->geom_conaffinity[drawn], 0);
  EXPECT_FLOAT_EQ(m->geom_rgba[4 * drawn + 2], 0.7f) << "drawn in the bin's colour";
  // The tray gives no visual: its collision boxes are drawn.
  const int tray = mj_name2id(m, mjOBJ_GEOM, "tray_collision_0");
  ASSERT_GE(tray, 0);
  EXPECT_EQ(m->geom_group[tray], 0);
}

// A convex piece that is not a box (a hexagonal bar standing on the table as a post) collides as its
// hull; the planner knows it as a box around it, never smaller.
TEST(CellParts, ANonBoxPieceIsThePlannersBoxAroundIt) {
  const TempDir dir;
  std::string xml = sceneText();
  const std::string bar = std::filesystem::absolute("scenes/meshes/hex_bar.urdf").string();
  xml.replace(xml.find("    <!-- Regions"), 0, "    <body name=\"post\" pos=\"0.2 0.5 0\" euler=\"0 0 0.3\"><include file=\"" + bar + "\"/></body>\n");
  std::string scene = (dir.path() / "scene.xml").string();
  std::filesystem::copy("scenes/parts", dir.path() / "parts");
  std::ofstream(scene) << xml;
  const auto w = SimWorld::load(scene, panda());
  const mjModel* m = w->mujocoModel();
  const int g = mj_name2id(m, mjOBJ_GEOM, "post_collision_0");
  ASSERT_GE(g, 0);
  EXPECT_EQ(m->geom_type[g], mjGEOM_MESH);
  const UrdfObject u = loadUrdfObject(bar);
  const Pose T_post = makePose(Vec3(0.2, 0.5, 0), Mat3(Eigen::AngleAxisd(0.3, Vec3::UnitZ())));
  bool exported = false;
  for (const Obstacle& o : w->staticObstacles()) {
    if (o.name != "post_collision_0") continue;
    exported = true;
    ASSERT_EQ(o.type, Obstacle::Type::kBox);
    for (const Vec3& v : u.collision.front()) {
      const Vec3 p = o.T_world.inverse() * (T_post * v);
      EXPECT_TRUE((p.cwiseAbs() - o.size).maxCoeff() < 1e-6) << "a hull vertex outside the planner's box: " << p.transpose();
    }
    // Hexagonal: the box is larger than the bar, by at most its corners' share.
    EXPECT_LT(8 * o.size.prod(), 1.6 * 0.045 * 0.045 * std::sqrt(3.0) / 2 * 0.05);
  }
  EXPECT_TRUE(exported);
}

TEST(CellParts, BadCellPartsAreExitTwoNamingTheFile) {
  const TempDir dir;
  std::filesystem::copy("scenes/parts", dir.path() / "parts");
  auto rejected = [&](const std::string& from, const std::string& to, const std::string& urdf_name, const std::string& urdf,
                      const std::string& expected) {
    std::string xml = sceneText();
    ASSERT_NE(xml.find(from), std::string::npos) << from;
    xml.replace(xml.find(from), from.size(), to);
    const std::string scene = dir.file("scene.xml", xml);
    if (!urdf.empty()) dir.file(urdf_name, urdf);
    try {
      SimWorld::load(scene, panda());
      ADD_FAILURE() << "accepted: " << expected;
    } catch (const InputError& e) {
      EXPECT_THAT(e.what(), HasSubstr(expected));
      EXPECT_THAT(e.what(), HasSubstr("scene.xml:")) << "the scene's line that includes the part";
      EXPECT_THAT(e.what(), HasSubstr(urdf_name));
    }
  };
  rejected("<body name=\"tray\" pos=\"0.45 0.3 0\"", "<body name=\"tray\" pos=\"0.45 0.3 0\" mocap=\"true\"", "", "", "is static: body 'tray' moves");
  rejected("parts/tray.urdf", "parts/nowhere.urdf", "nowhere.urdf", "", "cannot read");
  rejected("parts/tray.urdf", "two.urdf", "two.urdf",
           "<robot name=\"two\"><link name=\"a\"><collision><geometry><box size=\"0.1 0.1 0.1\"/></geometry></collision></link>"
           "<link name=\"b\"/><joint name=\"j\" type=\"fixed\"><parent link=\"a\"/><child link=\"b\"/></joint></robot>",
           "exactly one link");
  rejected("parts/tray.urdf", "unscaled.urdf", "unscaled.urdf",
           "<robot name=\"u\"><link name=\"u\"><collision><geometry><mesh filename=\"parts/bin.obj\"/></geometry></collision></link></robot>",
           "too large");
  rejected("parts/tray.urdf", "nothing.urdf", "nothing.urdf", "<robot name=\"n\"><link name=\"n\"/></robot>", "at least one <collision>");
  // And a run stops before its first trial: exit 2, the file named.
  std::string xml = sceneText();
  xml.replace(xml.find("parts/tray.urdf"), 15, "nothing.urdf");
  const std::string scene = dir.file("scene.xml", xml);
  const auto r = runMinimanip("run experiments/quickstart.yaml --trials 1 --out " + (dir.path() / "run").string() + " --set scene=" + scene);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_THAT(r.out, HasSubstr("nothing.urdf"));
}

// A campaign's identity holds its scene's parts: a results folder made with one bin mesh does not
// resume with another.
TEST(CellParts, AChangedPartIsAnotherCampaign) {
  const TempDir dir;
  std::filesystem::copy("scenes/parts", dir.path() / "parts");
  const std::string scene = dir.file("scene.xml", sceneText());
  const std::string out = (dir.path() / "run").string();
  const std::string cmd = "run experiments/quickstart.yaml --set progress=none --set scene=" + scene + " --out " + out + " --trials ";
  ASSERT_EQ(runMinimanip(cmd + "1").code, 0);
  EXPECT_EQ(runMinimanip(cmd + "2").code, 0) << "the same cell resumes";
  std::ofstream(dir.path() / "parts" / "bin.obj", std::ios::app) << "# another bin\n";
  const auto r = runMinimanip(cmd + "3");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_THAT(r.out, HasSubstr("scene file contents differ"));
}

// The quickstart's cell with its parts from URDF: camera-mode trials clear the bin as in the MJCF
// cell, trial for trial.
TEST(CellParts, CameraTrialsRunInACellFromUrdf) {
  const TempDir dir;
  const std::string common = "run experiments/camera.yaml --trials 6 --set progress=none --set perception.camera_width=640 --set perception.camera_height=480";
  const auto a = runMinimanip(common + " --out " + (dir.path() / "mjcf").string());
  const auto b = runMinimanip(common + " --out " + (dir.path() / "urdf").string() + " --set scene=scenes/bin_table_urdf.xml");
  ASSERT_EQ(a.code, 0) << a.out;
  ASSERT_EQ(b.code, 0) << b.out;
  const auto ta = readTrials(dir.path() / "mjcf"), tb = readTrials(dir.path() / "urdf");
  ASSERT_EQ(ta.size(), 6u);
  ASSERT_EQ(tb.size(), 6u);
  for (size_t k = 0; k < ta.size(); ++k) {
    EXPECT_EQ(tb[k]["objects_placed"], ta[k]["objects_placed"]) << k;
    EXPECT_EQ(tb[k]["objects_in_bin"], ta[k]["objects_in_bin"]) << k;
    EXPECT_EQ(tb[k]["collision_count"], 0) << k;
  }
}

}  // namespace
}  // namespace mm
