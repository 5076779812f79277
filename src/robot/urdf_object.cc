#include "robot/urdf_object.h"

#include <urdf_parser/urdf_parser.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <cmath>
#include <fstream>
#include <sstream>

#include "core/error.h"
#include "robot/urdf_parse.h"

namespace mm {
namespace {

Pose toPose(const urdf::Pose& p) {
  double x, y, z, w;
  p.rotation.getQuaternion(x, y, z, w);
  return makePose(Vec3(p.position.x, p.position.y, p.position.z), Quat(w, x, y, z).normalized().toRotationMatrix());
}

std::vector<Vec3> boxPoints(const Vec3& half) {
  std::vector<Vec3> v;
  for (int k = 0; k < 8; ++k) v.emplace_back((k & 1) ? half.x() : -half.x(), (k & 2) ? half.y() : -half.y(), (k & 4) ? half.z() : -half.z());
  return v;
}

std::vector<Vec3> cylinderPoints(double r, double length) {
  std::vector<Vec3> v;
  for (int k = 0; k < 32; ++k)
    for (double z : {-length / 2, length / 2}) v.emplace_back(r * std::cos(k * M_PI / 16), r * std::sin(k * M_PI / 16), z);
  return v;
}

// An icosahedron with each edge's midpoint added, on the sphere: 42 points.
std::vector<Vec3> spherePoints(double r) {
  const double t = (1 + std::sqrt(5.0)) / 2;
  std::vector<Vec3> ico = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                           {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  std::vector<Vec3> v;
  for (const Vec3& p : ico) v.push_back(r * p.normalized());
  const double edge = 2.0;  // the icosahedron's edge length before normalising
  for (size_t i = 0; i < ico.size(); ++i)
    for (size_t j = i + 1; j < ico.size(); ++j)
      if (std::abs((ico[i] - ico[j]).norm() - edge) < 1e-9) v.push_back(r * (ico[i] + ico[j]).normalized());
  return v;
}

}  // namespace

UrdfObject loadUrdfObject(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, "cannot read the object's URDF");
  std::stringstream text;
  text << in.rdbuf();
  const auto model = parseUrdfText(text.str(), path);
  std::vector<urdf::LinkSharedPtr> links;
  model->getLinks(links);
  if (links.size() != 1)
    throw InputError(path, "an object's or cell part's URDF has exactly one link (one rigid body), this one has " + std::to_string(links.size()));
  const urdf::Link& l = *links.front();
  UrdfObject o;
  o.name = l.name;
  const std::string where = path + ": link '" + l.name + "'";
  const std::vector<std::string> dirs = urdfSearchDirs(path);
  auto meshParts = [&](const urdf::Mesh& me) {
    const std::string f = resolveUrdfMesh(me.filename, path, dirs, where, "ROS_PACKAGE_PATH and the folders above the URDF");
    o.files.push_back(f);
    try {
      return readMeshParts(f, Vec3(me.scale.x, me.scale.y, me.scale.z));
    } catch (const InputError& e) {
      throw InputError(where, e.what());
    }
  };
  for (const auto& c : l.collision_array) {
    if (!c || !c->geometry) continue;
    const Pose T = toPose(c->origin);
    std::vector<std::vector<Vec3>> pieces;
    std::string what;
    UrdfObject::Primitive primitive;
    primitive.T = T;
    switch (c->geometry->type) {
      case urdf::Geometry::BOX: {
        const auto& b = static_cast<const urdf::Box&>(*c->geometry);
        pieces.push_back(boxPoints(Vec3(b.dim.x, b.dim.y, b.dim.z) / 2));
        primitive.kind = UrdfObject::Primitive::Kind::kBox;
        primitive.size = Vec3(b.dim.x, b.dim.y, b.dim.z) / 2;
        what = "a box";
        break;
      }
      case urdf::Geometry::CYLINDER: {
        const auto& cy = static_cast<const urdf::Cylinder&>(*c->geometry);
        pieces.push_back(cylinderPoints(cy.radius, cy.length));
        primitive.kind = UrdfObject::Primitive::Kind::kCylinder;
        primitive.size = Vec3(cy.radius, cy.length / 2, 0);
        what = "a cylinder";
        break;
      }
      case urdf::Geometry::SPHERE:
        pieces.push_back(spherePoints(static_cast<const urdf::Sphere&>(*c->geometry).radius));
        primitive.kind = UrdfObject::Primitive::Kind::kSphere;
        primitive.size = Vec3(static_cast<const urdf::Sphere&>(*c->geometry).radius, 0, 0);
        what = "a sphere";
        break;
      case urdf::Geometry::MESH: {
        const auto& me = static_cast<const urdf::Mesh&>(*c->geometry);
        for (const TriangleMesh& part : meshParts(me)) pieces.push_back(part.vertices);
        what = "mesh '" + me.filename + "'";
        break;
      }
      default:
        continue;
    }
    for (auto& p : pieces) {
      for (Vec3& v : p) v = T * v;
      o.collision.push_back(std::move(p));
      o.collision_what.push_back(where + ", collision " + what);
      o.collision_primitive.push_back(primitive);
    }
  }
  if (o.collision.empty()) throw InputError(where, "an object or cell part needs at least one <collision> (a mesh, box, cylinder or sphere)");
  for (const auto& v : l.visual_array) {
    if (!v || !v->geometry || v->geometry->type != urdf::Geometry::MESH) continue;
    const Pose T = toPose(v->origin);
    for (TriangleMesh part : meshParts(static_cast<const urdf::Mesh&>(*v->geometry))) {
      for (Vec3& p : part.vertices) p = T * p;
      o.visual.push_back(std::move(part));
    }
  }
  if (l.inertial) {
    const auto& inert = *l.inertial;
    o.has_inertial = true;
    o.mass = inert.mass;
    const Pose T = toPose(inert.origin);
    o.com = T.translation();
    Mat3 I;
    I << inert.ixx, inert.ixy, inert.ixz, inert.ixy, inert.iyy, inert.iyz, inert.ixz, inert.iyz, inert.izz;
    o.inertia = T.linear() * I * T.linear().transpose();
    if (!(o.mass > 0) || !std::isfinite(o.mass)) throw InputError(where, "<inertial> mass must be > 0, got " + std::to_string(o.mass));
    // A body's principal moments are positive and each at most the sum of the other two.
    const Eigen::SelfAdjointEigenSolver<Mat3> eig(o.inertia);
    const Vec3 m = eig.eigenvalues();
    if (!o.inertia.allFinite() || !(m.minCoeff() > 1e-12) || m[2] > m[0] + m[1])
      throw InputError(where, "<inertial> inertia is not a body's (principal moments " + std::to_string(m[0]) + ", " + std::to_string(m[1]) +
                                  ", " + std::to_string(m[2]) + " kg m^2: each must be > 0 and at most the sum of the other two)");
  }
  return o;
}

}  // namespace mm
