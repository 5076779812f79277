// One declaration per option: every experiment key, given a value other than its default in a
// YAML file or by --set, reaches the struct field it is declared next to, and config.resolved.yaml
// loads back to the same values. Lists, durations and paths included.
#include "core/config.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "campaign/experiment.h"
#include "core/error.h"
#include "planning/time_parameterization.h"

namespace mm {
namespace {

namespace fs = std::filesystem;
using K = ParamDecl::Kind;

// A valid value other than the default.
std::string otherValue(const ParamDecl& d) {
  if (d.key == "shard") return "1/3";  // a text of its own format
  if (d.key == "render.fps") return "50";  // a divisor of the control rate
  switch (d.kind) {
    case K::kInt: {
      const long v = std::stol(d.default_value);
      return std::to_string(v + 1 <= d.max ? v + 1 : v - 1);
    }
    case K::kDouble: {
      const double v = std::stod(d.default_value);
      const double hi = std::isfinite(d.max) ? d.max : v + 2;
      std::ostringstream o;
      o.precision(17);
      o << (v + hi) / 2;
      return o.str();
    }
    case K::kBool: return d.default_value == "true" ? "false" : "true";
    case K::kString: return "another_name";
    case K::kPath: return "elsewhere/file.xml";
    case K::kChoice:
      for (const auto& c : d.choices)
        if (c != d.default_value) return c;
      return d.default_value;
    case K::kIntList: return "1,2";
    case K::kRealList: return std::to_string(std::max(d.min, 0.0)) + "," + std::to_string(std::min(d.max, 0.25));
    case K::kChoiceList: return d.choices.empty() ? "a,b" : d.choices.front() != d.default_value ? d.choices.front() : d.choices.back();
  }
  return "";
}

// The YAML text of one nested key.
std::string yamlOf(const std::string& key, const std::string& value, bool list) {
  std::vector<std::string> parts;
  std::stringstream ss(key);
  for (std::string p; std::getline(ss, p, '.');) parts.push_back(p);
  std::string y;
  for (size_t i = 0; i < parts.size(); ++i) {
    y += std::string(2 * i, ' ') + parts[i] + ":";
    y += i + 1 < parts.size() ? "\n" : " " + (list ? "[" + value + "]" : value) + "\n";
  }
  return y;
}

bool sameValue(const ParamDecl& d, const std::string& a, const std::string& b) {
  if (d.kind == K::kInt || d.kind == K::kDouble) return std::abs(std::stod(a) - std::stod(b)) < 1e-12 * (1 + std::abs(std::stod(a)));
  if (d.kind == K::kRealList || d.kind == K::kIntList) {
    const auto x = splitCommas(a), y = splitCommas(b);
    if (x.size() != y.size()) return false;
    for (size_t i = 0; i < x.size(); ++i)
      if (std::abs(std::stod(x[i]) - std::stod(y[i])) > 1e-12) return false;
    return true;
  }
  if (d.kind == K::kPath) return fs::path(a).filename() == fs::path(b).filename();
  return a == b;
}

// The struct's fields as declarations (their values become the "defaults").
std::map<std::string, std::string> fieldsOf(Experiment& e) {
  std::map<std::string, std::string> out;
  for (const ParamDecl& d : declarationsOf([&](ConfigArchive& a) { e.declare(a); })) out[d.key] = d.default_value;
  return out;
}

class Config : public ::testing::Test {
 protected:
  void TearDown() override { fs::remove_all(dir_); }
  std::string file(const std::string& name, const std::string& text) {
    fs::create_directories(dir_);
    std::ofstream(dir_ / name) << text;
    return (dir_ / name).string();
  }
  fs::path dir_ = fs::temp_directory_path() / ("mm_config_" + std::to_string(getpid()));
};

TEST_F(Config, EveryExperimentKeyRoundTripsThroughYamlSetAndTheResolvedFile) {
  const auto decls = experimentParams();
  ASSERT_GT(decls.size(), 45u);
  const std::string base = file("base.yaml", "name: base\n");
  for (const ParamDecl& d : decls) {
    SCOPED_TRACE(d.key);
    const std::string v = otherValue(d);
    ASSERT_NE(v, d.default_value);
    const bool list = d.isList();
    // A key that needs another (a camera fault, the oracle's segmentation: camera mode) gets it alongside.
    const bool camera = d.key == "faults.camera_blackout" || d.key == "faults.depth_dropout" || d.key == "faults.extrinsics_drift" ||
                        d.key == "perception.segmentation";
    const bool in_perception = d.key.rfind("perception.", 0) == 0;  // then in the same section
    const std::string also = !camera ? "" : in_perception ? "  mode: camera\n" : "perception:\n  mode: camera\n";
    // In a file: the ParamSet holds it and the struct field got it.
    Experiment from_file = loadExperiment(file("one.yaml", yamlOf(d.key, v, list) + also), {});
    EXPECT_TRUE(sameValue(d, from_file.params.getString(d.key), v)) << from_file.params.getString(d.key) << " vs " << v;
    EXPECT_TRUE(sameValue(d, fieldsOf(from_file)[d.key], v)) << fieldsOf(from_file)[d.key] << " vs " << v;
    // By --set.
    std::vector<std::string> sets = {d.key + "=" + v};
    if (camera) sets.push_back("perception.mode=camera");
    Experiment from_set = loadExperiment(base, sets);
    EXPECT_TRUE(sameValue(d, fieldsOf(from_set)[d.key], v)) << fieldsOf(from_set)[d.key] << " vs " << v;
    // config.resolved.yaml reads back to the same values.
    Experiment again = loadExperiment(file("resolved.yaml", from_set.params.toYaml()), {});
    for (const ParamDecl& k : decls)
      EXPECT_TRUE(sameValue(k, again.params.getString(k.key), from_set.params.getString(k.key))) << k.key;
  }
}

TEST_F(Config, ChoiceListsComeFromTheRegistries) {
  const auto decls = experimentParams();
  auto choices = [&](const std::string& key) {
    for (const auto& d : decls)
      if (d.key == key) return d.choices;
    return std::vector<std::string>{};
  };
  EXPECT_EQ(choices("kinematics.solver"), ikSolverNames());
  EXPECT_EQ(choices("planning.planner"), plannerNames());
  EXPECT_EQ(choices("planning.checker"), checkerNames());
  EXPECT_EQ(choices("planning.time_parameterization"), timeParameterizationNames());
}

TEST_F(Config, DurationsAndListsAreReadWithTheirUnits) {
  const Experiment e = loadExperiment(file("d.yaml", "bt:\n  time_budget: 90s\nplanning:\n  time_limit: 250ms\n"
                                                     "grasp:\n  yaw_offsets: [0, 0.2]\n"),
                                      {});
  EXPECT_DOUBLE_EQ(e.tree_run.time_budget, 90);
  EXPECT_DOUBLE_EQ(e.task.planner.time_limit, 0.25);
  EXPECT_EQ(e.task.grasp.yaw_offsets, (std::vector<double>{0, 0.2}));
  EXPECT_THROW(loadExperiment(file("e.yaml", "grasp:\n  yaw_offsets: [0, 2]\n"), {}), InputError);
  EXPECT_THROW(loadExperiment(file("f.yaml", "trials: [1, 2]\n"), {}), InputError);
}

TEST_F(Config, PathsResolveAgainstTheFileTheWorkingDirectoryOrTheProjectRoot) {
  const std::string f = file("paths.yaml", "scene: my_scene.xml\n");
  const Experiment e = loadExperiment(f, {"tree=trees/t.xml"});
  EXPECT_EQ(e.scene_path, (dir_ / "my_scene.xml").lexically_normal().string());         // the file's folder
  EXPECT_EQ(e.tree_path, "trees/t.xml");                                                // --set: the working directory
  EXPECT_EQ(e.robot_path, (fs::path(MINIMANIP_SOURCE_DIR) / "robots/panda/panda.yaml").string());  // default
}

// The oracle's segmentation reads the camera's labels: without camera mode it is bad input, as is a
// source that does not exist.
TEST(ExperimentInput, TheLabelsOracleNeedsCameraMode) {
  try {
    loadExperiment("experiments/clutter_pile.yaml", {"perception.segmentation=labels"});
    ADD_FAILURE() << "perception.segmentation labels accepted with ground-truth perception";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("needs perception.mode camera"), std::string::npos) << e.what();
  }
  EXPECT_THROW(loadExperiment("experiments/clutter_pile.yaml", {"perception.segmentation=colour", "perception.mode=camera"}), InputError);
  EXPECT_NO_THROW(loadExperiment("experiments/clutter_pile.yaml", {"perception.segmentation=labels", "perception.mode=camera"}));
}

}  // namespace
}  // namespace mm
