#include "sim/scene_compose.h"

#include <tinyxml2.h>

#include <Eigen/Geometry>

#include <cmath>
#include <cstdio>
#include <algorithm>
#include <cstring>
#include <filesystem>
#include <functional>
#include <set>

#include "core/error.h"
#include "core/pose.h"
#include "robot/description_writer.h"

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

// Replaces each <include file=".."/> under `parent` by the included file's top-level children
// (MuJoCo's semantics), recursively; paths relative to the including file.
void expandIncludes(XMLDocument& doc, XMLElement* parent, const std::string& file, int depth,
                    const std::set<std::string>& robot_names) {
  if (depth > 20) throw InputError(file, "<include> nested more than 20 deep (a cycle?)");
  for (XMLElement* e = parent->FirstChildElement(); e;) {
    XMLElement* next = e->NextSiblingElement();
    if (std::strcmp(e->Name(), "include") == 0) {
      const char* f = e->Attribute("file");
      if (!f) throw InputError(at(file, e), "<include> needs a 'file' attribute");
      const std::string path = (std::filesystem::path(file).parent_path() / f).lexically_normal().string();
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

}  // namespace

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
  auto numbers = [](const std::vector<Vec3>& points) {
    std::string out;
    char v[100];
    for (const Vec3& p : points) {
      std::snprintf(v, sizeof v, "%.9g %.9g %.9g ", p.x(), p.y(), p.z());
      out += v;
    }
    return out;
  };
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
        hull->SetAttribute("vertex", numbers((*solid.pieces)[j].vertices).c_str());
      }
      XMLElement* visual = asset->InsertEndChild(scene.NewElement("mesh"))->ToElement();
      visual->SetAttribute("name", (name + "_visual").c_str());
      visual->SetAttribute("vertex", numbers(solid.visual_vertices).c_str());
      std::string faces;
      for (const auto& f : solid.visual_faces) faces += std::to_string(f[0]) + " " + std::to_string(f[1]) + " " + std::to_string(f[2]) + " ";
      visual->SetAttribute("face", faces.c_str());
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
