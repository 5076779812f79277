// The behavior-tree engine's basic types, with BehaviorTree.CPP v4's semantics (our own code; its
// behaviour was read from BT.CPP 4.10's sources and checked against its traces): node status,
// a dynamically typed value (Any) with BT.CPP's conversion rules, and typed, described ports.
#pragma once
#include <any>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>

namespace mm::bt {

/// BT.CPP's NodeStatus, with its numeric values (the SQLite log stores them).
enum class NodeStatus { kIdle = 0, kRunning = 1, kSuccess = 2, kFailure = 3, kSkipped = 4 };
const char* toString(NodeStatus s);  ///< "IDLE", "RUNNING", "SUCCESS", "FAILURE", "SKIPPED"
inline bool isCompleted(NodeStatus s) { return s == NodeStatus::kSuccess || s == NodeStatus::kFailure; }
inline bool isActive(NodeStatus s) { return s != NodeStatus::kIdle && s != NodeStatus::kSkipped; }

/// A runtime error inside the tree (a script that fails, a port that cannot be read): it ends the
/// trial with a failure of kind "tree", naming the node.
class RuntimeError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};
/// A RuntimeError already prefixed with the node it happened in.
class NodeError : public RuntimeError {
 public:
  using RuntimeError::RuntimeError;
};

/// A value or why there is none.
template <class T>
class Expected {
 public:
  Expected(T v) : value_(std::move(v)) {}  // NOLINT: implicit, like nonstd::expected
  static Expected error(std::string e) {
    Expected x;
    x.error_ = std::move(e);
    return x;
  }
  explicit operator bool() const { return value_.has_value(); }
  const T& value() const {
    if (!value_) throw RuntimeError(error_);
    return *value_;
  }
  const T& operator*() const { return value(); }
  const std::string& error() const { return error_; }

 private:
  Expected() = default;
  std::optional<T> value_;
  std::string error_;
};

/// A dynamically typed value as BT.CPP's Any keeps it: integers (and bools) as int64, reals as
/// double, strings, or any other type; the original C++ type's name is kept for messages and
/// type checks.
class Any {
 public:
  enum class Kind { kEmpty, kInteger, kReal, kString, kOther };
  Any() = default;
  Any(bool v) : kind_(Kind::kInteger), i_(v), type_("bool") {}  // NOLINT
  Any(int v) : kind_(Kind::kInteger), i_(v), type_("int") {}    // NOLINT
  Any(long v) : kind_(Kind::kInteger), i_(v), type_("long") {}  // NOLINT
  Any(unsigned v) : kind_(Kind::kInteger), i_(v), type_("unsigned int") {}  // NOLINT
  Any(double v) : kind_(Kind::kReal), d_(v), type_("double") {}  // NOLINT
  Any(std::string v) : kind_(Kind::kString), s_(std::move(v)), type_("std::string") {}  // NOLINT
  Any(const char* v) : Any(std::string(v)) {}  // NOLINT
  /// A value of another type (a pose, a grasp list), named for messages and type checks.
  template <class T>
  static Any other(T v, std::string type_name) {
    Any a;
    a.kind_ = Kind::kOther;
    a.o_ = std::move(v);
    a.type_ = std::move(type_name);
    return a;
  }

  Kind kind() const { return kind_; }
  bool empty() const { return kind_ == Kind::kEmpty; }
  bool isNumber() const { return kind_ == Kind::kInteger || kind_ == Kind::kReal; }
  bool isString() const { return kind_ == Kind::kString; }
  const std::string& typeName() const { return type_; }
  int64_t integer() const { return i_; }
  double real() const { return kind_ == Kind::kInteger ? static_cast<double>(i_) : d_; }
  const std::string& string() const { return s_; }
  const std::any& other() const { return o_; }
  /// As text: strings as they are, integers by std::to_string, reals as "%f" (BT.CPP's rule).
  std::string toString() const;
  /// The same stored value under another type name (BT.CPP keeps a destination's declared type
  /// when a compatible value is copied into it).
  Any retyped(std::string type_name) const {
    Any a = *this;
    a.type_ = std::move(type_name);
    return a;
  }

 private:
  Kind kind_ = Kind::kEmpty;
  int64_t i_ = 0;
  double d_ = 0;
  std::string s_;
  std::any o_;
  std::string type_;
};

/// How a port's type reads from text and what it is called. An empty name: any type allowed
/// (not strongly typed).
struct TypeInfo {
  std::string name;
  std::function<Any(const std::string&)> parse;  ///< throws RuntimeError on bad text; may be empty
  bool stronglyTyped() const { return !name.empty(); }
};

// ---- conversions (BT.CPP's convertFromString and Any::tryCast) -------------------------------

int64_t parseInteger(const std::string& s, int64_t lo, int64_t hi);  ///< prefix parse, range checked
double parseReal(const std::string& s);
bool parseBool(const std::string& s);  ///< 0 1 true TRUE True false FALSE False
NodeStatus parseStatus(const std::string& s);

/// The type information of T. Specialized here for the built-in types; a node library adds its
/// own types by specializing it (a type without one cannot be written as text in the XML).
template <class T>
TypeInfo typeInfo();
template <> TypeInfo typeInfo<int>();
template <> TypeInfo typeInfo<unsigned>();
template <> TypeInfo typeInfo<long>();
template <> TypeInfo typeInfo<double>();
template <> TypeInfo typeInfo<bool>();
template <> TypeInfo typeInfo<std::string>();
template <> TypeInfo typeInfo<NodeStatus>();
/// No type: any value (SetBlackboard's ports, for instance).
struct AnyTypeAllowed {};
template <> TypeInfo typeInfo<AnyTypeAllowed>();

/// Reads `a` as T by BT.CPP's rules (docs/behavior-trees.md, the port conversions): numbers convert when
/// exact, strings parse, other types must match.
template <class T>
Expected<T> anyCast(const Any& a) {
  if (a.empty()) return Expected<T>::error("the value is empty");
  try {
    if constexpr (std::is_same_v<T, std::string>) {
      if (a.kind() == Any::Kind::kOther) return Expected<T>::error("can't convert [" + a.typeName() + "] to std::string");
      return a.toString();
    } else if constexpr (std::is_same_v<T, Any>) {
      return a;
    } else if constexpr (std::is_same_v<T, bool>) {
      if (a.isString()) return parseBool(a.string());
      if (a.kind() == Any::Kind::kReal) return a.real() != 0.0;
      if (a.kind() == Any::Kind::kInteger) {
        if (a.integer() == 0 || a.integer() == 1) return a.integer() == 1;
        return Expected<T>::error("Implicit casting to bool is not allowed");
      }
    } else if constexpr (std::is_integral_v<T>) {
      if (a.isString())
        return static_cast<T>(parseInteger(a.string(), static_cast<int64_t>(std::numeric_limits<T>::min()),
                                           static_cast<int64_t>(std::numeric_limits<T>::max())));
      int64_t v = 0;
      if (a.kind() == Any::Kind::kReal) {
        if (a.real() != static_cast<double>(static_cast<int64_t>(a.real())))
          return Expected<T>::error("Invalid floating point to integer conversion");
        v = static_cast<int64_t>(a.real());
      } else if (a.kind() == Any::Kind::kInteger) {
        v = a.integer();
      } else {
        return Expected<T>::error("can't convert [" + a.typeName() + "] to an integer");
      }
      if (std::is_unsigned_v<T> && v < 0) return Expected<T>::error("Value is negative and can't be converted to unsigned");
      if (v < static_cast<int64_t>(std::numeric_limits<T>::min()) || v > static_cast<int64_t>(std::numeric_limits<T>::max()))
        return Expected<T>::error("Value out of bound");
      return static_cast<T>(v);
    } else if constexpr (std::is_floating_point_v<T>) {
      if (a.isString()) return static_cast<T>(parseReal(a.string()));
      if (a.isNumber()) return static_cast<T>(a.real());
      return Expected<T>::error("can't convert [" + a.typeName() + "] to a number");
    } else if constexpr (std::is_same_v<T, NodeStatus>) {
      if (a.isString()) return parseStatus(a.string());
      if (a.kind() == Any::Kind::kOther) {
        if (const auto* s = std::any_cast<NodeStatus>(&a.other())) return *s;
      }
      return Expected<T>::error("can't convert [" + a.typeName() + "] to NodeStatus");
    } else {
      if (a.kind() == Any::Kind::kOther) {
        if (const auto* v = std::any_cast<T>(&a.other())) return *v;
        return Expected<T>::error("the value has type [" + a.typeName() + "], not [" + typeInfo<T>().name + "]");
      }
      if (a.isString()) {
        const TypeInfo info = typeInfo<T>();
        if (!info.parse) return Expected<T>::error("[" + info.name + "] can't be written as text");
        const Any parsed = info.parse(a.string());
        if (const auto* v = std::any_cast<T>(&parsed.other())) return *v;
      }
      return Expected<T>::error("can't convert [" + a.typeName() + "] to [" + typeInfo<T>().name + "]");
    }
  } catch (const std::exception& e) {
    return Expected<T>::error(e.what());
  }
  return Expected<T>::error("no conversion");
}

/// Wraps a value of T into an Any (the built-in kinds stay numbers and strings).
template <class T>
Any toAny(const T& v) {
  if constexpr (std::is_same_v<T, Any>) return v;
  else if constexpr (std::is_same_v<T, bool> || std::is_same_v<T, int> || std::is_same_v<T, long> ||
                     std::is_same_v<T, unsigned> || std::is_same_v<T, double> || std::is_same_v<T, std::string>)
    return Any(v);
  else return Any::other(v, typeInfo<T>().name);
}

// ---- ports -----------------------------------------------------------------------------------

enum class PortDirection { kInput, kOutput, kInOut };

/// A node's port: direction, type, meaning and (as text) its default. A port without a default
/// is required (the tree fails to load without it) unless declared optional.
struct PortInfo {
  PortDirection direction = PortDirection::kInput;
  TypeInfo type;
  std::string description;
  std::optional<std::string> default_value;
  bool optional = false;
  bool required() const { return !default_value && !optional; }
};
using PortsList = std::map<std::string, PortInfo>;

template <class T>
std::pair<std::string, PortInfo> inputPort(std::string name, std::string description) {
  return {std::move(name), PortInfo{PortDirection::kInput, typeInfo<T>(), std::move(description), {}, false}};
}
template <class T>
std::pair<std::string, PortInfo> inputPort(std::string name, std::string default_text, std::string description) {
  return {std::move(name), PortInfo{PortDirection::kInput, typeInfo<T>(), std::move(description), std::move(default_text), false}};
}
/// An input that may be left out (getInput then fails and the node decides).
template <class T>
std::pair<std::string, PortInfo> optionalInputPort(std::string name, std::string description) {
  return {std::move(name), PortInfo{PortDirection::kInput, typeInfo<T>(), std::move(description), {}, true}};
}
template <class T>
std::pair<std::string, PortInfo> outputPort(std::string name, std::string description) {
  return {std::move(name), PortInfo{PortDirection::kOutput, typeInfo<T>(), std::move(description), {}, true}};
}
template <class T>
std::pair<std::string, PortInfo> bidirectionalPort(std::string name, std::string description) {
  return {std::move(name), PortInfo{PortDirection::kInOut, typeInfo<T>(), std::move(description), {}, false}};
}

/// "{key}" (spaces around allowed) → key; "{=}" → the port's own name. Else nullopt.
std::optional<std::string> blackboardKey(const std::string& remap, const std::string& port);

}  // namespace mm::bt
