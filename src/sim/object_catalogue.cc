#include "sim/object_catalogue.h"

#include <cmath>

#include "robot/spec_reader.h"

namespace mm {

const ObjectKind* ObjectCatalogue::find(const std::string& name) const {
  for (const ObjectKind& k : kinds)
    if (k.name == name) return &k;
  return nullptr;
}

std::vector<std::string> ObjectCatalogue::names() const {
  std::vector<std::string> out;
  for (const ObjectKind& k : kinds) out.push_back(k.name);
  return out;
}

ObjectKind ObjectCatalogue::asObject(const ObjectKind& kind, int k) const {
  ObjectKind o = kind;
  if (!o.has_rgba && !palette.empty()) o.rgba = palette[static_cast<size_t>(k) % palette.size()];
  return o;
}

namespace {

std::array<double, 4> readRgba(const spec_io::Reader& r, const YAML::Node& n) {
  if (!n.IsSequence() || n.size() != 4) throw InputError(r.at(n), "a colour expects 4 numbers in [0, 1] (r g b a)");
  std::array<double, 4> c{};
  for (size_t i = 0; i < 4; ++i) {
    try {
      c[i] = n[i].as<double>();
    } catch (const YAML::Exception&) {
      throw InputError(r.at(n[i]), "a colour expects numbers in [0, 1]");
    }
    if (!(c[i] >= 0 && c[i] <= 1)) throw InputError(r.at(n[i]), "a colour's components must be in [0, 1]");
  }
  return c;
}

}  // namespace

ObjectCatalogue loadObjectCatalogue(const std::string& path) {
  const spec_io::Reader r{path};
  const YAML::Node root = spec_io::loadYaml(path, "an object catalogue (kinds: name: {shape, size, mass, ...})");
  ObjectCatalogue c;
  c.file = path;
  const YAML::Node kinds = r.require(root, "kinds", root);
  if (!kinds.IsMap() || kinds.size() == 0) throw InputError(r.at(kinds), "'kinds' expects a map of object kinds by name");
  for (const auto& entry : kinds) {
    const YAML::Node& n = entry.second;
    ObjectKind k;
    k.name = entry.first.Scalar();
    if (!n.IsMap()) throw InputError(r.at(n), "object kind '" + k.name + "' expects a map (shape, size, mass, ...)");
    for (const auto& field : n) {
      const std::string key = field.first.Scalar();
      if (key != "shape" && key != "size" && key != "mass" && key != "friction" && key != "condim" && key != "rgba")
        throw InputError(r.at(field.first), "object kind '" + k.name + "': unknown key '" + key +
                                                "' (expected shape, size, mass, friction, condim, rgba)");
    }
    const std::string shape = r.text(n, "shape");
    if (shape == "cylinder") k.shape = ObjectShape::kCylinder;
    else if (shape != "box") throw InputError(r.at(n["shape"]), "object kind '" + k.name + "': shape '" + shape + "' is not supported (expected box or cylinder)");
    const auto size = r.vec3(n, "size");
    for (int i = 0; i < 3; ++i) {
      if (!(size[i] > 0 && size[i] <= 1)) throw InputError(r.at(n["size"]), "object kind '" + k.name + "': size expects edge lengths in (0, 1] m");
      k.half_size[i] = size[i] / 2;
    }
    if (k.shape == ObjectShape::kCylinder && size[0] != size[1])
      throw InputError(r.at(n["size"]), "object kind '" + k.name + "': a cylinder's size is [diameter, diameter, height]");
    k.mass = r.positive(n, "mass");
    if (n["friction"]) {
      k.friction = r.vec3(n, "friction");
      for (double f : k.friction)
        if (f < 0) throw InputError(r.at(n["friction"]), "object kind '" + k.name + "': friction must be >= 0");
    }
    if (n["condim"]) {
      const double d = r.number(n, "condim");
      if (d != 1 && d != 3 && d != 4 && d != 6) throw InputError(r.at(n["condim"]), "object kind '" + k.name + "': condim expects 1, 3, 4 or 6");
      k.condim = static_cast<int>(d);
    }
    if (n["rgba"]) {
      k.rgba = readRgba(r, n["rgba"]);
      k.has_rgba = true;
    }
    c.kinds.push_back(k);
  }
  if (const YAML::Node p = root["palette"]) {
    if (!p.IsSequence()) throw InputError(r.at(p), "'palette' expects a list of colours (r g b a)");
    for (const auto& colour : p) c.palette.push_back(readRgba(r, colour));
  }
  for (const auto& entry : root) {
    const std::string key = entry.first.Scalar();
    if (key != "kinds" && key != "palette") throw InputError(r.at(entry.first), "unknown key '" + key + "' (expected kinds, palette)");
  }
  return c;
}

}  // namespace mm
