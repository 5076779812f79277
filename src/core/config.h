// Configuration declared once, next to the struct it fills (Drake's Serialize(Archive*) is the
// model): each options struct has
//     void declare(ConfigArchive& a) {
//       a.value("count_min", count_min, {1, 6}, "", "fewest objects in the bin");
//       ...
//     }
// naming the key, the field, its range (or choices), unit and meaning in one line; the field's
// initializer is the default. The same declaration gives the key table (ParamDecl: the YAML
// loader, --set, config.resolved.yaml, `minimanip config-doc` and docs/reference/config.md) and the
// reading of validated values back into the struct, so none of them can drift.
#pragma once
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "core/params.h"

namespace mm {

struct Range {
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
};

class ConfigArchive {
 public:
  virtual ~ConfigArchive() = default;
  virtual void value(const char* key, int& field, Range range, const char* unit, const char* help) = 0;
  virtual void value(const char* key, int64_t& field, Range range, const char* unit, const char* help) = 0;
  virtual void value(const char* key, uint64_t& field, Range range, const char* unit, const char* help) = 0;
  virtual void value(const char* key, double& field, Range range, const char* unit, const char* help) = 0;
  virtual void value(const char* key, bool& field, const char* help) = 0;
  /// Free text (a name).
  virtual void value(const char* key, std::string& field, const char* help) = 0;
  /// A file: relative paths resolve against the file that set it, the working directory for
  /// --set, the project root for the default.
  virtual void path(const char* key, std::string& field, const char* help) = 0;
  /// One of `choices` (a registry's names, so the list cannot go stale).
  virtual void choice(const char* key, std::string& field, const std::vector<std::string>& choices, const char* help) = 0;
  /// A list of numbers: a YAML sequence, or "a,b,c" with --set.
  virtual void list(const char* key, std::vector<double>& field, Range range, const char* unit, const char* help) = 0;
  /// A list of integers (indices, counts), likewise.
  virtual void list(const char* key, std::vector<int64_t>& field, Range range, const char* help) = 0;
  /// A list of names out of `choices` (empty choices: any).
  virtual void list(const char* key, std::vector<std::string>& field, const std::vector<std::string>& choices,
                    const char* help) = 0;

  /// Keys declared between enter() and leave() are prefixed with "name.".
  void enter(const std::string& section) { sections_.push_back(section); }
  void leave() { sections_.pop_back(); }
  /// An enum-like field written as one of its names.
  template <class E>
  void named(const char* key, E& field, const std::vector<std::pair<std::string, E>>& names, const char* help) {
    std::string text;
    std::vector<std::string> choices;
    for (const auto& [n, v] : names) {
      choices.push_back(n);
      if (v == field) text = n;
    }
    choice(key, text, choices, help);
    for (const auto& [n, v] : names)
      if (n == text) field = v;
  }

 protected:
  std::string fullKey(const char* key) const;

 private:
  std::vector<std::string> sections_;
};

/// The declarations of `declare` (defaults from the struct's initial values).
std::vector<ParamDecl> declarationsOf(const std::function<void(ConfigArchive&)>& declare);

/// Fills the struct through `declare` from validated values. `origin` says where each path was set
/// ("" for the default) so that it resolves against the right folder.
void readConfig(const ParamSet& values, const std::function<void(ConfigArchive&)>& declare,
                const std::function<std::string(const std::string& key, const std::string& path)>& resolve_path);


}  // namespace mm
