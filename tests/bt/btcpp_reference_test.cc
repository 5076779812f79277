// Differential test against BehaviorTree.CPP itself: tests/bt/btcpp_reference/ holds 54 trees and
// the transitions BT.CPP 4.10.0 produced for each (built outside this repository from a fetched
// snapshot and run by a small tracer linking it; see that folder's README). Our engine runs the
// same trees with the same three test nodes and must print the same trace: every status
// transition with its node's UID and path, per tick, the re-ticks after a wake-up signal, the
// halts, and the root blackboard at the end. Error trees must fail the same way (at load or at a
// tick), except where we reject at load what BT.CPP only finds when ticking (listed below).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "bt/factory.h"
#include "core/error.h"

namespace mm::bt {
namespace {

namespace fs = std::filesystem;
const fs::path kDir = "tests/bt/btcpp_reference";

// The tracer's test nodes, with the same ports and behaviour.
class TestAction final : public StatefulActionNode {
 public:
  using StatefulActionNode::StatefulActionNode;
  static PortsList providedPorts() {
    return {inputPort<int>("ticks", "0", "number of RUNNING ticks before completing"),
            inputPort<std::string>("result", "SUCCESS", "SUCCESS or FAILURE")};
  }

 protected:
  NodeStatus onStart() override {
    const int ticks = getInput<int>("ticks").value();
    if (ticks <= 0) return result();
    remaining_ = ticks;
    return NodeStatus::kRunning;
  }
  NodeStatus onRunning() override { return --remaining_ <= 0 ? result() : NodeStatus::kRunning; }
  void onHalted() override {}

 private:
  NodeStatus result() const {
    const std::string r = getInput<std::string>("result").value();
    if (r == "SUCCESS") return NodeStatus::kSuccess;
    if (r == "FAILURE") return NodeStatus::kFailure;
    throw RuntimeError("TestAction: invalid result [" + r + "], expected SUCCESS or FAILURE");
  }
  int remaining_ = 0;
};

class TestCondition final : public ConditionNode {
 public:
  using ConditionNode::ConditionNode;
  static PortsList providedPorts() { return {inputPort<bool>("value", "condition value")}; }

 protected:
  NodeStatus tick() override { return getInput<bool>("value").value() ? NodeStatus::kSuccess : NodeStatus::kFailure; }
};

class Counter final : public SyncActionNode {
 public:
  using SyncActionNode::SyncActionNode;
  static PortsList providedPorts() { return {bidirectionalPort<int>("value", "incremented by one at each tick")}; }

 protected:
  NodeStatus tick() override {
    const auto v = getInput<int>("value");
    if (const auto err = setOutput("value", (v ? *v : 0) + 1)) throw RuntimeError(*err);
    return NodeStatus::kSuccess;
  }
};

std::string oneLine(std::string s) {
  std::string out;
  for (char c : s) {
    if (c == '\n') out += "\\n";
    else if (c != '\r') out += c;
  }
  return out;
}

struct Trace {
  std::vector<std::string> lines;
  bool load_error = false, tick_error = false;
};

Trace runTrace(const fs::path& xml, int max_ticks) {
  Trace t;
  Factory f;
  f.registerNodeType<TestAction>("TestAction");
  f.registerNodeType<TestCondition>("TestCondition");
  f.registerNodeType<Counter>("Counter");
  std::unique_ptr<Tree> tree;
  try {
    tree = f.instantiate(f.load(xml.string()));
  } catch (const InputError& e) {
    t.lines.push_back("ERROR " + oneLine(e.what()));
    t.load_error = true;
    return t;
  }
  std::string label;
  tree->addObserver([&](const TreeNode& n, NodeStatus prev, NodeStatus now) {
    t.lines.push_back(label + " " + std::to_string(n.uid()) + " " + n.fullPath() + " " + toString(prev) + "->" + toString(now));
  });
  for (int k = 0; k < max_ticks; ++k) {
    label = "T" + std::to_string(k);
    NodeStatus s;
    try {
      s = tree->tickOnce(1000, [&] { t.lines.push_back("# " + label + " retick"); });
    } catch (const std::exception& e) {
      t.lines.push_back(label + " exception=" + oneLine(e.what()));
      t.tick_error = true;
      break;
    }
    t.lines.push_back(label + " root=" + toString(s));
    if (s != NodeStatus::kRunning) break;
  }
  if (tree->root()->status() == NodeStatus::kRunning || t.tick_error) {
    label = "H";
    try {
      tree->haltTree();
    } catch (const std::exception& e) {
      t.lines.push_back("H exception=" + oneLine(e.what()));
    }
  }
  Blackboard& bb = tree->rootBlackboard();
  for (const std::string& key : bb.localKeys()) {
    const Any& v = bb.getEntry(key)->value;
    t.lines.push_back("BB " + key + "=" +
                      (v.empty() ? "<empty>" : v.kind() == Any::Kind::kOther ? "<" + v.typeName() + ">" : oneLine(v.toString())));
  }
  return t;
}

struct Case {
  std::string name;
  int ticks = 50;
  int btcpp_exit = 0;
};

std::vector<Case> cases() {
  std::vector<Case> out;
  std::ifstream in(kDir / "INDEX.tsv");
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    std::stringstream s(line);
    std::string file, args, exit;
    std::getline(s, file, '\t');
    std::getline(s, args, '\t');
    std::getline(s, exit, '\t');
    Case c;
    c.name = file.substr(0, file.size() - 4);
    if (args.rfind("--ticks ", 0) == 0) c.ticks = std::stoi(args.substr(8));
    c.btcpp_exit = std::stoi(exit);
    out.push_back(c);
  }
  return out;
}

std::vector<std::string> readLines(const fs::path& p) {
  std::vector<std::string> v;
  std::ifstream in(p);
  for (std::string l; std::getline(in, l);) v.push_back(l);
  return v;
}

class BtcppReference : public ::testing::TestWithParam<Case> {};

TEST_P(BtcppReference, SameTraceAsBehaviorTreeCpp) {
  const Case& c = GetParam();
  const auto expected = readLines(kDir / (c.name + ".out"));
  const Trace got = runTrace(kDir / (c.name + ".xml"), c.ticks);
  std::ostringstream diff;
  for (const auto& l : got.lines) diff << "  " << l << "\n";
  if (c.name == "16b_setblackboard_untyped_bug") {
    // BT.CPP 4.10 loses a literal SetBlackboard writes into an entry an untyped port declared
    // (TypeInfo::parseString of AnyTypeAllowed yields an empty value): a bug we do not copy.
    EXPECT_EQ(got.lines.back(), "BB answer_copy=42") << diff.str();
    EXPECT_EQ(got.lines[got.lines.size() - 3], "T0 root=SUCCESS") << diff.str();
    return;
  }
  if (c.btcpp_exit == 0) {
    ASSERT_FALSE(got.load_error || got.tick_error) << diff.str();
    EXPECT_EQ(got.lines, expected) << "ours:\n" << diff.str();
    return;
  }
  if (c.btcpp_exit == 2) {  // rejected when the tree is built: so must we
    EXPECT_TRUE(got.load_error) << "BT.CPP rejects this tree at load (" << expected.front() << "); ours:\n" << diff.str();
    return;
  }
  // BT.CPP throws while ticking. We do the same, at the same tick with the same transitions
  // before it; or, for a missing required port, we reject the tree at load (exit code 2 before
  // any trial, as the harness promises).
  if (c.name == "92_err_missing_required_port") {
    EXPECT_TRUE(got.load_error) << diff.str();
    return;
  }
  ASSERT_TRUE(got.tick_error) << "BT.CPP throws while ticking; ours:\n" << diff.str();
  auto until_exception = [](const std::vector<std::string>& v) {
    std::vector<std::string> out;
    for (const auto& l : v) {
      const auto pos = l.find(" exception=");
      if (pos != std::string::npos) {
        out.push_back(l.substr(0, pos) + " exception");
        break;
      }
      out.push_back(l);
    }
    return out;
  };
  EXPECT_EQ(until_exception(got.lines), until_exception(expected)) << "ours:\n" << diff.str();
}

INSTANTIATE_TEST_SUITE_P(Trees, BtcppReference, ::testing::ValuesIn(cases()),
                         [](const ::testing::TestParamInfo<Case>& i) { return "t" + i.param.name; });

}  // namespace
}  // namespace mm::bt
