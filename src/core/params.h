// Declared parameters: each key is declared once with its type, default, range, unit and help.
// The YAML loader, `--set key=value`, config.resolved.yaml and docs/reference/config.md all
// come from the same declarations, so they cannot drift. Unknown keys are input errors.
#pragma once
#include <cstdint>
#include <limits>
#include <map>
#include <string>
#include <vector>

namespace mm {

/// "a,b, c" -> {"a", "b", "c"} (items trimmed of spaces and tabs, empty ones dropped).
std::vector<std::string> splitCommas(const std::string& text);

struct ParamDecl {
  /// kPath: a file; kRealList: numbers "a,b,c" (a YAML sequence in a file); kIntList: integers, likewise; kChoiceList: names
  /// out of `choices` (any name when there are none). A kDouble in seconds (unit "s") also reads
  /// "5ms", "500us" and "0.01s".
  enum class Kind { kInt, kDouble, kBool, kString, kChoice, kPath, kRealList, kIntList, kChoiceList };
  bool isList() const { return kind == Kind::kRealList || kind == Kind::kIntList || kind == Kind::kChoiceList; }
  std::string key;  ///< dotted path, e.g. "planning.time_limit"
  Kind kind;
  std::string default_value;  ///< as YAML text
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  std::vector<std::string> choices;  ///< for kChoice
  std::string unit;
  std::string help;
};

class ParamSet {
 public:
  explicit ParamSet(std::vector<ParamDecl> decls);

  /// Loads a YAML file of nested maps. Throws InputError naming file:line:col for malformed YAML,
  /// unknown keys, wrong types and out-of-range values.
  void loadYamlFile(const std::string& path);
  /// Sets one value from text; `where` names the origin for messages (e.g. "--set").
  void set(const std::string& key, const std::string& text, const std::string& where);
  /// As set(), recording that the value came from `origin` (a file; "" for --set).
  void set(const std::string& key, const std::string& text, const std::string& where, const std::string& origin);
  /// Where the value came from: the file that set it, "" when set by --set, "(default)" if unset.
  const std::string& origin(const std::string& key) const;
  bool has(const std::string& key) const;
  bool isList(const std::string& key) const;

  int64_t getInt(const std::string& key) const;
  double getDouble(const std::string& key) const;
  bool getBool(const std::string& key) const;
  const std::string& getString(const std::string& key) const;
  bool wasSet(const std::string& key) const;

  /// Every parameter as used, nested, with units and help as comments.
  std::string toYaml() const;
  /// A Markdown table of every parameter (key, default, range, unit, meaning).
  std::string toMarkdown() const;
  const std::vector<ParamDecl>& decls() const { return decls_; }

  /// A factor of a sweep: one key, a few values (each validated as that key's), in the order given.
  struct Sweep {
    std::string key;
    std::vector<std::string> values;
    std::string where;   ///< file:line:col or "--sweep"
    std::string origin;  ///< the file whose sweep: map it is (its path values are relative to it); "" for --sweep
  };
  /// Adds a factor ("a,b,c" or a YAML sequence's items). A file's top-level `sweep:` map (key: [values])
  /// is read by loadYamlFile into the same list. Throws InputError on an unknown key, a list key, a
  /// value its key refuses, fewer than two values or a key swept twice.
  void addSweep(const std::string& key, const std::vector<std::string>& values, const std::string& where,
                const std::string& origin = "");
  /// Forgets every factor (a file's sweep: map ignored, to run one cell with --set).
  void clearSweeps() { sweeps_.clear(); }
  const std::vector<Sweep>& sweeps() const { return sweeps_; }

 private:
  const ParamDecl& decl(const std::string& key, const std::string& where) const;
  std::vector<ParamDecl> decls_;
  std::map<std::string, std::string> values_;  ///< validated text
  std::map<std::string, bool> set_;
  std::map<std::string, std::string> origin_;
  std::vector<Sweep> sweeps_;
};

}  // namespace mm
