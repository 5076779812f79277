// The reference tracer (ours; not built by this project): runs a tree with BehaviorTree.CPP 4.10 and
// prints its transitions in the format ../README.md describes. How to build it: ../README.md.
#include <algorithm>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <unistd.h>
#include <string>

#include "behaviortree_cpp/bt_factory.h"
#include "behaviortree_cpp/loggers/abstract_logger.h"

using namespace BT;

static std::string oneLine(std::string s) {
  std::string out;
  for (char c : s) {
    if (c == '\n') out += "\\n";
    else if (c != '\r') out += c;
  }
  return out;
}

class TestAction : public StatefulActionNode {
 public:
  TestAction(const std::string& n, const NodeConfig& c) : StatefulActionNode(n, c) {}
  static PortsList providedPorts() {
    return {InputPort<int>("ticks", 0, "number of RUNNING ticks before completing"),
            InputPort<std::string>("result", "SUCCESS", "SUCCESS or FAILURE")};
  }
  NodeStatus onStart() override {
    const int ticks = getInput<int>("ticks").value();
    if (ticks <= 0) return result();
    remaining_ = ticks;
    return NodeStatus::RUNNING;
  }
  NodeStatus onRunning() override { return --remaining_ <= 0 ? result() : NodeStatus::RUNNING; }
  void onHalted() override {}

 private:
  NodeStatus result() {
    const std::string r = getInput<std::string>("result").value();
    if (r == "SUCCESS") return NodeStatus::SUCCESS;
    if (r == "FAILURE") return NodeStatus::FAILURE;
    throw RuntimeError("TestAction: invalid result [" + r + "], expected SUCCESS or FAILURE");
  }
  int remaining_ = 0;
};

class TestCondition : public ConditionNode {
 public:
  TestCondition(const std::string& n, const NodeConfig& c) : ConditionNode(n, c) {}
  static PortsList providedPorts() { return {InputPort<bool>("value", "condition value")}; }
  NodeStatus tick() override {
    const auto v = getInput<bool>("value");
    if (!v) throw RuntimeError(v.error());
    return *v ? NodeStatus::SUCCESS : NodeStatus::FAILURE;
  }
};

class Counter : public SyncActionNode {
 public:
  Counter(const std::string& n, const NodeConfig& c) : SyncActionNode(n, c) {}
  static PortsList providedPorts() { return {BidirectionalPort<int>("value", "incremented by one at each tick")}; }
  NodeStatus tick() override {
    const auto v = getInput<int>("value");
    auto r = setOutput("value", (v ? *v : 0) + 1);
    if (!r) throw RuntimeError(r.error());
    return NodeStatus::SUCCESS;
  }
};

static std::string label;
static std::ostringstream trace;  // written to the real stdout at the end: BT.CPP prints its warnings to std::cout
static int real_stdout = -1;
static int finish(int code) {
  const std::string t = trace.str();
  (void)!write(real_stdout, t.data(), t.size());
  return code;
}

class Tracer : public StatusChangeLogger {
 public:
  explicit Tracer(TreeNode* root) : StatusChangeLogger(root) {}
  void callback(Duration, const TreeNode& node, NodeStatus prev, NodeStatus status) override {
    trace << label << " " << node.UID() << " " << node.fullPath() << " " << toStr(prev) << "->" << toStr(status) << "\n";
  }
  void flush() override {}
};

int main(int argc, char** argv) {
  if (argc < 2) return 1;
  std::cout.flush();
  real_stdout = dup(1);
  dup2(2, 1);  // BT.CPP's own prints go to stderr
  int max_ticks = 50;
  for (int i = 2; i + 1 < argc; ++i)
    if (std::strcmp(argv[i], "--ticks") == 0) max_ticks = std::stoi(argv[i + 1]);
  BehaviorTreeFactory f;
  f.registerNodeType<TestAction>("TestAction");
  f.registerNodeType<TestCondition>("TestCondition");
  f.registerNodeType<Counter>("Counter");
  Tree tree;
  try {
    tree = f.createTreeFromFile(std::filesystem::absolute(argv[1]).string());
  } catch (const std::exception& e) {
    trace << "ERROR " << oneLine(e.what()) << "\n";
    return finish(2);
  }
  Tracer tracer(tree.rootNode());
  int ticks_this_round = 0;
  tree.rootNode()->setPreTickFunction([&](TreeNode&) -> NodeStatus {
    if (ticks_this_round++ > 0) trace << "# " << label << " retick\n";
    return NodeStatus::IDLE;
  });
  bool tick_error = false;
  for (int k = 0; k < max_ticks; ++k) {
    label = "T" + std::to_string(k);
    ticks_this_round = 0;
    NodeStatus s;
    try {
      s = tree.tickOnce();
    } catch (const std::exception& e) {
      trace << label << " exception=" << oneLine(e.what()) << "\n";
      tick_error = true;
      break;
    }
    trace << label << " root=" << toStr(s) << "\n";
    if (s != NodeStatus::RUNNING) break;
  }
  if (tree.rootNode()->status() == NodeStatus::RUNNING || tick_error) {
    label = "H";
    try {
      tree.haltTree();
    } catch (const std::exception& e) {
      trace << "H exception=" << oneLine(e.what()) << "\n";
    }
  }
  auto bb = tree.rootBlackboard();
  std::vector<std::string> keys;
  for (const auto& k : bb->getKeys()) keys.emplace_back(k);
  std::sort(keys.begin(), keys.end());
  for (const auto& key : keys) {
    auto entry = bb->getEntry(key);
    const Any& v = entry->value;
    std::string text;
    if (v.empty()) text = "<empty>";
    else {
      try {
        text = oneLine(v.cast<std::string>());
      } catch (...) {
        text = "<" + demangle(v.type()) + ">";
      }
    }
    trace << "BB " << key << "=" << text << "\n";
  }
  return finish(tick_error ? 3 : 0);
}
