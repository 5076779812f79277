#include "core/params.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "core/error.h"

namespace mm {
namespace {

using K = ParamDecl::Kind;

std::vector<ParamDecl> decls() {
  return {{"name", K::kString, "x", -INFINITY, INFINITY, {}, "", "a name"},
          {"a.n", K::kInt, "3", 1, 10, {}, "", "an int"},
          {"a.v", K::kDouble, "0.5", 0.0, 1.0, {}, "m", "a length"},
          {"a.b.flag", K::kBool, "false", -INFINITY, INFINITY, {}, "", "a flag"},
          {"mode", K::kChoice, "one", -INFINITY, INFINITY, {"one", "two"}, "", "a choice"}};
}

std::string write(const std::string& text) {
  const auto p = std::filesystem::temp_directory_path() / ("mm_params_" + std::to_string(getpid()) + ".yaml");
  std::ofstream(p) << text;
  return p.string();
}

std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(ParamSet, LoadsNestedYamlAndSetOverrides) {
  ParamSet p(decls());
  p.loadYamlFile(write("a:\n  n: 7\n  b:\n    flag: true\nmode: two\n"));
  p.set("a.v", "0.25", "--set a.v");
  EXPECT_EQ(p.getInt("a.n"), 7);
  EXPECT_TRUE(p.getBool("a.b.flag"));
  EXPECT_EQ(p.getString("mode"), "two");
  EXPECT_DOUBLE_EQ(p.getDouble("a.v"), 0.25);
  EXPECT_EQ(p.getString("name"), "x");  // default
  EXPECT_TRUE(p.wasSet("a.n"));
  EXPECT_FALSE(p.wasSet("name"));
}

TEST(ParamSet, ErrorsNameFileLineColumnAndExpectation) {
  const std::string f = write("a:\n  n: 7\n  q: 1\n");
  EXPECT_THAT(errorOf([&] { ParamSet(decls()).loadYamlFile(f); }),
              ::testing::MatchesRegex(".*mm_params_[0-9]+\\.yaml:3:3: unknown key 'a\\.q' \\(known in this section: a\\.n, a\\.v.*"));
  const std::string g = write("a:\n  n: 70\n");
  EXPECT_THAT(errorOf([&] { ParamSet(decls()).loadYamlFile(g); }), ::testing::HasSubstr(":2:3: 'a.n' must be in [1, 10], got 70"));
  const std::string h = write("a:\n  n: 2.5\n");
  EXPECT_THAT(errorOf([&] { ParamSet(decls()).loadYamlFile(h); }), ::testing::HasSubstr("'a.n' expects an integer, got '2.5'"));
  const std::string i = write("a: [1, 2]\n");
  EXPECT_THAT(errorOf([&] { ParamSet(decls()).loadYamlFile(i); }),
              ::testing::HasSubstr(":1:1: 'a' is a section (a.n, a.v, a.b.flag): expected a map of its keys under it, got a list"));
  const std::string i2 = write("a:\n  n: [1, 2]\n");
  EXPECT_THAT(errorOf([&] { ParamSet(decls()).loadYamlFile(i2); }), ::testing::HasSubstr("'a.n' expects a single value, got a list"));
  EXPECT_THAT(errorOf([&] { ParamSet(decls()).set("a.v", "nan", "--set a.v"); }), ::testing::HasSubstr("--set a.v: 'a.v' expects a number, got 'nan'"));
}

TEST(ParamSet, ResolvedYamlReloadsToTheSameValues) {
  ParamSet p(decls());
  p.set("a.n", "9", "test");
  p.set("mode", "two", "test");
  ParamSet q(decls());
  q.loadYamlFile(write(p.toYaml()));
  for (const auto& d : decls()) EXPECT_EQ(p.getString(d.key), q.getString(d.key)) << d.key;
}

TEST(ParamSet, InputIsCheckedWhereItEnters) {
  // A key given twice: YAML forbids it, and a reader that kept one would hide the other.
  const std::string dup = write("name: a\na:\n  n: 2\n  v: 0.1\n  n: 3\n");
  EXPECT_THAT(errorOf([&] { ParamSet(decls()).loadYamlFile(dup); }),
              ::testing::MatchesRegex(".*\\.yaml:5:3: duplicate key 'a\\.n' \\(first at line 3; a key is given once\\)"));
  const std::string top = write("name: a\nmode: one\nname: b\n");
  EXPECT_THAT(errorOf([&] { ParamSet(decls()).loadYamlFile(top); }), ::testing::HasSubstr(":3:1: duplicate key 'name' (first at line 1"));
  // A section given a value says what it is, not "unknown key".
  const std::string scalar = write("a: 5\n");
  EXPECT_THAT(errorOf([&] { ParamSet(decls()).loadYamlFile(scalar); }),
              ::testing::HasSubstr(":1:1: 'a' is a section (a.n, a.v, a.b.flag): expected a map of its keys under it, got the value '5'"));
  // A value given a map.
  const std::string map = write("name:\n  x: 1\n");
  EXPECT_THAT(errorOf([&] { ParamSet(decls()).loadYamlFile(map); }), ::testing::HasSubstr(":1:1: 'name' expects a single value, got a map"));
  // Bytes that are not UTF-8, in a file (Latin-1 e-acute) and through --set: the place and the key.
  const std::string latin1 = write("name: ok\na:\n  v: 0.1\n  n: 2 # caf\xe9\n");
  EXPECT_THAT(errorOf([&] { ParamSet(decls()).loadYamlFile(latin1); }),
              ::testing::HasSubstr(":4:13: the line of 'a.n' is not valid UTF-8 (byte 0xE9; expected UTF-8 text)"));
  EXPECT_THAT(errorOf([&] { ParamSet(decls()).set("name", "r\xc3\x28sult", "--set name"); }),
              ::testing::HasSubstr("--set name: the value of 'name' is not valid UTF-8 (byte 0xC3 at column 2"));
  // Real UTF-8 passes.
  ParamSet ok(decls());
  ok.set("name", "caf\xc3\xa9 \xe2\x9c\x93", "--set name");
  EXPECT_EQ(ok.getString("name"), "caf\xc3\xa9 \xe2\x9c\x93");
}

}  // namespace
}  // namespace mm
