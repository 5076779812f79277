#include "bt/basic.h"

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdlib>

namespace mm::bt {

const char* toString(NodeStatus s) {
  switch (s) {
    case NodeStatus::kIdle: return "IDLE";
    case NodeStatus::kRunning: return "RUNNING";
    case NodeStatus::kSuccess: return "SUCCESS";
    case NodeStatus::kFailure: return "FAILURE";
    case NodeStatus::kSkipped: return "SKIPPED";
  }
  return "?";
}

std::string Any::toString() const {
  switch (kind_) {
    case Kind::kEmpty: return "";
    case Kind::kInteger: return std::to_string(i_);
    case Kind::kReal: return std::to_string(d_);
    case Kind::kString: return s_;
    case Kind::kOther: return "[" + type_ + "]";
  }
  return "";
}

// BT.CPP reads integers with from_chars: a prefix parse (trailing characters are ignored), no
// leading '+' or space.
int64_t parseInteger(const std::string& s, int64_t lo, int64_t hi) {
  int64_t v = 0;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec == std::errc::result_out_of_range) throw RuntimeError("Value out of bound when converting [" + s + "] to integer");
  if (ec != std::errc() || ptr == s.data()) throw RuntimeError("Can't convert string [" + s + "] to integer");
  if (v < lo || v > hi) throw RuntimeError("Value out of bound when converting [" + s + "] to integer");
  return v;
}

double parseReal(const std::string& s) {
  if (s.empty() || s[0] == '+' || std::isspace(static_cast<unsigned char>(s[0])))
    throw RuntimeError("Can't convert string [" + s + "] to double");
  // strtod also takes hex, which from_chars(general) does not.
  if (s.size() > 1 && s[0] == '0' && (s[1] == 'x' || s[1] == 'X')) return 0.0;
  if (s.size() > 2 && s[0] == '-' && s[1] == '0' && (s[2] == 'x' || s[2] == 'X')) return -0.0;
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(s.c_str(), &end);
  if (end == s.c_str()) throw RuntimeError("Can't convert string [" + s + "] to double");
  return v;
}

bool parseBool(const std::string& s) {
  if (s == "1" || s == "true" || s == "TRUE" || s == "True") return true;
  if (s == "0" || s == "false" || s == "FALSE" || s == "False") return false;
  throw RuntimeError("convertFromString(): invalid bool conversion");
}

NodeStatus parseStatus(const std::string& s) {
  for (NodeStatus st : {NodeStatus::kIdle, NodeStatus::kRunning, NodeStatus::kSuccess, NodeStatus::kFailure,
                        NodeStatus::kSkipped})
    if (s == toString(st)) return st;
  throw RuntimeError("Cannot convert this to NodeStatus: " + s);
}

template <>
TypeInfo typeInfo<int>() {
  return {"int", [](const std::string& s) { return Any(static_cast<int>(parseInteger(s, INT32_MIN, INT32_MAX))); }};
}
template <>
TypeInfo typeInfo<unsigned>() {
  return {"unsigned int", [](const std::string& s) { return Any(static_cast<unsigned>(parseInteger(s, 0, UINT32_MAX))); }};
}
template <>
TypeInfo typeInfo<long>() {
  return {"long", [](const std::string& s) { return Any(static_cast<long>(parseInteger(s, INT64_MIN, INT64_MAX))); }};
}
template <>
TypeInfo typeInfo<double>() {
  return {"double", [](const std::string& s) { return Any(parseReal(s)); }};
}
template <>
TypeInfo typeInfo<bool>() {
  return {"bool", [](const std::string& s) { return Any(parseBool(s)); }};
}
template <>
TypeInfo typeInfo<std::string>() {
  return {"std::string", [](const std::string& s) { return Any(s); }};
}
template <>
TypeInfo typeInfo<NodeStatus>() {
  return {"BT::NodeStatus", [](const std::string& s) { return Any::other(parseStatus(s), "BT::NodeStatus"); }};
}
template <>
TypeInfo typeInfo<AnyTypeAllowed>() {
  return {};
}

std::optional<std::string> blackboardKey(const std::string& remap, const std::string& port) {
  size_t a = remap.find_first_not_of(" \t");
  size_t b = remap.find_last_not_of(" \t");
  if (a == std::string::npos || remap[a] != '{' || remap[b] != '}' || b < a + 1) {
    if (remap == "=") return port;
    return std::nullopt;
  }
  std::string key = remap.substr(a + 1, b - a - 1);
  if (key == "=") return port;
  if (key.empty()) return std::nullopt;
  return key;
}

}  // namespace mm::bt
