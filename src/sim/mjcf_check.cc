#include "sim/mjcf_check.h"

#include <tinyxml2.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <sstream>
#include <vector>

#include "core/error.h"
#include "sim/scene_compose.h"

namespace mm {
namespace {

// Attributes holding numbers in MJCF (the ones whose silent NaN would corrupt a model).
const std::set<std::string> kNumeric = {
    "pos", "quat", "euler", "axisangle", "xyaxes", "zaxis", "size", "fromto", "mass", "density",
    "range", "axis", "friction", "solref", "solimp", "margin", "gap", "damping", "armature",
    "stiffness", "frictionloss", "ctrlrange", "forcerange", "gear", "kp", "diaginertia",
    "fullinertia", "timestep", "gravity", "rgba", "fovy", "dir", "diffuse", "relpose", "scale"};

void checkElement(const tinyxml2::XMLElement* e, const std::string& file, int depth);

void checkFile(const std::string& path, int depth) {
  if (depth > 8) throw InputError(path, "includes nested too deep (expected at most 8 levels)");
  tinyxml2::XMLDocument doc;
  const auto rc = doc.LoadFile(path.c_str());
  if (rc == tinyxml2::XML_ERROR_FILE_NOT_FOUND || rc == tinyxml2::XML_ERROR_FILE_COULD_NOT_BE_OPENED)
    throw InputError(path, "cannot open file (expected an MJCF model)");
  if (rc != tinyxml2::XML_SUCCESS)
    throw InputError(path + ":" + std::to_string(doc.ErrorLineNum()),
                     std::string("malformed XML (expected an MJCF model): ") + doc.ErrorStr());
  const auto* root = doc.RootElement();
  if (!root || std::string(root->Name()) != "mujoco")
    throw InputError(path + ":" + std::to_string(root ? root->GetLineNum() : 1), "expected a <mujoco> root element");
  checkElement(root, path, depth);
}

void checkElement(const tinyxml2::XMLElement* e, const std::string& file, int depth) {
  const std::string where = file + ":" + std::to_string(e->GetLineNum());
  const std::string tag = e->Name();
  for (const auto* a = e->FirstAttribute(); a; a = a->Next()) {
    const std::string name = a->Name();
    if (!kNumeric.count(name)) continue;
    std::stringstream ss(a->Value());
    std::vector<double> vals;
    for (std::string tok; ss >> tok;) {
      char* end = nullptr;
      const double v = std::strtod(tok.c_str(), &end);
      if (!end || *end != '\0')
        throw InputError(where, "<" + tag + "> " + name + "=\"" + a->Value() + "\": expected numbers");
      if (!std::isfinite(v))
        throw InputError(where, "<" + tag + "> " + name + "=\"" + a->Value() + "\": expected finite numbers");
      vals.push_back(v);
    }
    if (name == "quat") {
      if (vals.size() != 4) throw InputError(where, "<" + tag + "> quat expects 4 numbers");
      if (std::abs(vals[0]) + std::abs(vals[1]) + std::abs(vals[2]) + std::abs(vals[3]) < 1e-12)
        throw InputError(where, "<" + tag + "> quat is zero (expected a non-zero quaternion)");
    }
    if (name == "size" || name == "mass")
      for (double v : vals)
        if (v < 0) throw InputError(where, "<" + tag + "> " + name + " must not be negative");
  }
  if (tag == "mesh" || tag == "hfield" || tag == "texture") {
    if (const char* f = e->Attribute("file")) {
      const std::string stem = std::filesystem::path(f).filename().string();
      if (stem.size() < 3)  // MuJoCo 2.2.2 aborts the process on such names
        throw InputError(where, "<" + tag + "> file=\"" + f + "\": expected a file name of at least 3 characters");
    }
  }
  if (tag == "include") {
    const char* f = e->Attribute("file");
    if (!f) throw InputError(where, "<include> needs a file attribute");
    const auto inc = std::filesystem::path(file).parent_path() / f;
    // A URDF file is a static cell part: the scene's composition reads and checks it.
    if (!isUrdfPart(inc.string())) checkFile(inc.string(), depth + 1);
  }
  for (const auto* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) checkElement(c, file, depth);
}

}  // namespace

void checkMjcf(const std::string& path) { checkFile(path, 0); }

}  // namespace mm
