#include "core/config.h"

#include <charconv>
#include <cmath>

#include "core/error.h"

namespace mm {

std::string ConfigArchive::fullKey(const char* key) const {
  std::string k;
  for (const auto& s : sections_) k += s + ".";
  return k + key;
}

namespace {

// The shortest text that reads back as the same number.
std::string numberText(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}
template <class I>
std::string integerText(I v) {
  return std::to_string(v);
}

std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ",") + x;
  return s;
}

// Collects the declarations, the fields' initial values as defaults.
class Declarer final : public ConfigArchive {
 public:
  std::vector<ParamDecl> decls;
  void value(const char* key, int& f, Range r, const char* unit, const char* help) override {
    add(key, ParamDecl::Kind::kInt, integerText(f), r, {}, unit, help);
  }
  void value(const char* key, int64_t& f, Range r, const char* unit, const char* help) override {
    add(key, ParamDecl::Kind::kInt, integerText(f), r, {}, unit, help);
  }
  void value(const char* key, uint64_t& f, Range r, const char* unit, const char* help) override {
    add(key, ParamDecl::Kind::kInt, integerText(f), r, {}, unit, help);
  }
  void value(const char* key, double& f, Range r, const char* unit, const char* help) override {
    add(key, ParamDecl::Kind::kDouble, numberText(f), r, {}, unit, help);
  }
  void value(const char* key, bool& f, const char* help) override {
    add(key, ParamDecl::Kind::kBool, f ? "true" : "false", {}, {}, "", help);
  }
  void value(const char* key, std::string& f, const char* help) override {
    add(key, ParamDecl::Kind::kString, f, {}, {}, "", help);
  }
  void path(const char* key, std::string& f, const char* help) override {
    add(key, ParamDecl::Kind::kPath, f, {}, {}, "", help);
  }
  void choice(const char* key, std::string& f, const std::vector<std::string>& choices, const char* help) override {
    add(key, ParamDecl::Kind::kChoice, f, {}, choices, "", help);
  }
  void list(const char* key, std::vector<double>& f, Range r, const char* unit, const char* help) override {
    std::vector<std::string> text;
    for (double v : f) text.push_back(numberText(v));
    add(key, ParamDecl::Kind::kRealList, join(text), r, {}, unit, help);
  }
  void list(const char* key, std::vector<int64_t>& f, Range r, const char* help) override {
    std::vector<std::string> text;
    for (int64_t v : f) text.push_back(std::to_string(v));
    add(key, ParamDecl::Kind::kIntList, join(text), r, {}, "", help);
  }
  void list(const char* key, std::vector<std::string>& f, const std::vector<std::string>& choices, const char* help) override {
    add(key, ParamDecl::Kind::kChoiceList, join(f), {}, choices, "", help);
  }

 private:
  void add(const char* key, ParamDecl::Kind kind, std::string def, Range r, std::vector<std::string> choices,
           const char* unit, const char* help) {
    ParamDecl d;
    d.key = fullKey(key);
    d.kind = kind;
    d.default_value = std::move(def);
    d.min = r.min;
    d.max = r.max;
    d.choices = std::move(choices);
    d.unit = unit;
    d.help = help;
    decls.push_back(std::move(d));
  }
};

// Reads validated values back into the fields.
class Reader final : public ConfigArchive {
 public:
  using Resolve = std::function<std::string(const std::string&, const std::string&)>;
  Reader(const ParamSet& p, Resolve resolve) : p_(p), resolve_(std::move(resolve)) {}
  void value(const char* key, int& f, Range, const char*, const char*) override {
    f = static_cast<int>(p_.getInt(fullKey(key)));
  }
  void value(const char* key, int64_t& f, Range, const char*, const char*) override { f = p_.getInt(fullKey(key)); }
  void value(const char* key, uint64_t& f, Range, const char*, const char*) override {
    f = static_cast<uint64_t>(p_.getInt(fullKey(key)));
  }
  void value(const char* key, double& f, Range, const char*, const char*) override { f = p_.getDouble(fullKey(key)); }
  void value(const char* key, bool& f, const char*) override { f = p_.getBool(fullKey(key)); }
  void value(const char* key, std::string& f, const char*) override { f = p_.getString(fullKey(key)); }
  void path(const char* key, std::string& f, const char*) override {
    const std::string k = fullKey(key);
    f = resolve_ ? resolve_(k, p_.getString(k)) : p_.getString(k);
  }
  void choice(const char* key, std::string& f, const std::vector<std::string>&, const char*) override {
    f = p_.getString(fullKey(key));
  }
  void list(const char* key, std::vector<double>& f, Range, const char*, const char*) override {
    f.clear();
    for (const std::string& s : splitCommas(p_.getString(fullKey(key)))) f.push_back(std::strtod(s.c_str(), nullptr));
  }
  void list(const char* key, std::vector<int64_t>& f, Range, const char*) override {
    f.clear();
    for (const std::string& s : splitCommas(p_.getString(fullKey(key)))) f.push_back(std::llround(std::strtod(s.c_str(), nullptr)));
  }
  void list(const char* key, std::vector<std::string>& f, const std::vector<std::string>&, const char*) override {
    f = splitCommas(p_.getString(fullKey(key)));
  }

 private:
  const ParamSet& p_;
  Resolve resolve_;
};

}  // namespace

std::vector<ParamDecl> declarationsOf(const std::function<void(ConfigArchive&)>& declare) {
  Declarer d;
  declare(d);
  return std::move(d.decls);
}

void readConfig(const ParamSet& values, const std::function<void(ConfigArchive&)>& declare,
                const std::function<std::string(const std::string&, const std::string&)>& resolve_path) {
  Reader r(values, resolve_path);
  declare(r);
}

}  // namespace mm
