// BT.CPP v4's script language (as of 4.10: tokenizer + Pratt parser), our own implementation:
//   statements separated by ';' (optional), values: integers (decimal, 0x hex), reals, 'strings',
//   true/false; names read the blackboard (@name: the root's) or a registered enum;
//   operators by binding power: := = += -= *= /= (2) ?: (4) || (6) && (8)
//   == != < > <= >= (10, chained: a < b < c is (a<b) && (b<c)) | ^ (12) & (14) + - .. (16)
//   * / (18), prefix - ~ ! (20), parentheses.
// Arithmetic gives reals; && and || evaluate both sides; == on numbers allows FLT_EPSILON.
#pragma once
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "bt/basic.h"
#include "bt/blackboard.h"

namespace mm::bt {

using ScriptEnums = std::map<std::string, int>;

struct ScriptEnv {
  Blackboard* vars = nullptr;
  const ScriptEnums* enums = nullptr;
};

class Script {
 public:
  /// Parses `code`; throws RuntimeError with the position of the first error.
  static Script parse(const std::string& code);
  /// Runs every statement; returns the last one's value. Throws RuntimeError on a runtime error.
  Any run(ScriptEnv env) const;
  const std::string& code() const { return code_; }

  struct Node;

 private:
  std::string code_;
  std::vector<std::shared_ptr<const Node>> statements_;
};

/// A script's value read as a condition: reals are true when nonzero, integers must be 0 or 1,
/// strings are an error (BT.CPP's cast<bool>).
bool scriptTruth(const Any& v);

}  // namespace mm::bt
