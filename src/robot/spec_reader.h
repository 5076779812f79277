// Internal to robot/: reading robot and gripper YAML files with errors that name file:line:column.
#pragma once
#include <yaml-cpp/yaml.h>

#include <array>
#include <cmath>
#include <string>

#include "core/error.h"
#include "robot/robot_spec.h"

namespace mm::spec_io {

struct Reader {
  std::string file;
  std::string at(const YAML::Node& n) const {
    return file + ":" + std::to_string(n.Mark().line + 1) + ":" + std::to_string(n.Mark().column + 1);
  }
  YAML::Node require(const YAML::Node& map, const char* key, const YAML::Node& parent) const {
    if (!map.IsMap()) throw InputError(at(parent), std::string("expected a map holding '") + key + "'");
    if (!map[key]) throw InputError(at(parent), std::string("missing key '") + key + "'");
    return map[key];
  }
  double number(const YAML::Node& map, const char* key) const {
    YAML::Node n = require(map, key, map);
    double v;
    try {
      v = n.as<double>();
    } catch (const YAML::Exception&) {
      throw InputError(at(n), std::string("'") + key + "' expects a number");
    }
    if (!std::isfinite(v)) throw InputError(at(n), std::string("'") + key + "' must be finite");
    return v;
  }
  double positive(const YAML::Node& map, const char* key) const {
    const double v = number(map, key);
    if (v <= 0) throw InputError(at(map[key]), std::string("'") + key + "' must be > 0");
    return v;
  }
  std::string text(const YAML::Node& map, const char* key) const {
    YAML::Node n = require(map, key, map);
    if (!n.IsScalar() || n.Scalar().empty())
      throw InputError(at(n), std::string("'") + key + "' expects a non-empty string");
    return n.Scalar();
  }
  std::array<double, 3> vec3(const YAML::Node& map, const char* key) const {
    YAML::Node n = require(map, key, map);
    if (!n.IsSequence() || n.size() != 3)
      throw InputError(at(n), std::string("'") + key + "' expects a list of 3 numbers");
    std::array<double, 3> v{};
    for (size_t i = 0; i < 3; ++i) {
      try {
        v[i] = n[i].as<double>();
      } catch (const YAML::Exception&) {
        throw InputError(at(n[i]), std::string("'") + key + "' expects numbers");
      }
      if (!std::isfinite(v[i])) throw InputError(at(n[i]), std::string("'") + key + "' must be finite");
    }
    return v;
  }
};

/// Loads a YAML map; `what` says what was expected, for the errors.
YAML::Node loadYaml(const std::string& path, const char* what);
/// A link: name, mass, shapes.
LinkSpec readLink(const Reader& r, const YAML::Node& l);
/// Reads `gripper_path`, mounts it on the arm in `s` (links, TCP) and checks that no name is used
/// twice.
void mountGripper(RobotSpec& s, const std::string& gripper_path);
/// The gripper to mount: `chosen` (the experiment's), else `map`'s `gripper`, relative to `file`.
std::string gripperPath(const std::string& chosen, const Reader& r, const YAML::Node& map, const std::string& file);
/// `map`'s optional `analytic_ik` (a closed form RobotSpec::analytic_ik names); "" when absent.
std::string readAnalyticIk(const Reader& r, const YAML::Node& map);

}  // namespace mm::spec_io
