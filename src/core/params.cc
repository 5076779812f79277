#include "core/params.h"

#include <yaml-cpp/yaml.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <algorithm>
#include <fstream>
#include <map>
#include <sstream>

#include "core/error.h"
#include "core/utf8.h"

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

// The keys declared under `section` ("objects" -> objects.count_min, ...), for a message.
std::string sectionKeys(const std::vector<ParamDecl>& decls, const std::string& section) {
  std::string keys;
  int n = 0;
  for (const ParamDecl& d : decls)
    if (d.key.rfind(section + ".", 0) == 0 && n++ < 6) keys += (keys.empty() ? "" : ", ") + d.key;
  return n > 6 ? keys + ", ..." : keys;
}

// Refuses a map that names a key twice (YAML forbids it; yaml-cpp keeps both and the reader would
// silently take one).
void requireUniqueKeys(const YAML::Node& map, const std::string& prefix, const std::string& file) {
  std::map<std::string, int> seen;  // key -> line
  for (auto it = map.begin(); it != map.end(); ++it) {
    const YAML::Mark mark = it->first.Mark();
    const std::string name = it->first.IsScalar() ? it->first.Scalar() : "?";
    const auto [at, fresh] = seen.emplace(name, mark.line + 1);
    if (!fresh)
      throw InputError(file + ":" + std::to_string(mark.line + 1) + ":" + std::to_string(mark.column + 1),
                       "duplicate key '" + (prefix.empty() ? name : prefix + "." + name) + "' (first at line " +
                           std::to_string(at->second) + "; a key is given once)");
  }
}

void walk(const YAML::Node& node, const std::string& prefix, const std::string& file,
          ParamSet& set) {
  requireUniqueKeys(node, prefix, file);
  for (auto it = node.begin(); it != node.end(); ++it) {
    // yaml-cpp's iterator hands out a temporary proxy: copy what it holds (Node is a handle),
    // never bind a reference to its members.
    const YAML::Mark mark = it->first.Mark();
    const std::string where =
        file + ":" + std::to_string(mark.line + 1) + ":" + std::to_string(mark.column + 1);
    if (!it->first.IsScalar()) throw InputError(where, "expected a key (a name), got a " + std::string(it->first.IsMap() ? "map" : "list"));
    const std::string key = prefix.empty() ? it->first.as<std::string>()
                                           : prefix + "." + it->first.as<std::string>();
    const YAML::Node v = it->second;
    if (!v.IsMap() && !set.has(key)) {
      const std::string keys = sectionKeys(set.decls(), key);
      if (!keys.empty())
        throw InputError(where, "'" + key + "' is a section (" + keys + "): expected a map of its keys under it, got " +
                                    (v.IsScalar() ? "the value '" + v.Scalar() + "'" : v.IsSequence() ? std::string("a list") : std::string("nothing")));
    }
    if (v.IsMap()) {
      if (set.has(key)) throw InputError(where, "'" + key + "' expects a single value, got a map");
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

// The dotted key of a block-style YAML line (its parents by indentation), e.g. "camera.name";
// "" when the line holds no key. For messages about a line that could not be parsed.
std::string yamlKeyOfLine(const std::string& text, size_t line_no) {
  std::vector<std::string> lines;
  std::stringstream ss(text);
  for (std::string l; std::getline(ss, l);) lines.push_back(l);
  if (line_no == 0 || line_no > lines.size()) return "";
  auto keyOf = [](const std::string& l, size_t& indent) -> std::string {
    indent = l.find_first_not_of(' ');
    if (indent == std::string::npos || l[indent] == '#' || l[indent] == '-') return "";
    const size_t colon = l.find(':', indent);
    if (colon == std::string::npos) return "";
    std::string k = l.substr(indent, colon - indent);
    while (!k.empty() && k.back() == ' ') k.pop_back();
    return k;
  };
  size_t indent = 0;
  std::string key = keyOf(lines[line_no - 1], indent);
  if (key.empty()) return "";
  for (size_t i = line_no - 1; i-- > 0 && indent > 0;) {
    size_t pi = 0;
    const std::string parent = keyOf(lines[i], pi);
    if (!parent.empty() && pi < indent) key = parent + "." + key, indent = pi;
  }
  return key;
}

void ParamSet::loadYamlFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "cannot open file (expected a YAML experiment file)");
  std::ostringstream contents;
  contents << in.rdbuf();
  const std::string text = contents.str();
  try {
    requireUtf8File(text, path);
  } catch (const InputError& e) {
    // Name the key whose line holds the byte.
    const std::string w = e.where();
    const size_t a = w.find(':', path.size()), b = w.find(':', a + 1);
    const std::string key = yamlKeyOfLine(text, std::stoul(w.substr(a + 1, b - a - 1)));
    if (key.empty()) throw;
    throw InputError(w, "the line of '" + key + "' is " + std::string(e.what()).substr(w.size() + 2));
  }
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(path + ":" + std::to_string(e.mark.line + 1) + ":" +
                         std::to_string(e.mark.column + 1),
                     "malformed YAML: " + e.msg);
  }
  if (root.IsNull()) throw InputError(path, "empty file (expected a YAML map of settings)");
  if (!root.IsMap()) throw InputError(path + ":1:1", "expected a YAML map of settings at the top");
  requireUniqueKeys(root, "", path);
  if (const YAML::Node sweep = root["sweep"]) {
    const std::string at = path + ":" + std::to_string(sweep.Mark().line + 1) + ":" + std::to_string(sweep.Mark().column + 1);
    if (!sweep.IsMap()) throw InputError(at, "'sweep' expects a map of keys to lists of values (objects.count_max: [1, 3, 5])");
    requireUniqueKeys(sweep, "sweep", path);
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
  requireUtf8(key, where, "the key");
  const ParamDecl& d = decl(key, where);
  requireUtf8(text, where, "the value of '" + key + "'");
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
