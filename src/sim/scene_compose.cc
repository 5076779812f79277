#include "sim/scene_compose.h"

#include <tinyxml2.h>

#include <Eigen/Geometry>

#include <cmath>
#include <cstdio>
#include <algorithm>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <functional>
#include <set>

#include "core/error.h"
#include "core/pose.h"
#include "robot/description_writer.h"
#include "robot/solid_mesh.h"
#include "robot/urdf_object.h"
#include "sim/object_catalogue.h"

namespace mm {
namespace {

using tinyxml2::XMLDocument;
using tinyxml2::XMLElement;
using tinyxml2::XMLNode;

std::string at(const std::string& file, const XMLElement* e) { return file + ":" + std::to_string(e->GetLineNum()); }

void parseFile(XMLDocument& doc, const std::string& path) {
  if (doc.LoadFile(path.c_str()) != tinyxml2::XML_SUCCESS) {
    if (doc.ErrorID() == tinyxml2::XML_ERROR_FILE_NOT_FOUND || doc.ErrorID() == tinyxml2::XML_ERROR_FILE_COULD_NOT_BE_OPENED)
      throw InputError(path, "cannot open file (expected an MJCF scene)");
    throw InputError(path + ":" + std::to_string(doc.ErrorLineNum()), std::string("malformed XML: ") + doc.ErrorStr());
  }
  if (!doc.RootElement() || std::strcmp(doc.RootElement()->Name(), "mujoco") != 0)
    throw InputError(path, "expected an MJCF file (root element <mujoco>)");
}

void collectNames(const XMLElement* e, const char* element, std::vector<const XMLElement*>& out);

// The scene holds the world only: none of the robot's bodies (checked per file, for its lines).
void checkNoRobot(const XMLElement* root, const std::string& file, const std::set<std::string>& robot_names) {
  std::vector<const XMLElement*> bodies;
  collectNames(root, "body", bodies);
  for (const XMLElement* b : bodies)
    if (robot_names.count(b->Attribute("name")))
      throw InputError(at(file, b), std::string("body '") + b->Attribute("name") +
                                        "' belongs to the robot: a scene holds the world only (the harness mounts the robot)");
}

std::string vec3Text(const Vec3& v) {
  char buf[100];
  std::snprintf(buf, sizeof buf, "%.12g %.12g %.12g", v.x(), v.y(), v.z());
  return buf;
}

// A mesh's vertices for its <mesh vertex=".."> (9 digits: micrometres at a kilometre).
std::string verticesText(const std::vector<Vec3>& points) {
  std::string out;
  char v[100];
  for (const Vec3& p : points) {
    std::snprintf(v, sizeof v, "%.9g %.9g %.9g ", p.x(), p.y(), p.z());
    out += v;
  }
  return out;
}

std::string facesText(const std::vector<std::array<int, 3>>& faces) {
  std::string out;
  for (const auto& f : faces) out += std::to_string(f[0]) + " " + std::to_string(f[1]) + " " + std::to_string(f[2]) + " ";
  return out;
}

// A convex hull that is a box (six faces in three pairs of opposite, mutually orthogonal normals):
// its pose (the axes right-handed) and half sizes. False for any other hull.
bool hullBox(const ConvexHull& hull, Pose& T, Vec3& half) {
  std::vector<Vec3> normals;
  for (const auto& f : hull.faces) {
    const Vec3 a = hull.vertices[static_cast<size_t>(f[0])], b = hull.vertices[static_cast<size_t>(f[1])], c = hull.vertices[static_cast<size_t>(f[2])];
    const Vec3 n = (b - a).cross(c - a);
    if (n.norm() < 1e-15) continue;
    if (std::none_of(normals.begin(), normals.end(), [&](const Vec3& m) { return m.dot(n.normalized()) > 1 - 1e-9; }))
      normals.push_back(n.normalized());
  }
  if (normals.size() != 6) return false;
  std::vector<Vec3> axes;
  for (const Vec3& n : normals) {
    if (std::none_of(normals.begin(), normals.end(), [&](const Vec3& m) { return m.dot(n) < -1 + 1e-9; })) return false;
    if (std::none_of(axes.begin(), axes.end(), [&](const Vec3& a) { return std::abs(a.dot(n)) > 1 - 1e-9; })) axes.push_back(n);
  }
  if (axes.size() != 3 || std::abs(axes[0].dot(axes[1])) > 1e-9 || std::abs(axes[0].dot(axes[2])) > 1e-9 || std::abs(axes[1].dot(axes[2])) > 1e-9)
    return false;
  Mat3 R;
  R << axes[0], axes[1], axes[0].cross(axes[1]);
  Vec3 lo = Vec3::Constant(INFINITY), hi = -lo;
  for (const Vec3& v : hull.vertices) lo = lo.cwiseMin(R.transpose() * v), hi = hi.cwiseMax(R.transpose() * v);
  half = (hi - lo) / 2;
  T = makePose(R * (hi + lo) / 2, R);
  return true;
}

// A static cell part from a URDF file (a bin, a tray, a table, as PyBullet-era sets ship them):
// `include` (<include file="part.urdf"/> in <worldbody> or in a body without joints) becomes the
// link's geoms there, in the enclosing body's frame. Each collision element is a geom: a box,
// cylinder or sphere as MuJoCo's own, a mesh file's part (an OBJ's groups: its convex pieces) as
// its convex hull capped at kDefaultHullVertices (a box when the hull is one: a bin's wall), its
// size between 1 mm and 10 m. Each visual mesh is drawn (no contacts), and the
// collision geoms are then hidden (group 3); with none, the collision geoms are drawn. The geoms
// take no class of their own: the enclosing body's childclass gives them friction and colour.
// Named <prefix>_collision_<j> and <prefix>_visual_<j>, the prefix the enclosing body's name (the
// link's in <worldbody>).
void expandUrdfPart(XMLDocument& doc, XMLElement* include, const std::string& path, const std::string& where) {
  XMLElement* parent = include->Parent()->ToElement();
  const std::string pname = parent ? parent->Name() : "";
  if (pname != "worldbody" && pname != "body")
    throw InputError(where, "a URDF cell part goes in <worldbody> or a <body>, not in <" + pname + ">");
  for (const XMLElement* b = parent; b && std::strcmp(b->Name(), "body") == 0; b = b->Parent()->ToElement()) {
    const bool moves = b->BoolAttribute("mocap", false) || b->FirstChildElement("joint") || b->FirstChildElement("freejoint");
    if (moves)
      throw InputError(where, std::string("a URDF cell part is static: body '") + (b->Attribute("name") ? b->Attribute("name") : "") +
                                  "' moves (a joint, a free joint or mocap); include it in <worldbody> or a body welded to it");
  }
  UrdfObject part;
  try {
    part = loadUrdfObject(path);
  } catch (const InputError& e) {
    throw InputError(where, e.what());
  }
  const std::string prefix = pname == "body" && parent->Attribute("name") ? parent->Attribute("name") : part.name;
  XMLElement* asset = doc.RootElement()->InsertEndChild(doc.NewElement("asset"))->ToElement();
  XMLNode* after = include;
  auto add = [&](XMLElement* g) { after = parent->InsertAfterChild(after, g); };
  for (size_t j = 0; j < part.collision.size(); ++j) {
    UrdfObject::Primitive p = part.collision_primitive[j];
    const std::string name = prefix + "_collision_" + std::to_string(j);
    XMLElement* g = doc.NewElement("geom");
    g->SetAttribute("name", name.c_str());
    // Its size sane (a millimetre file without its scale is a 300 m bin).
    ConvexHull hull;
    try {
      hull = cappedHull(part.collision[j], kDefaultHullVertices, part.collision_what[j]);
      TriangleMesh solid;
      solid.vertices = hull.vertices;
      solid.faces = hull.faces;
      checkSolid(solid, part.collision_what[j], 0.001, 10.0);
    } catch (const InputError& e) {
      throw InputError(where, e.what());
    }
    // A mesh part that is a box (a bin's wall) collides as MuJoCo's box: exact for the planner, and
    // the cheapest contact there is.
    if (p.kind == UrdfObject::Primitive::Kind::kNone && hullBox(hull, p.T, p.size)) p.kind = UrdfObject::Primitive::Kind::kBox;
    if (p.kind == UrdfObject::Primitive::Kind::kNone) {
      XMLElement* mesh = asset->InsertNewChildElement("mesh");
      mesh->SetAttribute("name", name.c_str());
      mesh->SetAttribute("vertex", verticesText(hull.vertices).c_str());
      g->SetAttribute("type", "mesh");
      g->SetAttribute("mesh", name.c_str());
    } else {
      using Kind = UrdfObject::Primitive::Kind;
      char buf[120];
      if (p.kind == Kind::kBox) std::snprintf(buf, sizeof buf, "%.12g %.12g %.12g", p.size.x(), p.size.y(), p.size.z());
      else if (p.kind == Kind::kCylinder) std::snprintf(buf, sizeof buf, "%.12g %.12g", p.size.x(), p.size.y());
      else std::snprintf(buf, sizeof buf, "%.12g", p.size.x());
      g->SetAttribute("type", p.kind == Kind::kBox ? "box" : p.kind == Kind::kCylinder ? "cylinder" : "sphere");
      g->SetAttribute("size", buf);
      g->SetAttribute("pos", vec3Text(p.T.translation()).c_str());
      const Quat q(p.T.linear());
      std::snprintf(buf, sizeof buf, "%.12g %.12g %.12g %.12g", q.w(), q.x(), q.y(), q.z());
      g->SetAttribute("quat", buf);
    }
    if (!part.visual.empty()) g->SetAttribute("group", 3);
    add(g);
  }
  for (size_t j = 0; j < part.visual.size(); ++j) {
    const std::string name = prefix + "_visual_" + std::to_string(j);
    XMLElement* mesh = asset->InsertNewChildElement("mesh");
    mesh->SetAttribute("name", name.c_str());
    mesh->SetAttribute("vertex", verticesText(part.visual[j].vertices).c_str());
    mesh->SetAttribute("face", facesText(part.visual[j].faces).c_str());
    XMLElement* g = doc.NewElement("geom");
    g->SetAttribute("name", name.c_str());
    g->SetAttribute("type", "mesh");
    g->SetAttribute("mesh", name.c_str());
    g->SetAttribute("contype", 0);
    g->SetAttribute("conaffinity", 0);
    g->SetAttribute("group", 1);
    add(g);
  }
  parent->DeleteChild(include);
}

// Replaces each <include file=".."/> under `parent` by the included file's top-level children
// (MuJoCo's semantics), recursively; paths relative to the including file. A URDF file is a static
// cell part (expandUrdfPart).
void expandIncludes(XMLDocument& doc, XMLElement* parent, const std::string& file, int depth,
                    const std::set<std::string>& robot_names) {
  if (depth > 20) throw InputError(file, "<include> nested more than 20 deep (a cycle?)");
  for (XMLElement* e = parent->FirstChildElement(); e;) {
    XMLElement* next = e->NextSiblingElement();
    if (std::strcmp(e->Name(), "include") == 0) {
      const char* f = e->Attribute("file");
      if (!f) throw InputError(at(file, e), "<include> needs a 'file' attribute");
      const std::string path = (std::filesystem::path(file).parent_path() / f).lexically_normal().string();
      if (isUrdfPart(path)) {
        expandUrdfPart(doc, e, path, at(file, e));
        e = next;
        continue;
      }
      XMLDocument inc;
      parseFile(inc, path);
      checkNoRobot(inc.RootElement(), path, robot_names);
      expandIncludes(inc, inc.RootElement(), path, depth + 1, robot_names);
      XMLNode* after = e;
      for (XMLElement* c = inc.RootElement()->FirstChildElement(); c; c = c->NextSiblingElement()) {
        XMLNode* copy = c->DeepClone(&doc);
        parent->InsertAfterChild(after, copy);
        after = copy;
      }
      parent->DeleteChild(e);
    } else {
      expandIncludes(doc, e, file, depth, robot_names);
    }
    e = next;
  }
}

void collectNames(const XMLElement* e, const char* element, std::vector<const XMLElement*>& out) {
  for (const XMLElement* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) {
    if (std::strcmp(c->Name(), element) == 0 && c->Attribute("name")) out.push_back(c);
    collectNames(c, element, out);
  }
}

void collectSources(const XMLElement* e, const std::string& file, int depth, std::vector<std::string>& out) {
  if (depth > 20) throw InputError(file, "<include> nested more than 20 deep (a cycle?)");
  for (const XMLElement* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) {
    if (std::strcmp(c->Name(), "include") == 0 && c->Attribute("file")) {
      const std::string path = (std::filesystem::path(file).parent_path() / c->Attribute("file")).lexically_normal().string();
      out.push_back(path);
      if (isUrdfPart(path)) {
        const UrdfObject part = loadUrdfObject(path);
        out.insert(out.end(), part.files.begin(), part.files.end());
      } else {
        XMLDocument inc;
        parseFile(inc, path);
        collectSources(inc.RootElement(), path, depth + 1, out);
      }
    }
    collectSources(c, file, depth, out);
  }
}

}  // namespace

bool isUrdfPart(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".urdf";
}

std::vector<std::string> sceneSources(const std::string& scene_xml) {
  XMLDocument scene;
  parseFile(scene, scene_xml);
  std::vector<std::string> out;
  collectSources(scene.RootElement(), scene_xml, 0, out);
  return out;
}

std::string composeScene(const std::string& scene_xml, const RobotSpec& robot, const std::vector<ObjectKind>& objects) {
  XMLDocument scene;
  parseFile(scene, scene_xml);
  XMLElement* root = scene.RootElement();
  std::set<std::string> robot_names;
  for (const auto& l : robot.links) robot_names.insert(l.name);
  checkNoRobot(root, scene_xml, robot_names);
  expandIncludes(scene, root, scene_xml, 0, robot_names);

  XMLDocument arm;
  const std::string arm_xml = writeMjcf(robot);
  if (arm.Parse(arm_xml.c_str()) != tinyxml2::XML_SUCCESS)
    throw InputError(robot.file, std::string("internal: the robot's MJCF does not parse: ") + arm.ErrorStr());

  std::vector<const XMLElement*> bodies;
  collectNames(root, "body", bodies);

  // The mount: a site directly in <worldbody>; its pose is the base's.
  std::vector<XMLElement*> worlds;  // an <include> may add <worldbody> sections
  for (XMLElement* w = root->FirstChildElement("worldbody"); w; w = w->NextSiblingElement("worldbody")) worlds.push_back(w);
  if (worlds.empty()) throw InputError(scene_xml, "expected a <worldbody>");
  bool degrees = true;  // MuJoCo's default angle unit
  bool xyz_euler = true;  // MuJoCo's default euler sequence
  for (const XMLElement* c = root->FirstChildElement("compiler"); c; c = c->NextSiblingElement("compiler")) {
    if (const char* unit = c->Attribute("angle")) degrees = std::strcmp(unit, "radian") != 0;
    if (const char* seq = c->Attribute("eulerseq")) xyz_euler = std::strcmp(seq, "xyz") == 0 || std::strcmp(seq, "XYZ") == 0;
  }
  Vec3 mount_p = Vec3::Zero();
  double mount_yaw = 0;
  std::vector<const XMLElement*> sites;
  collectNames(root, "site", sites);
  for (const XMLElement* s : sites) {
    if (std::strcmp(s->Attribute("name"), "robot_mount") != 0) continue;
    if (std::find(worlds.begin(), worlds.end(), s->Parent()) == worlds.end())
      throw InputError(at(scene_xml, s), "site 'robot_mount' must be a direct child of <worldbody>");
    double x[4] = {0, 0, 0, 0};
    if (const char* v = s->Attribute("pos")) {
      if (std::sscanf(v, "%lf %lf %lf", &x[0], &x[1], &x[2]) != 3) throw InputError(at(scene_xml, s), "site 'robot_mount': pos expects 3 numbers");
      mount_p = Vec3(x[0], x[1], x[2]);
    }
    // The base may turn about z only: gravity stays along the robot's -z.
    const std::string yaw_only = "site 'robot_mount': the base may turn about z only (quat=\"cos(a/2) 0 0 sin(a/2)\" or euler=\"0 0 a\")";
    if (const char* v = s->Attribute("quat")) {
      if (std::sscanf(v, "%lf %lf %lf %lf", &x[0], &x[1], &x[2], &x[3]) != 4 || x[1] != 0 || x[2] != 0 || (x[0] == 0 && x[3] == 0))
        throw InputError(at(scene_xml, s), yaw_only);
      mount_yaw = 2 * std::atan2(x[3], x[0]);
    } else if (const char* e = s->Attribute("euler")) {
      if (!xyz_euler || std::sscanf(e, "%lf %lf %lf", &x[0], &x[1], &x[2]) != 3 || x[0] != 0 || x[1] != 0)
        throw InputError(at(scene_xml, s), yaw_only + " (an euler mount needs the default eulerseq xyz)");
      mount_yaw = degrees ? x[2] * M_PI / 180 : x[2];
    }
    for (const char* a : {"axisangle", "xyaxes", "zaxis"})
      if (s->Attribute(a)) throw InputError(at(scene_xml, s), yaw_only);
  }
  if (!mount_p.isZero() || mount_yaw != 0) {
    // The harness works in the robot's base frame: the scene is moved by the inverse of the mount
    // (static parts inside one frame body; bodies that must stay the world's children — free and
    // mocap bodies — each moved).
    const Mat3 Rt = Eigen::AngleAxisd(-mount_yaw, Vec3::UnitZ()).toRotationMatrix();
    const Vec3 t = -(Rt * mount_p);
    const Quat q_inv(Eigen::AngleAxisd(-mount_yaw, Vec3::UnitZ()));
    char buf[160];
    for (size_t wi = 0; wi < worlds.size(); ++wi) {
      XMLElement* world = worlds[wi];
      XMLElement* frame = scene.NewElement("body");
      frame->SetAttribute("name", ("minimanip_scene_frame_" + std::to_string(wi)).c_str());
      std::snprintf(buf, sizeof buf, "%.12g %.12g %.12g", t.x(), t.y(), t.z());
      frame->SetAttribute("pos", buf);
      std::snprintf(buf, sizeof buf, "%.12g 0 0 %.12g", q_inv.w(), q_inv.z());
      frame->SetAttribute("quat", buf);
      std::vector<XMLElement*> children;
      for (XMLElement* c = world->FirstChildElement(); c; c = c->NextSiblingElement()) children.push_back(c);
      for (XMLElement* c : children) {
        bool top_level = false;  // a free or mocap body: MuJoCo keeps them the world's children
        if (std::strcmp(c->Name(), "body") == 0) {
          top_level = c->BoolAttribute("mocap", false) || c->FirstChildElement("freejoint");
          for (const XMLElement* j = c->FirstChildElement("joint"); j && !top_level; j = j->NextSiblingElement("joint"))
            top_level = j->Attribute("type") && std::strcmp(j->Attribute("type"), "free") == 0;
        }
        if (!top_level) {
          frame->InsertEndChild(c);  // moves it
          continue;
        }
        for (const char* a : {"euler", "axisangle", "xyaxes", "zaxis"})
          if (c->Attribute(a))
            throw InputError(at(scene_xml, c), std::string("a free or mocap body in a scene whose robot_mount is moved needs its orientation as quat (not ") + a + ")");
        Vec3 p = Vec3::Zero();
        if (const char* v = c->Attribute("pos")) std::sscanf(v, "%lf %lf %lf", &p.x(), &p.y(), &p.z());
        Quat q = Quat::Identity();
        if (const char* v = c->Attribute("quat")) {
          double w = 1, x = 0, y = 0, z = 0;
          std::sscanf(v, "%lf %lf %lf %lf", &w, &x, &y, &z);
          q = Quat(w, x, y, z).normalized();
        }
        const Vec3 p2 = Rt * p + t;
        const Quat q2 = q_inv * q;
        std::snprintf(buf, sizeof buf, "%.12g %.12g %.12g", p2.x(), p2.y(), p2.z());
        c->SetAttribute("pos", buf);
        std::snprintf(buf, sizeof buf, "%.12g %.12g %.12g %.12g", q2.w(), q2.x(), q2.y(), q2.z());
        c->SetAttribute("quat", buf);
      }
      world->InsertFirstChild(frame);
    }
  }

  // The robot's sections go where a scene's <include> of the robot used to be: before the scene's
  // own defaults, assets and bodies (so the model's element order, and its physics, are as before).
  XMLNode* before = nullptr;
  for (XMLElement* c = root->FirstChildElement(); c; c = c->NextSiblingElement()) {
    const std::string n = c->Name();
    if (n != "compiler" && n != "option" && n != "size" && n != "visual" && n != "statistic" && n != "extension") break;
    before = c;
  }
  // The robot's joint ranges are in radians; convert them when the scene works in degrees.
  if (degrees) {
    std::function<void(XMLElement*)> convert = [&](XMLElement* e) {
      for (XMLElement* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) {
        const char* type = c->Attribute("type");
        if (std::strcmp(c->Name(), "joint") == 0 && c->Attribute("range") && !(type && std::strcmp(type, "slide") == 0)) {
          double lo = 0, hi = 0;
          if (std::sscanf(c->Attribute("range"), "%lf %lf", &lo, &hi) == 2) {
            char buf[80];
            std::snprintf(buf, sizeof buf, "%.12g %.12g", lo * 180 / M_PI, hi * 180 / M_PI);
            c->SetAttribute("range", buf);
          }
        }
        convert(c);
      }
    };
    convert(arm.RootElement());
  }
  XMLNode* after = before;
  for (XMLElement* c = arm.RootElement()->FirstChildElement(); c; c = c->NextSiblingElement()) {
    if (std::strcmp(c->Name(), "compiler") == 0) continue;  // the scene's compiler rules
    XMLNode* copy = c->DeepClone(&scene);
    after = after ? root->InsertAfterChild(after, copy) : root->InsertFirstChild(copy);
  }

  // The trial's objects, as the world's last free bodies (before the obstacle pool, if any).
  for (const XMLElement* b : bodies)
    if (std::strncmp(b->Attribute("name"), "object_", 7) == 0)
      throw InputError(at(scene_xml, b), std::string("body '") + b->Attribute("name") +
                                             "': objects come from the object catalogue (objects.catalogue, objects.kinds), not the scene");
  XMLElement* world = worlds.front();
  XMLElement* obstacle = nullptr;
  for (XMLElement* c = world->FirstChildElement("body"); c && !obstacle; c = c->NextSiblingElement("body"))
    if (c->Attribute("name") && std::strncmp(c->Attribute("name"), "obstacle_", 9) == 0) obstacle = c;
  char buf[200];
  XMLElement* asset = root->LastChildElement("asset");
  for (size_t k = 0; k < objects.size(); ++k) {
    const ObjectKind& o = objects[k];
    const std::string name = "object_" + std::to_string(k);
    XMLElement* body = scene.NewElement("body");
    body->SetAttribute("name", name.c_str());
    std::snprintf(buf, sizeof buf, "0 %.12g -100", 0.2 * static_cast<double>(k));  // out of the way until parked
    body->SetAttribute("pos", buf);
    XMLElement* joint = scene.NewElement("freejoint");
    joint->SetAttribute("name", name.c_str());
    body->InsertEndChild(joint);
    XMLElement* geom = scene.NewElement("geom");
    geom->SetAttribute("name", name.c_str());
    geom->SetAttribute("type", shapeName(o.shape));
    if (o.shape == ObjectShape::kMesh) {
      // A mesh object: its mass properties given (MuJoCo 2.2's own for meshes are unreliable), the
      // collision hull as the object's geom (group 3: not drawn), the file's mesh drawn (no contacts).
      const ObjectSolid& solid = *o.solid;
      XMLElement* inertial = scene.NewElement("inertial");
      std::snprintf(buf, sizeof buf, "%.12g %.12g %.12g", solid.com.x(), solid.com.y(), solid.com.z());
      inertial->SetAttribute("pos", buf);
      std::snprintf(buf, sizeof buf, "%.12g", o.mass);
      inertial->SetAttribute("mass", buf);
      const Mat3& J = solid.inertia;
      std::snprintf(buf, sizeof buf, "%.12g %.12g %.12g %.12g %.12g %.12g", J(0, 0), J(1, 1), J(2, 2), J(0, 1), J(0, 2), J(1, 2));
      inertial->SetAttribute("fullinertia", buf);
      body->InsertEndChild(inertial);
      if (!asset) asset = root->InsertEndChild(scene.NewElement("asset"))->ToElement();
      for (size_t j = 0; j < solid.pieces->size(); ++j) {
        XMLElement* hull = asset->InsertEndChild(scene.NewElement("mesh"))->ToElement();
        hull->SetAttribute("name", (name + "_hull" + (j ? "_" + std::to_string(j) : "")).c_str());
        hull->SetAttribute("vertex", verticesText((*solid.pieces)[j].vertices).c_str());
      }
      XMLElement* visual = asset->InsertEndChild(scene.NewElement("mesh"))->ToElement();
      visual->SetAttribute("name", (name + "_visual").c_str());
      visual->SetAttribute("vertex", verticesText(solid.visual_vertices).c_str());
      visual->SetAttribute("face", facesText(solid.visual_faces).c_str());
      geom->SetAttribute("mesh", (name + "_hull").c_str());
      geom->SetAttribute("group", 3);
    } else {
      if (o.shape == ObjectShape::kCylinder) std::snprintf(buf, sizeof buf, "%.12g %.12g", o.half_size.x(), o.half_size.z());
      else std::snprintf(buf, sizeof buf, "%.12g %.12g %.12g", o.half_size.x(), o.half_size.y(), o.half_size.z());
      geom->SetAttribute("size", buf);
      std::snprintf(buf, sizeof buf, "%.12g", o.mass);
      geom->SetAttribute("mass", buf);
    }
    geom->SetAttribute("condim", o.condim);
    std::snprintf(buf, sizeof buf, "%.12g %.12g %.12g", o.friction[0], o.friction[1], o.friction[2]);
    geom->SetAttribute("friction", buf);
    std::snprintf(buf, sizeof buf, "%.6g %.6g %.6g %.6g", o.rgba[0], o.rgba[1], o.rgba[2], o.rgba[3]);
    geom->SetAttribute("rgba", buf);
    body->InsertEndChild(geom);
    for (size_t j = 1; o.shape == ObjectShape::kMesh && j < o.solid->pieces->size(); ++j) {  // its other convex pieces, alike
      XMLElement* piece = geom->DeepClone(&scene)->ToElement();
      piece->SetAttribute("name", (name + "_piece_" + std::to_string(j)).c_str());
      piece->SetAttribute("mesh", (name + "_hull_" + std::to_string(j)).c_str());
      body->InsertEndChild(piece);
    }
    if (o.shape == ObjectShape::kMesh) {
      XMLElement* visual = scene.NewElement("geom");
      visual->SetAttribute("name", (name + "_visual").c_str());
      visual->SetAttribute("type", "mesh");
      visual->SetAttribute("mesh", (name + "_visual").c_str());
      visual->SetAttribute("contype", 0);
      visual->SetAttribute("conaffinity", 0);
      visual->SetAttribute("mass", 0);
      visual->SetAttribute("group", 1);
      visual->SetAttribute("rgba", buf);
      body->InsertEndChild(visual);
    }
    if (!obstacle) world->InsertEndChild(body);
    else if (XMLNode* prev = obstacle->PreviousSibling()) world->InsertAfterChild(prev, body);
    else world->InsertFirstChild(body);
  }

  // Weld-on-grasp (the source's attach plugin): one weld per object, off until a grasp.
  XMLElement* eq = scene.NewElement("equality");
  for (size_t k = 0; k < objects.size(); ++k) {
    const std::string name = "object_" + std::to_string(k);
    XMLElement* w = scene.NewElement("weld");
    w->SetAttribute("name", ("attach_" + std::to_string(k)).c_str());
    w->SetAttribute("body1", robot.gripper.hand.name.c_str());
    w->SetAttribute("body2", name.c_str());
    w->SetAttribute("active", "false");
    eq->InsertEndChild(w);
  }
  root->InsertEndChild(eq);

  tinyxml2::XMLPrinter printer;
  scene.Print(&printer);
  return printer.CStr();
}

}  // namespace mm
