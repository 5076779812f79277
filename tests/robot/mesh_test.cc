// Collision meshes: STL (binary, ASCII) and OBJ read alike; their convex hull; a URDF robot with a
// mesh link collides as that hull in FCL, in the sphere cover (conservatively) and in MuJoCo.
#include "robot/mesh.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "../campaign/cli_helpers.h"
#include "core/error.h"
#include "core/rng.h"
#include "planning/collision.h"
#include "robot/description_writer.h"
#include "sim/mjcf_robot.h"
#include "sim/sim_world.h"

namespace mm {
namespace {

using ::testing::HasSubstr;
using testing_cli::readTrials;
using testing_cli::runMinimanip;
using testing_cli::TempDir;
namespace fs = std::filesystem;

// The twelve triangles of an axis-aligned box of half sizes h (and one point inside, for OBJ).
std::vector<std::array<Vec3, 3>> boxTriangles(const Vec3& h) {
  std::vector<Vec3> c;
  for (int k = 0; k < 8; ++k) c.push_back(Vec3((k & 1) ? h.x() : -h.x(), (k & 2) ? h.y() : -h.y(), (k & 4) ? h.z() : -h.z()));
  const int f[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                        {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  std::vector<std::array<Vec3, 3>> t;
  for (const auto& tri : f) t.push_back({c[tri[0]], c[tri[1]], c[tri[2]]});
  return t;
}

void writeBinaryStl(const fs::path& p, const std::vector<std::array<Vec3, 3>>& tris) {
  std::ofstream o(p, std::ios::binary);
  char header[80] = "solid but binary: the header may say anything";
  o.write(header, 80);
  const uint32_t n = static_cast<uint32_t>(tris.size());
  o.write(reinterpret_cast<const char*>(&n), 4);
  for (const auto& t : tris) {
    float v[12] = {0, 0, 0};
    for (int k = 0; k < 3; ++k)
      for (int a = 0; a < 3; ++a) v[3 + 3 * k + a] = static_cast<float>(t[k][a]);
    o.write(reinterpret_cast<const char*>(v), 48);
    const uint16_t attr = 0;
    o.write(reinterpret_cast<const char*>(&attr), 2);
  }
}

void writeAsciiStl(const fs::path& p, const std::vector<std::array<Vec3, 3>>& tris) {
  std::ofstream o(p);
  o << "solid box\n";
  for (const auto& t : tris) {
    o << "  facet normal 0 0 0\n    outer loop\n";
    for (const Vec3& v : t) o << "      vertex " << v.x() << " " << v.y() << " " << v.z() << "\n";
    o << "    endloop\n  endfacet\n";
  }
  o << "endsolid box\n";
}

// A prism of `n` sides around z (radius r to its corners, length L), centred: as OBJ.
void writePrismObj(const fs::path& p, double r, double L, int n) {
  std::ofstream o(p);
  o << "# a " << n << "-sided prism\n";
  for (int k = 0; k < n; ++k)
    for (double z : {-L / 2, L / 2}) o << "v " << r * std::cos(2 * M_PI * k / n) << " " << r * std::sin(2 * M_PI * k / n) << " " << z << "\n";
  o << "v 0 0 0\n";  // inside: not a hull vertex
  for (int k = 0; k < n; ++k) o << "f " << 2 * k + 1 << " " << 2 * ((k + 1) % n) + 1 << " " << 2 * k + 2 << "\n";
}

void expectBoxHull(const ConvexHull& h, const Vec3& half) {
  EXPECT_EQ(h.vertices.size(), 8u);
  EXPECT_EQ(h.faces.size(), 12u);
  EXPECT_TRUE(h.lower.isApprox(-half, 1e-6));
  EXPECT_TRUE(h.upper.isApprox(half, 1e-6));
  for (const auto& f : h.faces) {  // counter-clockwise from outside: the normal points away from the centre
    const Vec3 a = h.vertices[f[0]], b = h.vertices[f[1]], c = h.vertices[f[2]];
    EXPECT_GT((b - a).cross(c - a).dot((a + b + c) / 3), 0.0);
  }
}

TEST(Mesh, BinaryAndAsciiStlAndObjGiveTheSameHull) {
  TempDir d;
  const Vec3 h(0.05, 0.03, 0.02);
  writeBinaryStl(d.path() / "box.stl", boxTriangles(h));
  writeAsciiStl(d.path() / "ascii.STL", boxTriangles(h));
  std::ofstream(d.path() / "box.obj") << "v -0.05 -0.03 -0.02\nv 0.05 -0.03 -0.02\nv -0.05 0.03 -0.02\nv 0.05 0.03 -0.02\n"
                                         "v -0.05 -0.03 0.02\nv 0.05 -0.03 0.02\nv -0.05 0.03 0.02\nv 0.05 0.03 0.02\nv 0 0 0.01\n"
                                         "vt 0.5 0.5\nvn 0 0 1\nf 1 2 3\n";
  for (const char* f : {"box.stl", "ascii.STL", "box.obj"}) {
    SCOPED_TRACE(f);
    expectBoxHull(convexHull(readMeshVertices((d.path() / f).string()), f), h);
  }
  // Scaled as a URDF's <mesh scale>.
  const ConvexHull s = convexHull(readMeshVertices((d.path() / "box.obj").string(), Vec3(2, 1, 0.5)), "scaled");
  EXPECT_TRUE(s.upper.isApprox(Vec3(0.1, 0.03, 0.01), 1e-12));
}

TEST(Mesh, UnreadableFlatOrOtherFormatsAreInputErrorsNamingTheFile) {
  TempDir d;
  const std::string missing = (d.path() / "none.stl").string();
  EXPECT_THAT([&] { readMeshVertices(missing); }, ::testing::ThrowsMessage<InputError>(HasSubstr(missing)));
  const std::string ply = d.file("part.ply", "ply\n");
  EXPECT_THAT([&] { readMeshVertices(ply); }, ::testing::ThrowsMessage<InputError>(HasSubstr("STL or OBJ")));
  const std::string flat = d.file("flat.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 0.5 0.5 0\n");
  EXPECT_THAT([&] { convexHull(readMeshVertices(flat), flat); }, ::testing::ThrowsMessage<InputError>(HasSubstr("spans no volume")));
  const std::string bad = d.file("bad.obj", "v 0 0\n");
  EXPECT_THAT([&] { readMeshVertices(bad); }, ::testing::ThrowsMessage<InputError>(HasSubstr(bad + ":1")));
}

// The Panda's URDF with link 6's main body (a cylinder r 5.5 cm, 6 cm long) as an OBJ octagonal
// prism around it (faces 5.5 cm from the axis, corners 5.95 cm), the rest as it is.
struct MeshPanda {
  TempDir dir;
  std::string urdf;
  MeshPanda() {
    writePrismObj(dir.path() / "link6_body.obj", 0.055 / std::cos(M_PI / 8), 0.06, 8);  // circumscribes the cylinder
    std::stringstream ss;
    ss << std::ifstream("robots/panda/panda.urdf").rdbuf();
    std::string text = ss.str();
    const std::string cyl = R"(<origin xyz="0 0 -0.01" rpy="0 0 0"/>
      <geometry><cylinder radius="0.055" length="0.06"/></geometry>)";
    const size_t at = text.find(cyl, text.find("<link name=\"panda_link6\""));
    if (at == std::string::npos) throw std::runtime_error("panda.urdf changed: link 6's body cylinder not found");
    text.replace(at, cyl.size(), R"(<origin xyz="0 0 -0.01" rpy="0 0 0"/>
      <geometry><mesh filename="link6_body.obj"/></geometry>)");
    urdf = (dir.path() / "panda_mesh.urdf").string();
    std::ofstream(urdf) << text;
    std::string side;
    std::stringstream ys;
    ys << std::ifstream("robots/panda/panda.urdf.yaml").rdbuf();
    side = ys.str();
    const std::string g = "gripper: ../grippers/panda_hand.yaml";
    side.replace(side.find(g), g.size(), "gripper: " + fs::absolute("robots/grippers/panda_hand.yaml").string());
    std::ofstream(urdf + ".yaml") << side;
  }
};

TEST(Mesh, AUrdfMeshLinkCollidesAsItsHullInFclTheSpheresAndMujoco) {
  MeshPanda p;
  const RobotModel robot = loadAnyRobot(p.urdf);
  int hulls = 0;
  for (const CollisionShape& s : robot.collisionShapes())
    if (s.type == CollisionShape::Type::kConvex) {
      ++hulls;
      EXPECT_EQ(s.hull->vertices.size(), 16u);
      EXPECT_EQ(robot.links()[s.link].name, "panda_link6");
    }
  ASSERT_EQ(hulls, 1);

  // FCL at the hull: a 2 mm cube towards a corner of the prism, outside the cylinder it replaces
  // (56-58 mm from the axis; the corner is at 59.5 mm) collides; one at 61-63 mm does not.
  std::vector<Pose> T;
  robot.linkPoses(robot.home(), 0.04, T);
  const Pose T6 = T[robot.linkIndex("panda_link6")];
  auto cubeAt = [&](double radial) {
    PlanningScene scene;
    Obstacle o;
    o.size = Vec3::Constant(0.001);
    o.T_world = makePose(T6 * Vec3(0, -radial, -0.01), Mat3::Identity());  // beside the body, away from the hand's side (+x)
    o.name = "probe";
    scene.obstacles.push_back(o);
    return scene;
  };
  EXPECT_FALSE(makeChecker("fcl", robot, cubeAt(0.057), 0.0)->isValid(robot.home()));
  EXPECT_TRUE(makeChecker("fcl", robot, cubeAt(0.062), 0.0)->isValid(robot.home()));
  // Padded as the primitives are: 1 cm of padding reaches the far cube.
  EXPECT_FALSE(makeChecker("fcl", robot, cubeAt(0.062), 0.01)->isValid(robot.home()));

  // The sphere cover is conservative against FCL's hull: random configurations and boxes.
  Rng rng = Rng::stream(5, 0, Purpose::kPlanner);
  int fcl_hits = 0;
  for (int i = 0; i < 300; ++i) {
    VecX q(robot.dof());
    for (int j = 0; j < robot.dof(); ++j) q[j] = rng.uniform(robot.lower()[j], robot.upper()[j]);
    robot.linkPoses(q, 0.04, T);
    PlanningScene scene;
    Obstacle o;
    o.size = Vec3(rng.uniform(0.005, 0.03), rng.uniform(0.005, 0.03), rng.uniform(0.005, 0.03));
    o.T_world = makePose(T[robot.linkIndex("panda_link6")] * Vec3(rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1)),
                         Mat3(Eigen::AngleAxisd(rng.uniform(0, M_PI), Vec3(rng.normal(), rng.normal(), rng.normal()).normalized())));
    o.name = "box";
    scene.obstacles.push_back(o);
    const bool fcl_free = makeChecker("fcl", robot, scene, 0.0)->isValid(q);
    const bool spheres_free = makeChecker("spheres", robot, scene, 0.0)->isValid(q);
    if (!fcl_free) {
      ++fcl_hits;
      EXPECT_FALSE(spheres_free) << "spheres missed an FCL collision at configuration " << i;
    }
  }
  EXPECT_GT(fcl_hits, 30);

  // MuJoCo collides the same hull: the robot's MJCF holds it as a mesh asset of its 16 vertices.
  const std::string mjcf = writeMjcf(robot.spec());
  EXPECT_THAT(mjcf, HasSubstr("<mesh name=\"panda_link6_c0_hull\""));
  auto world = SimWorld::load("scenes/bin_table.xml", robot);
  EXPECT_GT(world->numObjects(), -1);
}

// The same link in the Panda's MJCF: link 6's body capsule as a mesh geom of that prism. The
// robot read from the MJCF takes MuJoCo's compiled vertices, and the hull sits where the MJCF put
// it in the link's frame.
struct MeshPandaMjcf {
  TempDir dir;
  std::string mjcf;
  MeshPandaMjcf() {
    writePrismObj(dir.path() / "link6_body.obj", 0.055 / std::cos(M_PI / 8), 0.06, 8);
    std::stringstream ss;
    ss << std::ifstream("robots/panda/panda.xml").rdbuf();
    std::string text = ss.str();
    const std::string compiler = "<compiler angle=\"radian\"/>";
    text.replace(text.find(compiler), compiler.size(), compiler + "\n  <asset><mesh name=\"link6_body\" file=\"link6_body.obj\"/></asset>");
    const std::string capsule = R"(type="capsule" fromto="0 0 -0.04 0 0 0.02" size="0.055")";
    const size_t at = text.find(capsule, text.find("panda_link6_c0"));
    if (at == std::string::npos) throw std::runtime_error("panda.xml changed: link 6's body capsule not found");
    text.replace(at, capsule.size(), R"(type="mesh" mesh="link6_body" pos="0 0 -0.01")");
    mjcf = (dir.path() / "panda_mesh.xml").string();
    std::ofstream(mjcf) << text;
    std::stringstream ys;
    ys << std::ifstream("robots/panda/panda.xml.yaml").rdbuf();
    std::string side = ys.str();
    const std::string g = "gripper: ../grippers/panda_hand.yaml";
    side.replace(side.find(g), g.size(), "gripper: " + fs::absolute("robots/grippers/panda_hand.yaml").string());
    std::ofstream(mjcf + ".yaml") << side;
  }
};

TEST(Mesh, AnMjcfMeshGeomCollidesAsItsHullWhereTheMjcfPutsIt) {
  MeshPandaMjcf p;
  const RobotModel robot = loadAnyRobot(p.mjcf);
  int hulls = 0;
  for (const CollisionShape& s : robot.collisionShapes()) {
    if (s.type != CollisionShape::Type::kConvex) continue;
    ++hulls;
    EXPECT_EQ(robot.links()[s.link].name, "panda_link6");
    EXPECT_EQ(s.hull->vertices.size(), 16u);
    double zmin = 1, zmax = -1, radial = 0;
    for (const Vec3& v : s.hull->vertices) {
      const Vec3 w = s.T_link_shape * v;
      zmin = std::min(zmin, w.z()), zmax = std::max(zmax, w.z()), radial = std::max(radial, w.head<2>().norm());
    }
    EXPECT_NEAR(zmin, -0.04, 1e-6);
    EXPECT_NEAR(zmax, 0.02, 1e-6);
    EXPECT_NEAR(radial, 0.055 / std::cos(M_PI / 8), 1e-6);
  }
  EXPECT_EQ(hulls, 1);
}

// The quickstart with that robot: the same success per trial as the Panda from its URDF, place
// errors within 0.2 mm (link 6 touches nothing in these trials).
TEST(Mesh, TheQuickstartWithAMeshLinkPlacesAsWithThePrimitive) {
  MeshPanda p;
  TempDir d;
  const std::string common = " --trials 3 --set progress=none --out ";
  ASSERT_EQ(runMinimanip("run experiments/quickstart.yaml --set robot=robots/panda/panda.urdf" + common + (d.path() / "a").string()).code, 0);
  const testing_cli::RunResult r = runMinimanip("run experiments/quickstart.yaml --set robot=" + p.urdf + common + (d.path() / "b").string());
  ASSERT_EQ(r.code, 0) << r.out;
  const auto a = readTrials(d.path() / "a"), b = readTrials(d.path() / "b");
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i]["success"], b[i]["success"]) << i;
    EXPECT_NEAR(a[i]["place_position_error"].get<double>(), b[i]["place_position_error"].get<double>(), 2e-4) << i;
  }
}

}  // namespace
}  // namespace mm
