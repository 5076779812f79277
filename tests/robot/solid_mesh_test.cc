// Objects from meshes: OBJ (groups, polygons, every face-entry form, negative indices) and STL
// (binary, ASCII) read into parts; mass properties against closed forms; what checkSolid rejects and
// says; a capped convex hull that stays close to the full one.
#include "robot/solid_mesh.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <set>

#include "core/error.h"

namespace mm {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
namespace fs = std::filesystem;

// A fresh folder under the temporary directory for one test, removed after it.
struct ScratchDir {
  fs::path path;
  ScratchDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path = fs::temp_directory_path() / ("solid_mesh_test_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~ScratchDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  std::string write(const std::string& name, const std::string& text) const {
    std::ofstream(path / name, std::ios::binary) << text;
    return (path / name).string();
  }
};

// The unit cube [0, 1]^3: corner k at (k & 1, k & 2, k & 4), and its six faces as quads wound
// counter-clockwise seen from outside.
Vec3 cubeCorner(int k) { return Vec3((k & 1) ? 1 : 0, (k & 2) ? 1 : 0, (k & 4) ? 1 : 0); }
const int kCubeQuads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};

// The unit cube as an OBJ: quads, 'v//vn' entries.
std::string cubeObj() {
  std::string s = "# a unit cube\n";
  for (int k = 0; k < 8; ++k) s += "v " + std::to_string(cubeCorner(k).x()) + " " + std::to_string(cubeCorner(k).y()) + " " + std::to_string(cubeCorner(k).z()) + "\n";
  s += "vn 0 0 -1\nvn 0 0 1\nvn 0 -1 0\nvn 0 1 0\nvn -1 0 0\nvn 1 0 0\n";
  for (int f = 0; f < 6; ++f) {
    s += "f";
    for (int c : kCubeQuads[f]) s += " " + std::to_string(c + 1) + "//" + std::to_string(f + 1);
    s += "\n";
  }
  return s;
}

// A cube of side `side` centred at the origin, as twelve outward triangles.
TriangleMesh cubeMesh(double side) {
  TriangleMesh m;
  for (int k = 0; k < 8; ++k) m.vertices.push_back((cubeCorner(k) - Vec3::Constant(0.5)) * side);
  for (const auto& q : kCubeQuads) {
    m.faces.push_back({q[0], q[1], q[2]});
    m.faces.push_back({q[0], q[2], q[3]});
  }
  return m;
}

void writeBinaryStl(const std::string& path, const TriangleMesh& m) {
  std::ofstream o(path, std::ios::binary);
  char header[80] = "solid, says the header, but the file is binary";
  o.write(header, 80);
  const uint32_t n = static_cast<uint32_t>(m.faces.size());
  o.write(reinterpret_cast<const char*>(&n), 4);
  for (const auto& f : m.faces) {
    float v[12] = {0, 0, 0};
    for (int k = 0; k < 3; ++k)
      for (int a = 0; a < 3; ++a) v[3 + 3 * k + a] = static_cast<float>(m.vertices[static_cast<size_t>(f[static_cast<size_t>(k)])][a]);
    o.write(reinterpret_cast<const char*>(v), 48);
    const uint16_t attribute = 0;
    o.write(reinterpret_cast<const char*>(&attribute), 2);
  }
}

void writeAsciiStl(const std::string& path, const TriangleMesh& m) {
  std::ofstream o(path);
  o << "solid cube\n";
  for (const auto& f : m.faces) {
    o << "  facet normal 0 0 0\n    outer loop\n";
    for (int v : f) o << "      vertex " << m.vertices[static_cast<size_t>(v)].x() << " " << m.vertices[static_cast<size_t>(v)].y() << " " << m.vertices[static_cast<size_t>(v)].z() << "\n";
    o << "    endloop\n  endfacet\n";
  }
  o << "endsolid cube\n";
}

void expectNear(const Mat3& a, const Mat3& b, double tolerance) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(a(i, j), b(i, j), tolerance) << "(" << i << ", " << j << ")";
}

std::string inputErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no InputError)";
}

TEST(SolidMesh, ObjCubeOfQuadsHasTheCubesMassProperties) {
  ScratchDir dir;
  const std::string path = dir.write("cube.obj", cubeObj());
  const std::vector<TriangleMesh> parts = readMeshParts(path);
  ASSERT_EQ(parts.size(), 1u);
  EXPECT_EQ(parts[0].part, "");
  EXPECT_EQ(parts[0].vertices.size(), 8u);
  EXPECT_EQ(parts[0].faces.size(), 12u);  // six quads, fanned
  EXPECT_NO_THROW(checkSolid(parts[0], path));
  const MassProperties p = massProperties(parts[0]);
  EXPECT_NEAR(p.volume, 1.0, 1e-12);
  EXPECT_TRUE(p.centroid.isApprox(Vec3(0.5, 0.5, 0.5), 1e-12)) << p.centroid.transpose();
  expectNear(p.inertia, Mat3::Identity() / 6, 1e-12);
  expectNear(inertiaWithMass(p, 3.0), Mat3::Identity() * 3.0 / 6, 1e-12);
}

TEST(SolidMesh, ScaleMultipliesEveryVertexPerAxis) {
  ScratchDir dir;
  const std::string path = dir.write("cube.obj", cubeObj());
  const MassProperties small = massProperties(readMeshParts(path, Vec3::Constant(0.05)).at(0));
  EXPECT_NEAR(small.volume, 1.25e-4, 1e-15);
  EXPECT_TRUE(small.centroid.isApprox(Vec3::Constant(0.025), 1e-12));
  expectNear(small.inertia, Mat3::Identity() * std::pow(0.05, 5) / 6, 1e-18);
  // A box 1 x 2 x 3: volume 6, Ixx = V (b^2 + c^2) / 12 = 6.5.
  const MassProperties box = massProperties(readMeshParts(path, Vec3(1, 2, 3)).at(0));
  EXPECT_NEAR(box.volume, 6.0, 1e-12);
  EXPECT_TRUE(box.centroid.isApprox(Vec3(0.5, 1.0, 1.5), 1e-12));
  expectNear(box.inertia, Vec3(6.5, 5.0, 2.5).asDiagonal().toDenseMatrix(), 1e-12);
}

TEST(SolidMesh, BinaryAndAsciiStlReadAlikeWelded) {
  ScratchDir dir;
  const TriangleMesh cube = cubeMesh(0.04);
  const std::string binary = (dir.path / "cube_binary.stl").string(), ascii = (dir.path / "cube_ascii.STL").string();
  writeBinaryStl(binary, cube);
  writeAsciiStl(ascii, cube);
  const std::vector<TriangleMesh> b = readMeshParts(binary), a = readMeshParts(ascii);
  ASSERT_EQ(b.size(), 1u);
  ASSERT_EQ(a.size(), 1u);
  for (const TriangleMesh* m : {&b[0], &a[0]}) {
    EXPECT_EQ(m->part, "");
    EXPECT_EQ(m->vertices.size(), 8u);  // 36 corners welded into 8
    EXPECT_EQ(m->faces.size(), 12u);
    EXPECT_NO_THROW(checkSolid(*m, "cube"));
  }
  EXPECT_EQ(a[0].faces, b[0].faces);
  for (size_t v = 0; v < 8; ++v) EXPECT_TRUE(a[0].vertices[v].isApprox(b[0].vertices[v], 1e-6)) << v;  // binary: float
  EXPECT_NEAR(massProperties(a[0]).volume, std::pow(0.04, 3), 1e-9);
  EXPECT_NEAR(massProperties(b[0]).volume, std::pow(0.04, 3), 1e-9);
  // Scaled too.
  EXPECT_NEAR(massProperties(readMeshParts(binary, Vec3::Constant(10)).at(0)).volume, std::pow(0.4, 3), 1e-6);
}

TEST(SolidMesh, ObjGroupsArePartsEachReindexed) {
  ScratchDir dir;
  // Two tetrahedra: the first's faces by negative (relative) indices before the second's vertices
  // exist, the second's by positive ones in the other entry forms; the second is twice the size.
  const std::string text =
      "mtllib parts.mtl\n"
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n"
      "vt 0 0\nvn 0 0 1\n"
      "o first\nusemtl red\ns off\n"
      "f -4 -2 -3\nf -4/1 -3/1 -1/1\nf -4//1 -1//1 -2//1\nf -3/1/1 -2/1/1 -1/1/1\n"
      "v 2 0 0\nv 4 0 0\nv 2 2 0\n"
      "v 2 0 \\\n 2\n"  // a continued line
      "g second  # a comment\n"
      "f 5/1 7/1 6/1\nf 5/1/1 6/1/1 8/1/1\nf 5 8 7\nf 6//1 7//1 8//1\n";
  const std::string path = dir.write("parts.obj", text);
  const std::vector<TriangleMesh> parts = readMeshParts(path);
  ASSERT_EQ(parts.size(), 2u);
  EXPECT_EQ(parts[0].part, "first");
  EXPECT_EQ(parts[1].part, "second");
  const std::vector<std::array<int, 3>> faces = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  for (const TriangleMesh& m : parts) {
    ASSERT_EQ(m.vertices.size(), 4u) << m.part;
    EXPECT_EQ(m.faces, faces) << m.part;
    EXPECT_NO_THROW(checkSolid(m, m.part, 0.005, 5.0));
  }
  EXPECT_TRUE(parts[1].vertices[3].isApprox(Vec3(2, 0, 2)));
  // The unit right tetrahedron: about its centroid (1/4, 1/4, 1/4), Ixx = 1/80 and Ixy = 1/480
  // (integrals of x^2 and x y over it: 1/60 and 1/120, less the centroid's share).
  const MassProperties tetra = massProperties(parts[0]);
  EXPECT_NEAR(tetra.volume, 1.0 / 6, 1e-12);
  EXPECT_TRUE(tetra.centroid.isApprox(Vec3::Constant(0.25), 1e-12));
  expectNear(tetra.inertia, Mat3::Constant(1.0 / 480) + Mat3::Identity() * (1.0 / 80 - 1.0 / 480), 1e-12);
  EXPECT_NEAR(massProperties(parts[1]).volume, 8.0 / 6, 1e-12);
  EXPECT_TRUE(massProperties(parts[1]).centroid.isApprox(Vec3(2.5, 0.5, 0.5), 1e-12));
  // A group named again adds to its part; a group with no faces is no part.
  const std::string again = dir.write("again.obj",
                                      "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\ng a\nf 1 3 2\nf 1 2 4\ng empty\ng b\nf 1 4 3\ng a\nf 2 3 4\n");
  const std::vector<TriangleMesh> ab = readMeshParts(again);
  ASSERT_EQ(ab.size(), 2u);
  EXPECT_EQ(ab[0].part, "a");
  EXPECT_EQ(ab[0].faces.size(), 3u);
  EXPECT_EQ(ab[1].part, "b");
  EXPECT_EQ(ab[1].vertices.size(), 3u);  // only the vertices its face uses
}

TEST(SolidMesh, ReadingRejectsBadFilesNamingThePlace) {
  ScratchDir dir;
  const std::string missing = (dir.path / "missing.obj").string();
  EXPECT_THAT(inputErrorOf([&] { readMeshParts(missing); }), HasSubstr(missing + ": cannot read"));
  const std::string ply = dir.write("cube.ply", "ply\n");
  EXPECT_THAT(inputErrorOf([&] { readMeshParts(ply); }), HasSubstr("STL or OBJ"));
  const std::string points = dir.write("points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
  EXPECT_THAT(inputErrorOf([&] { readMeshParts(points); }), HasSubstr(points + ": the mesh has no faces"));
  const std::string high = dir.write("high.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 4\n");
  EXPECT_THAT(inputErrorOf([&] { readMeshParts(high); }), HasSubstr(high + ":5: OBJ: vertex index 4 is out of range"));
  const std::string low = dir.write("low.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n");
  EXPECT_THAT(inputErrorOf([&] { readMeshParts(low); }), HasSubstr(low + ":4: OBJ: vertex index -4 is out of range"));
  const std::string zero = dir.write("zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n");
  EXPECT_THAT(inputErrorOf([&] { readMeshParts(zero); }), HasSubstr(zero + ":4:"));
  const std::string nan = dir.write("nan.obj", "v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n");
  EXPECT_THAT(inputErrorOf([&] { readMeshParts(nan); }), HasSubstr(nan + ":2: OBJ: a vertex coordinate that is not a finite number"));
  const std::string huge = dir.write("huge.obj", "v 0 0 0\nv 1 1e999 0\nv 0 1 0\nf 1 2 3\n");
  EXPECT_THAT(inputErrorOf([&] { readMeshParts(huge); }), HasSubstr(huge + ":2:"));
  const std::string tiny = dir.write("tiny.obj", "v 0 0 1e-999\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");  // underflow: 0
  EXPECT_EQ(readMeshParts(tiny).at(0).vertices[0], Vec3::Zero());
  const std::string word = dir.write("word.obj", "v 0 0 zero\n");
  EXPECT_THAT(inputErrorOf([&] { readMeshParts(word); }), HasSubstr(word + ":1: OBJ: 'zero' is not a number"));
  const std::string line = dir.write("line.obj", "v 0 0 0\nv 1 0 0\nf 1 2\n");
  EXPECT_THAT(inputErrorOf([&] { readMeshParts(line); }), HasSubstr(line + ":3: OBJ: a face needs at least three vertices"));
  const std::string empty_stl = dir.write("empty.stl", "solid nothing\nendsolid nothing\n");
  EXPECT_THAT(inputErrorOf([&] { readMeshParts(empty_stl); }), HasSubstr(empty_stl + ": the mesh has no faces"));
  const std::string nan_stl = dir.write("nan.stl", "solid t\nfacet normal 0 0 0\nouter loop\nvertex 0 0 0\nvertex inf 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n");
  EXPECT_THAT(inputErrorOf([&] { readMeshParts(nan_stl); }), HasSubstr(nan_stl + ":5: STL: a vertex coordinate that is not a finite number"));
  const std::string junk = dir.write("junk.stl", "not a mesh at all");
  EXPECT_THAT(inputErrorOf([&] { readMeshParts(junk); }), HasSubstr("not an STL file"));
}

TEST(SolidMesh, PrismOfManySidesHasTheCylindersMassProperties) {
  ScratchDir dir;
  const int n = 64;
  const double r = 0.03, h = 0.1;
  std::string s;
  for (int k = 0; k < n; ++k)
    for (double z : {0.0, h}) {
      char line[96];
      std::snprintf(line, sizeof line, "v %.17g %.17g %.17g\n", r * std::cos(2 * M_PI * k / n), r * std::sin(2 * M_PI * k / n), z);
      s += line;
    }
  // Corner k is at 2k + 1 (bottom) and 2k + 2 (top). Sides as quads, the ends as n-gons.
  for (int k = 0; k < n; ++k) {
    const int j = (k + 1) % n;
    s += "f " + std::to_string(2 * k + 1) + " " + std::to_string(2 * j + 1) + " " + std::to_string(2 * j + 2) + " " + std::to_string(2 * k + 2) + "\n";
  }
  s += "f";
  for (int k = n - 1; k >= 0; --k) s += " " + std::to_string(2 * k + 1);
  s += "\nf";
  for (int k = 0; k < n; ++k) s += " " + std::to_string(2 * k + 2);
  s += "\n";
  const TriangleMesh prism = readMeshParts(dir.write("prism.obj", s)).at(0);
  EXPECT_EQ(prism.faces.size(), static_cast<size_t>(2 * n + 2 * (n - 2)));
  EXPECT_NO_THROW(checkSolid(prism, "prism"));
  const MassProperties p = massProperties(prism);
  const double volume = M_PI * r * r * h;
  EXPECT_NEAR(p.volume, volume, 0.01 * volume);
  EXPECT_NEAR(p.centroid.norm() - h / 2, 0, 1e-12);
  EXPECT_NEAR(p.centroid.z(), h / 2, 1e-12);
  const double mass = 0.25;  // [kg]
  const Mat3 I = inertiaWithMass(p, mass);
  const double izz = mass * r * r / 2, ixx = mass * (3 * r * r + h * h) / 12;
  EXPECT_NEAR(I(2, 2), izz, 0.01 * izz);
  EXPECT_NEAR(I(0, 0), ixx, 0.01 * ixx);
  EXPECT_NEAR(I(1, 1), ixx, 0.01 * ixx);
  EXPECT_NEAR(I(0, 1), 0, 1e-6 * ixx);
  EXPECT_NEAR(I(0, 2), 0, 1e-6 * ixx);
  EXPECT_NEAR(I(1, 2), 0, 1e-6 * ixx);
  // Unit density: the tensor itself is the mass-volume one.
  EXPECT_NEAR(p.inertia(2, 2), volume * r * r / 2, 0.01 * volume * r * r / 2);
}

TEST(SolidMesh, CheckSolidAcceptsACubeAndNamesWhatIsWrong) {
  const TriangleMesh good = cubeMesh(0.05);
  EXPECT_NO_THROW(checkSolid(good, "cube"));

  TriangleMesh open = good;
  const std::array<int, 3> removed = open.faces.back();
  open.faces.pop_back();
  std::set<std::pair<int, int>> removed_edges;
  for (int k = 0; k < 3; ++k) removed_edges.insert({std::min(removed[k], removed[(k + 1) % 3]), std::max(removed[k], removed[(k + 1) % 3])});
  const auto [a, b] = *removed_edges.begin();
  const std::string open_msg = inputErrorOf([&] { checkSolid(open, "cube"); });
  EXPECT_THAT(open_msg, HasSubstr("cube: open: edge between vertices " + std::to_string(a) + " ("));
  EXPECT_THAT(open_msg, HasSubstr(" and " + std::to_string(b) + " ("));
  EXPECT_THAT(open_msg, HasSubstr("belongs to 1 face (and 2 more such edges)"));

  TriangleMesh inside_out = good;
  for (auto& f : inside_out.faces) std::swap(f[1], f[2]);
  EXPECT_THAT(inputErrorOf([&] { checkSolid(inside_out, "cube"); }), HasSubstr("cube: inside out"));

  TriangleMesh flipped = good;
  std::swap(flipped.faces[5][1], flipped.faces[5][2]);
  const std::string flipped_msg = inputErrorOf([&] { checkSolid(flipped, "cube"); });
  EXPECT_THAT(flipped_msg, HasSubstr("cube: inconsistently oriented: faces "));
  EXPECT_THAT(flipped_msg, HasSubstr(" and 5 both run from vertex"));

  TriangleMesh crowded = good;  // a fin on the cube's edge between corners 0 and 1
  crowded.vertices.push_back(Vec3(0, -0.05, -0.05));
  crowded.faces.push_back({0, 1, 8});
  EXPECT_THAT(inputErrorOf([&] { checkSolid(crowded, "cube"); }), HasSubstr("cube: non-manifold: edge between vertices 0 (-0.025, -0.025, -0.025) and 1 (0.025, -0.025, -0.025) belongs to 3 faces"));

  TriangleMesh degenerate = good;
  degenerate.faces[3] = {2, 2, 7};
  EXPECT_THAT(inputErrorOf([&] { checkSolid(degenerate, "cube"); }), HasSubstr("cube: degenerate: face 3 (vertices 2, 2, 7)"));

  TriangleMesh triangle;
  triangle.vertices = {Vec3(0, 0, 0), Vec3(0.1, 0, 0), Vec3(0, 0.1, 0)};
  triangle.faces = {{0, 1, 2}, {0, 2, 1}};
  EXPECT_THAT(inputErrorOf([&] { checkSolid(triangle, "sheet"); }), HasSubstr("sheet: a solid needs at least 4 vertices and 4 faces, the mesh has 3 vertices and 2 faces"));

  TriangleMesh bad_index = good;
  bad_index.faces[0][2] = 8;
  EXPECT_THAT(inputErrorOf([&] { checkSolid(bad_index, "cube"); }), HasSubstr("face 0 refers to vertex 8"));
}

TEST(SolidMesh, CheckSolidSaysTheSizeAndSuggestsMillimetresOnlyWhenTheyFit) {
  const std::string two_m = inputErrorOf([] { checkSolid(cubeMesh(2.0), "box.stl"); });
  EXPECT_THAT(two_m, HasSubstr("box.stl: 2 m wide (its bounding box's largest side) is too large for an object: expected 0.005 to 1 m"));
  EXPECT_THAT(two_m, Not(HasSubstr("scale 0.001")));  // 2 mm would be too small
  const std::string in_mm = inputErrorOf([] { checkSolid(cubeMesh(25.0), "box.stl"); });
  EXPECT_THAT(in_mm, HasSubstr("25 m wide"));
  EXPECT_THAT(in_mm, HasSubstr("did you mean scale 0.001 (a file in millimetres)? It would be 0.025 m wide"));
  const std::string tiny = inputErrorOf([] { checkSolid(cubeMesh(0.001), "box.stl"); });
  EXPECT_THAT(tiny, HasSubstr("box.stl: 0.001 m wide (its bounding box's largest side) is too small for an object: expected 0.005 to 1 m"));
  EXPECT_THAT(tiny, HasSubstr("at 1000 times the scale it would be 1 m wide"));
  EXPECT_THAT(inputErrorOf([] { checkSolid(cubeMesh(0.002), "box.stl", 0.005, 1.0); }), Not(HasSubstr("1000 times")));  // 2 m: too large
  EXPECT_NO_THROW(checkSolid(cubeMesh(2.0), "box.stl", 0.005, 2.5));
  // The bounding box's largest side counts: a 0.002 x 0.002 x 0.3 rod is fine.
  TriangleMesh rod = cubeMesh(1.0);
  for (Vec3& v : rod.vertices) v = v.cwiseProduct(Vec3(0.002, 0.002, 0.3));
  EXPECT_NO_THROW(checkSolid(rod, "rod"));
}

// Signed distance of `p` outside the hull: the largest over its faces' planes (positive outside).
double outside(const ConvexHull& h, const Vec3& p) {
  double d = -HUGE_VAL;
  for (const auto& f : h.faces) {
    const Vec3 &a = h.vertices[static_cast<size_t>(f[0])], &b = h.vertices[static_cast<size_t>(f[1])], &c = h.vertices[static_cast<size_t>(f[2])];
    d = std::max(d, (b - a).cross(c - a).normalized().dot(p - a));
  }
  return d;
}

double hullVolume(const ConvexHull& h) { return massProperties(TriangleMesh{"", h.vertices, h.faces}).volume; }

TEST(SolidMesh, CappedHullKeepsFewVerticesCloseToTheFullHull) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  const double radius = 0.04;
  std::vector<Vec3> points;
  while (points.size() < 2000) {
    const Vec3 p(u(rng), u(rng), u(rng));
    if (p.norm() > 0.1 && p.norm() <= 1) points.push_back(radius * p.normalized());
  }
  const ConvexHull full = convexHull(points, "sphere");
  ASSERT_GT(full.vertices.size(), 1000u);
  const ConvexHull capped = cappedHull(points, 64, "sphere");
  EXPECT_LE(capped.vertices.size(), 64u);
  EXPECT_GE(capped.vertices.size(), 60u);
  EXPECT_GE(hullVolume(capped), 0.9 * hullVolume(full)) << hullVolume(capped) / hullVolume(full);
  double worst = 0;
  for (const Vec3& p : points) worst = std::max(worst, outside(capped, p));
  EXPECT_LE(worst, 0.1 * radius);
  // Sampling starts at the largest x.
  const Vec3 east = *std::max_element(points.begin(), points.end(), [](const Vec3& a, const Vec3& b) { return a.x() < b.x(); });
  EXPECT_TRUE(std::find(capped.vertices.begin(), capped.vertices.end(), east) != capped.vertices.end());
  // Deterministic, and the points decide, not their order.
  const ConvexHull again = cappedHull(points, 64, "sphere");
  EXPECT_EQ(again.vertices, capped.vertices);
  EXPECT_EQ(again.faces, capped.faces);
  std::vector<Vec3> shuffled = points;
  std::shuffle(shuffled.begin(), shuffled.end(), rng);
  const ConvexHull reordered = cappedHull(shuffled, 64, "sphere");
  auto key = [](const std::vector<Vec3>& v) {
    std::set<std::array<double, 3>> s;
    for (const Vec3& p : v) s.insert({p.x(), p.y(), p.z()});
    return s;
  };
  EXPECT_EQ(key(reordered.vertices), key(capped.vertices));
}

TEST(SolidMesh, CappedHullOfFewVerticesIsTheFullHull) {
  TriangleMesh cube = cubeMesh(0.05);
  cube.vertices.push_back(Vec3::Zero());  // inside
  const ConvexHull h = cappedHull(cube.vertices, 8, "cube");
  EXPECT_EQ(h.vertices.size(), 8u);
  EXPECT_NEAR(hullVolume(h), 1.25e-4, 1e-15);
  // Capped at 4 of a cube's 8 corners: corner 1 (the largest x, the lowest index of four), the
  // opposite corner 6, then of the six at equal distance the lowest indices, 0 and 2.
  const ConvexHull four = cappedHull(cube.vertices, 4, "cube");
  std::set<std::array<double, 3>> kept, expected;
  for (const Vec3& v : four.vertices) kept.insert({v.x(), v.y(), v.z()});
  for (int k : {0, 1, 2, 6}) expected.insert({cube.vertices[k].x(), cube.vertices[k].y(), cube.vertices[k].z()});
  EXPECT_EQ(kept, expected);
  EXPECT_NEAR(hullVolume(four), 1.25e-4 / 6, 1e-15);
  EXPECT_THAT(inputErrorOf([&] { cappedHull(cube.vertices, 3, "cube"); }), HasSubstr("cube: a convex hull has at least 4 vertices, the cap is 3"));
}

}  // namespace
}  // namespace mm
