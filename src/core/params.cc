#include "core/params.h"

#include <yaml-cpp/yaml.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <algorithm>
#include <fstream>
#include <sstream>

#include "core/error.h"

namespace mm {

std::vector<std::string> splitCommas(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream ss(text);
  for (std::string item; std::getline(ss, item, ',');) {
    const auto a = item.find_first_not_of(" \t"), b = item.find_last_not_of(" \t");
    if (a != std::string::npos) out.push_back(item.substr(a, b - a + 1));
  }
  return out;
}

namespace {

std::string kindName(const ParamDecl& d) {
  switch (d.kind) {
    case ParamDecl::Kind::kInt: return "an integer";
    case ParamDecl::Kind::kDouble: return "a number";
    case ParamDecl::Kind::kBool: return "true or false";
    case ParamDecl::Kind::kString: return "a string";
    case ParamDecl::Kind::kChoice: {
      std::string s = "one of";
      for (size_t i = 0; i < d.choices.size(); ++i) s += (i ? ", " : " ") + d.choices[i];
      return s;
    }
    case ParamDecl::Kind::kPath: return "a file path";
    case ParamDecl::Kind::kRealList: return "a list of numbers";
    case ParamDecl::Kind::kIntList: return "a list of integers";
    case ParamDecl::Kind::kChoiceList: {
      if (d.choices.empty()) return "a list of names";
      std::string s = "a list of";
      for (size_t i = 0; i < d.choices.size(); ++i) s += (i ? ", " : " ") + d.choices[i];
      return s;
    }
  }
  return "?";
}

bool parseDouble(const std::string& t, double& out) {
  if (t.empty()) return false;
  char* end = nullptr;
  errno = 0;
  out = std::strtod(t.c_str(), &end);
  return errno == 0 && end && *end == '\0' && std::isfinite(out);
}

std::string rangeText(const ParamDecl& d) {
  std::ostringstream s;
  if (std::isfinite(d.min) && std::isfinite(d.max)) s << "[" << d.min << ", " << d.max << "]";
  else if (std::isfinite(d.min)) s << ">= " << d.min;
  else if (std::isfinite(d.max)) s << "<= " << d.max;
  return s.str();
}

// Seconds may be written with a unit: 5ms, 500us, 0.01s.
std::string secondsText(const ParamDecl& d, const std::string& text) {
  if (d.unit != "s") return text;
  for (const auto& [suffix, scale] : {std::pair<const char*, double>{"ms", 1e-3}, {"us", 1e-6}, {"s", 1.0}}) {
    const std::string sfx = suffix;
    if (text.size() > sfx.size() && text.compare(text.size() - sfx.size(), sfx.size(), sfx) == 0) {
      double v;
      if (parseDouble(text.substr(0, text.size() - sfx.size()), v)) {
        std::ostringstream o;
        o.precision(17);
        o << v * scale;
        return o.str();
      }
    }
  }
  return text;
}

// Validates `text` against `d`; returns the canonical text or throws InputError at `where`.
std::string validate(const ParamDecl& d, const std::string& raw, const std::string& where) {
  const std::string expected = "'" + d.key + "' expects " + kindName(d);
  const std::string text = secondsText(d, raw);
  switch (d.kind) {
    case ParamDecl::Kind::kPath:
      if (text.empty()) throw InputError(where, expected + ", got an empty value");
      return text;
    case ParamDecl::Kind::kRealList:
    case ParamDecl::Kind::kIntList: {
      std::string canonical;
      for (const std::string& item : splitCommas(text)) {
        double v;
        if (!parseDouble(item, v) || (d.kind == ParamDecl::Kind::kIntList && v != std::floor(v)))
          throw InputError(where, expected + ", got '" + item + "' in '" + text + "'");
        if (v < d.min || v > d.max)
          throw InputError(where, "'" + d.key + "' items must be in " + rangeText(d) + ", got " + item);
        canonical += (canonical.empty() ? "" : ",") + item;
      }
      return canonical;
    }
    case ParamDecl::Kind::kChoiceList: {
      std::string canonical;
      for (const std::string& item : splitCommas(text)) {
        if (!d.choices.empty() && std::find(d.choices.begin(), d.choices.end(), item) == d.choices.end())
          throw InputError(where, expected + ", got '" + item + "'");
        canonical += (canonical.empty() ? "" : ",") + item;
      }
      return canonical;
    }
    case ParamDecl::Kind::kBool:
      if (text == "true" || text == "false") return text;
      throw InputError(where, expected + ", got '" + text + "'");
    case ParamDecl::Kind::kString:
      if (text.empty()) throw InputError(where, expected + ", got an empty value");
      return text;
    case ParamDecl::Kind::kChoice:
      for (const auto& c : d.choices)
        if (c == text) return text;
      throw InputError(where, expected + ", got '" + text + "'");
    case ParamDecl::Kind::kInt:
    case ParamDecl::Kind::kDouble: {
      double v;
      if (!parseDouble(text, v)) throw InputError(where, expected + ", got '" + text + "'");
      if (d.kind == ParamDecl::Kind::kInt && v != std::floor(v))
        throw InputError(where, expected + ", got '" + text + "'");
      if (v < d.min || v > d.max)
        throw InputError(where, "'" + d.key + "' must be in " + rangeText(d) + ", got " + text);
      return text;
    }
  }
  return text;
}

void walk(const YAML::Node& node, const std::string& prefix, const std::string& file,
          ParamSet& set) {
  for (auto it = node.begin(); it != node.end(); ++it) {
    // yaml-cpp's iterator hands out a temporary proxy: copy what it holds (Node is a handle),
    // never bind a reference to its members.
    const YAML::Mark mark = it->first.Mark();
    const std::string where =
        file + ":" + std::to_string(mark.line + 1) + ":" + std::to_string(mark.column + 1);
    const std::string key = prefix.empty() ? it->first.as<std::string>()
                                           : prefix + "." + it->first.as<std::string>();
    const YAML::Node v = it->second;
    if (v.IsMap()) {
      walk(v, key, file, set);
    } else if (v.IsScalar()) {
      set.set(key, v.Scalar(), where, file);
    } else if (v.IsSequence() && set.has(key) && set.isList(key)) {
      std::string joined;
      for (const auto& item : v) {
        if (!item.IsScalar()) throw InputError(where, "'" + key + "' expects a list of single values");
        joined += (joined.empty() ? "" : ",") + item.Scalar();
      }
      set.set(key, joined, where, file);
    } else if (v.IsNull()) {
      throw InputError(where, "'" + key + "' has no value");
    } else {
      throw InputError(where, "'" + key + "' expects a single value, got a list");
    }
  }
}

}  // namespace

ParamSet::ParamSet(std::vector<ParamDecl> decls) : decls_(std::move(decls)) {
  for (const auto& d : decls_) {
    values_[d.key] = validate(d, d.default_value, "default of " + d.key);
    set_[d.key] = false;
  }
}

const ParamDecl& ParamSet::decl(const std::string& key, const std::string& where) const {
  for (const auto& d : decls_)
    if (d.key == key) return d;
  // Suggest keys that share the section, the most common cause being a typo.
  std::string hint;
  const auto dot = key.rfind('.');
  const std::string section = dot == std::string::npos ? "" : key.substr(0, dot + 1);
  for (const auto& d : decls_)
    if (!section.empty() && d.key.rfind(section, 0) == 0) hint += (hint.empty() ? "" : ", ") + d.key;
  throw InputError(where, "unknown key '" + key + "'" +
                              (hint.empty() ? "" : " (known in this section: " + hint + ")"));
}

void ParamSet::loadYamlFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, "cannot open file (expected a YAML experiment file)");
  YAML::Node root;
  try {
    root = YAML::Load(in);
  } catch (const YAML::Exception& e) {
    throw InputError(path + ":" + std::to_string(e.mark.line + 1) + ":" +
                         std::to_string(e.mark.column + 1),
                     "malformed YAML: " + e.msg);
  }
  if (root.IsNull()) throw InputError(path, "empty file (expected a YAML map of settings)");
  if (!root.IsMap()) throw InputError(path + ":1:1", "expected a YAML map of settings at the top");
  if (const YAML::Node sweep = root["sweep"]) {
    const std::string at = path + ":" + std::to_string(sweep.Mark().line + 1) + ":" + std::to_string(sweep.Mark().column + 1);
    if (!sweep.IsMap()) throw InputError(at, "'sweep' expects a map of keys to lists of values (objects.count_max: [1, 3, 5])");
    for (auto it = sweep.begin(); it != sweep.end(); ++it) {
      const YAML::Mark mark = it->first.Mark();
      const std::string where = path + ":" + std::to_string(mark.line + 1) + ":" + std::to_string(mark.column + 1);
      const YAML::Node v = it->second;
      if (!v.IsSequence()) throw InputError(where, "a swept key expects a list of values, e.g. [0, 0.1, 0.2]");
      std::vector<std::string> values;
      for (const auto& item : v) {
        if (!item.IsScalar()) throw InputError(where, "a swept key's values must be single values");
        values.push_back(item.Scalar());
      }
      addSweep(it->first.as<std::string>(), values, where, path);
    }
    root.remove("sweep");
  }
  walk(root, "", path, *this);
}

void ParamSet::set(const std::string& key, const std::string& text, const std::string& where) {
  set(key, text, where, "");
}

void ParamSet::set(const std::string& key, const std::string& text, const std::string& where, const std::string& origin) {
  const ParamDecl& d = decl(key, where);
  values_[key] = validate(d, text, where);
  set_[key] = true;
  origin_[key] = origin;
}

void ParamSet::addSweep(const std::string& key, const std::vector<std::string>& values, const std::string& where,
                        const std::string& origin) {
  const ParamDecl& d = decl(key, where);
  if (d.isList()) throw InputError(where, "'" + key + "' is a list and cannot be swept");
  for (const Sweep& s : sweeps_)
    if (s.key == key) throw InputError(where, "'" + key + "' is swept twice (first at " + s.where + ")");
  if (values.size() < 2) throw InputError(where, "sweeping '" + key + "' needs at least two values");
  Sweep s{key, {}, where, origin};
  for (const std::string& v : values) {
    const std::string text = validate(d, v, where + " (sweep of " + key + ")");
    if (std::find(s.values.begin(), s.values.end(), text) != s.values.end())
      throw InputError(where, "'" + key + "' lists the value " + text + " twice");
    s.values.push_back(text);
  }
  sweeps_.push_back(std::move(s));
}

const std::string& ParamSet::origin(const std::string& key) const {
  static const std::string kDefault = "(default)";
  auto it = origin_.find(key);
  return it == origin_.end() ? kDefault : it->second;
}

bool ParamSet::has(const std::string& key) const { return values_.count(key) > 0; }

bool ParamSet::isList(const std::string& key) const {
  for (const auto& d : decls_)
    if (d.key == key) return d.isList();
  return false;
}

int64_t ParamSet::getInt(const std::string& key) const {
  return static_cast<int64_t>(std::llround(getDouble(key)));
}
double ParamSet::getDouble(const std::string& key) const {
  return std::strtod(getString(key).c_str(), nullptr);
}
bool ParamSet::getBool(const std::string& key) const { return getString(key) == "true"; }
const std::string& ParamSet::getString(const std::string& key) const {
  auto it = values_.find(key);
  MM_DEMAND(it != values_.end());
  return it->second;
}
bool ParamSet::wasSet(const std::string& key) const { return set_.at(key); }

std::string ParamSet::toYaml() const {
  // Keys are declared grouped by section; emit nested maps in declaration order.
  std::ostringstream out;
  std::vector<std::string> open;
  for (const auto& d : decls_) {
    std::vector<std::string> parts;
    std::stringstream ss(d.key);
    for (std::string p; std::getline(ss, p, '.');) parts.push_back(p);
    size_t common = 0;
    while (common < open.size() && common + 1 < parts.size() && open[common] == parts[common])
      ++common;
    open.resize(common);
    for (size_t i = common; i + 1 < parts.size(); ++i) {
      out << std::string(2 * i, ' ') << parts[i] << ":\n";
      open.push_back(parts[i]);
    }
    const std::string& v = values_.at(d.key);
    const bool quote = d.kind == ParamDecl::Kind::kString || d.kind == ParamDecl::Kind::kPath;
    const bool list = d.isList();
    std::string shown = quote ? "\"" + v + "\"" : v;
    if (list) {
      shown = "[";
      const auto parts_v = splitCommas(v);
      for (size_t i = 0; i < parts_v.size(); ++i) shown += (i ? ", " : "") + parts_v[i];
      shown += "]";
    }
    out << std::string(2 * (parts.size() - 1), ' ') << parts.back() << ": " << shown << "  # " << (d.unit.empty() ? "" : "[" + d.unit + "] ")
        << d.help << "\n";
  }
  return out.str();
}

std::string ParamSet::toMarkdown() const {
  std::ostringstream out;
  out << "| key | default | allowed | unit | meaning |\n|---|---|---|---|---|\n";
  for (const auto& d : decls_) {
    std::string allowed = d.kind == ParamDecl::Kind::kChoice ? "" : rangeText(d);
    if (d.kind == ParamDecl::Kind::kChoice || d.kind == ParamDecl::Kind::kChoiceList)
      for (size_t i = 0; i < d.choices.size(); ++i) allowed += (i ? " \\| " : "") + d.choices[i];
    if (d.isList())
      allowed = "list" + std::string(allowed.empty() ? "" : " of ") + allowed;
    if (d.kind == ParamDecl::Kind::kPath) allowed = "file";
    if (d.kind == ParamDecl::Kind::kBool) allowed = "true \\| false";
    out << "| `" << d.key << "` | " << d.default_value << " | " << allowed << " | " << d.unit
        << " | " << d.help << " |\n";
  }
  return out.str();
}

}  // namespace mm
