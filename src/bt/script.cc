#include "bt/script.h"

#include <cctype>
#include <cfloat>
#include <charconv>
#include <cmath>

namespace mm::bt {

// ---- tokens ----------------------------------------------------------------------------------

namespace {

enum class Tok {
  kEnd, kError, kInteger, kReal, kString, kBoolean, kName,
  kColonEq, kEq, kPlusEq, kMinusEq, kStarEq, kSlashEq,  // assignments
  kQuestion, kColon, kOrOr, kAndAnd,
  kEqEq, kNotEq, kLess, kGreater, kLessEq, kGreaterEq,  // comparisons
  kPipe, kCaret, kAmp, kPlus, kMinus, kDotDot, kStar, kSlash, kTilde, kBang,
  kLParen, kRParen, kSemicolon,
};

struct Token {
  Tok type;
  std::string text;
  size_t pos;
};

bool identStart(char c) { return std::isalpha(static_cast<unsigned char>(c)) || c == '_' || c == '@'; }
bool identChar(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

std::vector<Token> tokenize(const std::string& s) {
  std::vector<Token> out;
  size_t i = 0;
  const size_t n = s.size();
  auto at = [&](size_t k) { return k < n ? s[k] : '\0'; };
  while (i < n) {
    const char c = s[i];
    if (c == ' ' || c == '\t' || c == '\n' || c == '\r') {
      ++i;
      continue;
    }
    const size_t start = i;
    if (c == '\'') {
      const size_t close = s.find('\'', i + 1);
      if (close == std::string::npos) {
        out.push_back({Tok::kError, s.substr(i), start});
        break;
      }
      out.push_back({Tok::kString, s.substr(i + 1, close - i - 1), start});
      i = close + 1;
      continue;
    }
    if (std::isdigit(static_cast<unsigned char>(c))) {
      bool real = false, bad = false;
      if (c == '0' && (at(i + 1) == 'x' || at(i + 1) == 'X')) {
        i += 2;
        const size_t digits = i;
        while (std::isxdigit(static_cast<unsigned char>(at(i)))) ++i;
        bad = i == digits;
      } else {
        while (std::isdigit(static_cast<unsigned char>(at(i)))) ++i;
        if (at(i) == '.' && at(i + 1) != '.') {  // "65..x" is 65 then ".."
          ++i;
          if (!std::isdigit(static_cast<unsigned char>(at(i)))) bad = true;
          while (std::isdigit(static_cast<unsigned char>(at(i)))) ++i;
          real = true;
        }
        if (!bad && (at(i) == 'e' || at(i) == 'E')) {
          ++i;
          if (at(i) == '+' || at(i) == '-') ++i;
          if (!std::isdigit(static_cast<unsigned char>(at(i)))) bad = true;
          while (std::isdigit(static_cast<unsigned char>(at(i)))) ++i;
          real = true;
        }
      }
      if (identChar(at(i)) || (at(i) == '.' && at(i + 1) != '.')) {
        bad = true;
        while (identChar(at(i)) || at(i) == '.') ++i;
      }
      out.push_back({bad ? Tok::kError : (real ? Tok::kReal : Tok::kInteger), s.substr(start, i - start), start});
      continue;
    }
    if (identStart(c)) {
      ++i;
      while (identChar(at(i))) ++i;
      std::string word = s.substr(start, i - start);
      out.push_back({word == "true" || word == "false" ? Tok::kBoolean : Tok::kName, word, start});
      continue;
    }
    static const std::pair<const char*, Tok> kTwo[] = {
        {"..", Tok::kDotDot}, {"&&", Tok::kAndAnd}, {"||", Tok::kOrOr}, {"==", Tok::kEqEq}, {"!=", Tok::kNotEq},
        {"<=", Tok::kLessEq}, {">=", Tok::kGreaterEq}, {":=", Tok::kColonEq}, {"+=", Tok::kPlusEq},
        {"-=", Tok::kMinusEq}, {"*=", Tok::kStarEq}, {"/=", Tok::kSlashEq}};
    bool matched = false;
    for (const auto& [text, type] : kTwo)
      if (s.compare(i, 2, text) == 0) {
        out.push_back({type, text, start});
        i += 2;
        matched = true;
        break;
      }
    if (matched) continue;
    static const std::pair<char, Tok> kOne[] = {
        {'+', Tok::kPlus}, {'-', Tok::kMinus}, {'*', Tok::kStar}, {'/', Tok::kSlash}, {'&', Tok::kAmp},
        {'|', Tok::kPipe}, {'^', Tok::kCaret}, {'~', Tok::kTilde}, {'!', Tok::kBang}, {'<', Tok::kLess},
        {'>', Tok::kGreater}, {'=', Tok::kEq}, {'?', Tok::kQuestion}, {':', Tok::kColon}, {'(', Tok::kLParen},
        {')', Tok::kRParen}, {';', Tok::kSemicolon}};
    for (const auto& [ch, type] : kOne)
      if (c == ch) {
        out.push_back({type, std::string(1, c), start});
        ++i;
        matched = true;
        break;
      }
    if (!matched) {
      out.push_back({Tok::kError, std::string(1, c), start});
      break;
    }
  }
  out.push_back({Tok::kEnd, "", n});
  return out;
}

}  // namespace

// ---- syntax tree -----------------------------------------------------------------------------

struct Script::Node {
  enum class Kind { kLiteral, kName, kUnary, kBinary, kComparison, kTernary, kAssign } kind;
  Any value;         // literal
  std::string name;  // name
  Tok op = Tok::kEnd;                         // unary, binary, assignment
  std::vector<Tok> ops;                       // comparison
  std::vector<std::shared_ptr<const Node>> operands;
};

namespace {

using NodePtr = std::shared_ptr<const Script::Node>;
using Kind = Script::Node::Kind;

constexpr int kAssignBP = 2, kTernaryBP = 4, kComparisonBP = 10, kPrefixBP = 20;

int leftBindingPower(Tok t) {
  switch (t) {
    case Tok::kColonEq: case Tok::kEq: case Tok::kPlusEq: case Tok::kMinusEq: case Tok::kStarEq: case Tok::kSlashEq:
      return kAssignBP;
    case Tok::kQuestion: return kTernaryBP;
    case Tok::kOrOr: return 6;
    case Tok::kAndAnd: return 8;
    case Tok::kEqEq: case Tok::kNotEq: case Tok::kLess: case Tok::kGreater: case Tok::kLessEq: case Tok::kGreaterEq:
      return kComparisonBP;
    case Tok::kPipe: case Tok::kCaret: return 12;
    case Tok::kAmp: return 14;
    case Tok::kPlus: case Tok::kMinus: case Tok::kDotDot: return 16;
    case Tok::kStar: case Tok::kSlash: return 18;
    default: return -1;
  }
}
bool isComparison(Tok t) { return leftBindingPower(t) == kComparisonBP; }
bool isAssignment(Tok t) { return leftBindingPower(t) == kAssignBP; }

const char* opText(Tok t) {
  switch (t) {
    case Tok::kColonEq: return ":=";
    case Tok::kEq: return "=";
    case Tok::kPlusEq: return "+=";
    case Tok::kMinusEq: return "-=";
    case Tok::kStarEq: return "*=";
    case Tok::kSlashEq: return "/=";
    case Tok::kOrOr: return "||";
    case Tok::kAndAnd: return "&&";
    case Tok::kEqEq: return "==";
    case Tok::kNotEq: return "!=";
    case Tok::kLess: return "<";
    case Tok::kGreater: return ">";
    case Tok::kLessEq: return "<=";
    case Tok::kGreaterEq: return ">=";
    case Tok::kPipe: return "|";
    case Tok::kCaret: return "^";
    case Tok::kAmp: return "&";
    case Tok::kPlus: return "+";
    case Tok::kMinus: return "-";
    case Tok::kDotDot: return "..";
    case Tok::kStar: return "*";
    case Tok::kSlash: return "/";
    default: return "?";
  }
}

class Parser {
 public:
  explicit Parser(std::vector<Token> tokens) : t_(std::move(tokens)) {}

  std::vector<NodePtr> statements() {
    std::vector<NodePtr> out;
    while (peek().type != Tok::kEnd) {
      out.push_back(expr(0));
      while (peek().type == Tok::kSemicolon) advance();
    }
    return out;
  }

 private:
  const Token& peek() const { return t_[k_]; }
  const Token& advance() {
    const Token& t = t_[k_];
    if (t.type != Tok::kEnd) ++k_;
    return t;
  }
  [[noreturn]] static void error(const std::string& what) { throw RuntimeError(what); }
  void expect(Tok type, const char* what) {
    if (peek().type != type)
      error("Parse error at position " + std::to_string(peek().pos) + ": " + what + " (got '" + peek().text + "')");
    advance();
  }
  static NodePtr make(Script::Node n) { return std::make_shared<const Script::Node>(std::move(n)); }

  NodePtr prefix() {
    const Token tok = peek();
    Script::Node n;
    switch (tok.type) {
      case Tok::kMinus: case Tok::kTilde: case Tok::kBang:
        advance();
        n.kind = Kind::kUnary;
        n.op = tok.type;
        n.operands.push_back(expr(kPrefixBP));
        return make(std::move(n));
      case Tok::kLParen: {
        advance();
        NodePtr inner = expr(0);
        expect(Tok::kRParen, "expected ')'");
        return inner;
      }
      case Tok::kBoolean:
        advance();
        n.kind = Kind::kLiteral;
        n.value = Any(tok.text == "true" ? 1.0 : 0.0);
        return make(std::move(n));
      case Tok::kInteger: {
        advance();
        long v = 0;
        const bool hex = tok.text.size() > 2 && (tok.text[1] == 'x' || tok.text[1] == 'X');
        const char* first = tok.text.data() + (hex ? 2 : 0);
        std::from_chars(first, tok.text.data() + tok.text.size(), v, hex ? 16 : 10);
        n.kind = Kind::kLiteral;
        n.value = Any(v);
        return make(std::move(n));
      }
      case Tok::kReal:
        advance();
        n.kind = Kind::kLiteral;
        n.value = Any(parseReal(tok.text));
        return make(std::move(n));
      case Tok::kString:
        advance();
        n.kind = Kind::kLiteral;
        n.value = Any(tok.text);
        return make(std::move(n));
      case Tok::kName:
        advance();
        n.kind = Kind::kName;
        n.name = tok.text;
        return make(std::move(n));
      case Tok::kError:
        error("Invalid token '" + tok.text + "' at position " + std::to_string(tok.pos));
      default:
        error("Expected operand at position " + std::to_string(tok.pos) + " (got '" + tok.text + "')");
    }
  }

  NodePtr expr(int min_bp) {
    NodePtr left = prefix();
    for (;;) {
      const Tok op = peek().type;
      const int lbp = leftBindingPower(op);
      if (lbp < 0 || lbp < min_bp) break;
      if (isAssignment(op)) {  // right side: a whole expression; not associative
        advance();
        Script::Node n;
        n.kind = Kind::kAssign;
        n.op = op;
        n.operands = {left, expr(0)};
        left = make(std::move(n));
        break;
      }
      if (op == Tok::kQuestion) {
        advance();
        Script::Node n;
        n.kind = Kind::kTernary;
        NodePtr then = expr(0);
        expect(Tok::kColon, "expected ':' in ternary expression");
        n.operands = {left, then, expr(kTernaryBP)};
        left = make(std::move(n));
        break;
      }
      if (isComparison(op)) {  // a chain: operands above the comparisons' level
        Script::Node n;
        n.kind = Kind::kComparison;
        n.operands.push_back(left);
        while (isComparison(peek().type)) {
          n.ops.push_back(advance().type);
          n.operands.push_back(expr(kComparisonBP + 1));
        }
        left = make(std::move(n));
        continue;
      }
      advance();
      Script::Node n;
      n.kind = Kind::kBinary;
      n.op = op;
      n.operands = {left, expr(lbp + 1)};
      left = make(std::move(n));
    }
    return left;
  }

  std::vector<Token> t_;
  size_t k_ = 0;
};

// ---- evaluation ------------------------------------------------------------------------------

std::string notInitialized(const char* side, const char* op) {
  return std::string("The ") + side + " operand of the operator [" + op + "] is not initialized";
}

double stringToDouble(const Any& v, const ScriptEnv& env) {
  const std::string& s = v.string();
  if (s == "true") return 1.0;
  if (s == "false") return 0.0;
  if (env.enums)
    if (auto it = env.enums->find(s); it != env.enums->end()) return it->second;
  double d = 0;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), d);
  if (ec != std::errc() || ptr == s.data()) throw RuntimeError("Any failed string to number conversion");
  return d;
}

int64_t exactInteger(const Any& v, const char* what) {
  const double x = v.real();
  if (v.kind() == Any::Kind::kInteger) return v.integer();
  if (x != std::floor(x) || std::abs(x) > 9.2e18) throw RuntimeError(what);
  return static_cast<int64_t>(x);
}

// Copies `value` into `dst` as BT.CPP's Any::copyInto: an empty destination takes it as it is;
// the same stored kind is copied (the destination keeps its type name); a number converts to the
// destination's kind when exact.
void copyInto(const Any& value, Any& dst) {
  if (dst.empty()) {
    dst = value;
    return;
  }
  if (value.kind() == dst.kind() && (dst.kind() != Any::Kind::kOther || value.typeName() == dst.typeName())) {
    dst = value.retyped(dst.typeName());
    return;
  }
  if (value.isNumber() && dst.isNumber()) {
    if (dst.kind() == Any::Kind::kReal) {
      dst = Any(value.real()).retyped(dst.typeName());
      return;
    }
    const double x = value.real();
    if (value.kind() == Any::Kind::kReal && (!std::isfinite(x) || x != std::floor(x) || std::abs(x) > 9.2e18))
      throw RuntimeError("Invalid floating point to integer conversion");
    dst = Any(value.kind() == Any::Kind::kInteger ? value.integer() : static_cast<long>(x)).retyped(dst.typeName());
    return;
  }
  throw RuntimeError("Any::copyInto fails");
}

Any evaluate(const Script::Node& n, const ScriptEnv& env);

Any evalBinary(const Script::Node& n, const ScriptEnv& env) {
  const Any l = evaluate(*n.operands[0], env), r = evaluate(*n.operands[1], env);
  const char* op = opText(n.op);
  if (l.empty()) throw RuntimeError(notInitialized("left", op));
  if (r.empty()) throw RuntimeError(notInitialized("right", op));
  if (l.isNumber() && r.isNumber()) {
    const double a = l.real(), b = r.real();
    switch (n.op) {
      case Tok::kPlus: return Any(a + b);
      case Tok::kMinus: return Any(a - b);
      case Tok::kStar: return Any(a * b);
      case Tok::kSlash: return Any(a / b);
      case Tok::kAmp: case Tok::kPipe: case Tok::kCaret: {
        const char* why = "Binary operators are not allowed if one of the operands is not an integer";
        const int64_t x = exactInteger(l, why), y = exactInteger(r, why);
        const int64_t z = n.op == Tok::kAmp ? (x & y) : n.op == Tok::kPipe ? (x | y) : (x ^ y);
        return Any(static_cast<double>(z));
      }
      case Tok::kAndAnd: case Tok::kOrOr: {
        const char* why = "Logic operators are not allowed if one of the operands is not castable to bool";
        auto truth = [&](const Any& v) {
          if (v.kind() == Any::Kind::kReal) return v.real() != 0.0;
          if (v.integer() != 0 && v.integer() != 1) throw RuntimeError(why);
          return v.integer() == 1;
        };
        const bool x = truth(l), y = truth(r);
        return Any(static_cast<double>(n.op == Tok::kAndAnd ? (x && y) : (x || y)));
      }
      default: return {};  // number .. number: empty (BT.CPP)
    }
  }
  if (l.isString() && r.isString() && n.op == Tok::kPlus) return Any(l.string() + r.string());
  if (n.op == Tok::kDotDot && (l.isString() || l.isNumber()) && (r.isString() || r.isNumber()))
    return Any(l.toString() + r.toString());
  throw RuntimeError("Operation not permitted");
}

Any evalComparison(const Script::Node& n, const ScriptEnv& env) {
  auto holds = [](auto a, auto b, Tok op) {
    switch (op) {
      case Tok::kEqEq: return a == b;
      case Tok::kNotEq: return !(a == b);
      case Tok::kLess: return a < b;
      case Tok::kGreater: return a > b;
      case Tok::kLessEq: return a <= b;
      default: return a >= b;
    }
  };
  struct Real {  // equality within FLT_EPSILON, as BT.CPP's IsSame for numbers
    double v;
    bool operator==(const Real& o) const { return std::abs(v - o.v) <= static_cast<double>(FLT_EPSILON); }
    bool operator<(const Real& o) const { return v < o.v; }
    bool operator>(const Real& o) const { return v > o.v; }
    bool operator<=(const Real& o) const { return v <= o.v; }
    bool operator>=(const Real& o) const { return v >= o.v; }
  };
  Any l = evaluate(*n.operands[0], env);
  for (size_t i = 0; i < n.ops.size(); ++i) {
    Any r = evaluate(*n.operands[i + 1], env);
    const char* op = opText(n.ops[i]);
    if (l.empty()) throw RuntimeError(notInitialized("left", op));
    if (r.empty()) throw RuntimeError(notInitialized("right", op));
    bool ok;
    if (l.isNumber() && r.isNumber()) ok = holds(Real{l.real()}, Real{r.real()}, n.ops[i]);
    else if (l.isString() && r.isString()) ok = holds(l.string(), r.string(), n.ops[i]);
    else if (l.isString() && r.isNumber()) ok = holds(Real{stringToDouble(l, env)}, Real{r.real()}, n.ops[i]);
    else if (l.isNumber() && r.isString()) ok = holds(Real{l.real()}, Real{stringToDouble(r, env)}, n.ops[i]);
    else
      throw RuntimeError("Can't mix different types in Comparison. Left operand [" + l.typeName() + "] right operand [" +
                         r.typeName() + "]");
    if (!ok) return Any(0.0);
    l = r;
  }
  return Any(1.0);
}

Any evalAssign(const Script::Node& n, const ScriptEnv& env) {
  if (n.operands[0]->kind != Kind::kName) throw RuntimeError("Assignment left operand not a blackboard entry");
  const std::string& key = n.operands[0]->name;
  Blackboard::Entry* entry = env.vars->getEntry(key);
  if (!entry) {
    if (n.op != Tok::kColonEq)
      throw RuntimeError("The blackboard entry [" + key +
                         "] doesn't exist, yet.\nIf you want to create a new one, use the operator [:=] instead of [=]");
    entry = env.vars->createEntry(key, TypeInfo{});  // created before the right side is evaluated
  }
  const Any value = evaluate(*n.operands[1], env);
  Any& dst = entry->value;
  const char* op = opText(n.op);
  auto prefix = [&] { return "Error assigning a value to entry [" + key + "] with type [" + dst.typeName() + "]. "; };
  if (value.empty()) throw RuntimeError(notInitialized("right", op));
  if (n.op == Tok::kColonEq || n.op == Tok::kEq) {
    if (dst.empty() && !entry->info.stronglyTyped()) {
      dst = value;
    } else if (value.isString() && !dst.isString()) {
      if (entry->info.parse) dst = entry->info.parse(value.string());
      else if (dst.isNumber()) dst = Any(stringToDouble(value, env));
      else throw RuntimeError(prefix() + "\nThe right operand is a string, can't convert to " + dst.typeName());
    } else {
      try {
        copyInto(value, dst);
      } catch (const RuntimeError&) {
        throw RuntimeError(prefix() + "\nThe right operand has type [" + value.typeName() +
                           "] and can't be converted to [" + dst.typeName() + "]");
      }
    }
    ++entry->sequence;
    return dst;
  }
  if (dst.empty()) throw RuntimeError(notInitialized("left", op));
  Any result;
  if (value.isNumber()) {
    if (!dst.isNumber()) throw RuntimeError("This Assignment operator can't be used with a non-numeric type");
    const double a = dst.real(), b = value.real();
    result = Any(n.op == Tok::kPlusEq ? a + b : n.op == Tok::kMinusEq ? a - b : n.op == Tok::kStarEq ? a * b : a / b);
  } else if (value.isString()) {
    if (n.op != Tok::kPlusEq) throw RuntimeError("Operator not supported for strings");
    result = Any(dst.toString() + value.string());
  }
  copyInto(result, dst);
  ++entry->sequence;
  return dst;
}

Any evaluate(const Script::Node& n, const ScriptEnv& env) {
  switch (n.kind) {
    case Kind::kLiteral: return n.value;
    case Kind::kName: {
      if (env.enums)
        if (auto it = env.enums->find(n.name); it != env.enums->end()) return Any(static_cast<double>(it->second));
      const Blackboard::Entry* e = env.vars ? env.vars->getEntry(n.name) : nullptr;
      if (!e) throw RuntimeError("Variable not found: " + n.name);
      return e->value;
    }
    case Kind::kUnary: {
      const Any v = evaluate(*n.operands[0], env);
      if (v.isNumber()) {
        const double x = v.real();
        if (n.op == Tok::kMinus) return Any(-x);
        if (n.op == Tok::kBang) return Any(static_cast<double>(!static_cast<bool>(x)));
        if (std::abs(x) > 9.2e18) throw RuntimeError("Number out of range for bitwise operation");
        return Any(static_cast<double>(~static_cast<int64_t>(x)));
      }
      if (v.isString()) throw RuntimeError("Invalid operator for std::string");
      throw RuntimeError("ExprUnaryArithmetic: undefined");
    }
    case Kind::kBinary: return evalBinary(n, env);
    case Kind::kComparison: return evalComparison(n, env);
    case Kind::kTernary: {
      const Any c = evaluate(*n.operands[0], env);
      bool yes;
      if (c.isString()) {  // BT.CPP reads the string as a number
        double d = 0;
        const auto [p, ec] = std::from_chars(c.string().data(), c.string().data() + c.string().size(), d);
        if (ec != std::errc() || p == c.string().data()) throw RuntimeError("Any failed string to number conversion");
        yes = d != 0.0;
      } else if (c.isNumber()) {
        yes = c.real() != 0.0;
      }
      else throw RuntimeError("the condition of ?: is not a number");
      return evaluate(*n.operands[yes ? 1 : 2], env);
    }
    case Kind::kAssign: return evalAssign(n, env);
  }
  return {};
}

}  // namespace

Script Script::parse(const std::string& code) {
  Script s;
  s.code_ = code;
  bool blank = true;
  for (char c : code) blank &= std::isspace(static_cast<unsigned char>(c)) != 0;
  if (blank) throw RuntimeError("Empty Script");
  s.statements_ = Parser(tokenize(code)).statements();
  return s;
}

Any Script::run(ScriptEnv env) const {
  Any last;
  for (const auto& st : statements_) last = evaluate(*st, env);
  return last;
}

bool scriptTruth(const Any& v) {
  if (v.kind() == Any::Kind::kReal) return v.real() != 0.0;
  if (v.kind() == Any::Kind::kInteger) {
    if (v.integer() == 0 || v.integer() == 1) return v.integer() == 1;
    throw RuntimeError("Implicit casting to bool is not allowed");
  }
  if (v.isString()) throw RuntimeError("[Any::convert]: no known safe conversion between [std::string] and [bool]");
  throw RuntimeError("the script's value is empty");
}

}  // namespace mm::bt
