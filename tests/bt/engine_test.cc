// The engine beyond the recorded BT.CPP traces: the script language against BT.CPP's own results
// on ~90 expressions, port conversions against its probe table, the timer nodes on a simulated
// clock (BT.CPP's run on threads and wall time, so they have no reference trace), halts, and the
// load-time errors (file, line, node).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

#include "bt/factory.h"
#include "core/error.h"

namespace mm::bt {
namespace {

using ::testing::HasSubstr;

// ---- scripts: BT.CPP's results for the same lines, run one after another on one blackboard ----

std::string describe(const Any& a) {
  if (a.empty()) return "<empty>";
  return a.toString() + " (" + a.typeName() + ")";
}

TEST(Script, SameResultsAsBehaviorTreeCppOnItsProbe) {
  std::ifstream in("tests/bt/btcpp_reference/script_probe.out");
  ASSERT_TRUE(in) << "missing probe file";
  Blackboard bb;
  const ScriptEnums enums{{"RED", 1}, {"GREEN", 2}};
  int lines = 0, errors = 0;
  for (std::string line; std::getline(in, line);) {
    const auto sep = line.find("   =>   ");
    ASSERT_NE(sep, std::string::npos) << line;
    const std::string code = line.substr(0, sep), expected = line.substr(sep + 8);
    const bool expect_error = expected.rfind("ERR", 0) == 0 || expected.rfind("EXC", 0) == 0;
    std::string got;
    bool error = false;
    try {
      got = describe(Script::parse(code).run({&bb, &enums}));
    } catch (const RuntimeError& e) {
      error = true;
      got = e.what();
    }
    ++lines;
    if (expect_error) {
      ++errors;
      EXPECT_TRUE(error) << code << " -> " << got << " (BT.CPP: " << expected << ")";
      // Parse errors carry the same message (position included).
      if (expected.rfind("ERR: Invalid token", 0) == 0 || expected.rfind("ERR: Expected operand", 0) == 0 ||
          expected.rfind("ERR: Parse error", 0) == 0) {
        EXPECT_EQ(got, expected.substr(5)) << code;
      }
    } else {
      EXPECT_FALSE(error) << code << " threw " << got;
      EXPECT_EQ(got, expected) << code;
    }
  }
  EXPECT_GE(lines, 90);
  EXPECT_GE(errors, 20);
}

// ---- port conversions: BT.CPP's getInput table ----

TEST(Ports, StoredValuesReadAsOtherTypesAsBehaviorTreeCpp) {
  struct Row {
    Any stored;
    const char* as_string;
    std::optional<int> as_int;
    std::optional<double> as_double;
    std::optional<bool> as_bool;
  };
  const Row rows[] = {
      {Any(true), "1", 1, 1.0, true},
      {Any(false), "0", 0, 0.0, false},
      {Any(1), "1", 1, 1.0, true},
      {Any(42), "42", 42, 42.0, std::nullopt},
      {Any(2.0), "2.000000", 2, 2.0, true},
      {Any(2.5), "2.500000", std::nullopt, 2.5, true},
      {Any(0.0), "0.000000", 0, 0.0, false},
      {Any("1"), "1", 1, 1.0, true},
      {Any("true"), "true", std::nullopt, std::nullopt, true},
      {Any("2.5"), "2.5", 2, 2.5, std::nullopt},
      {Any("abc"), "abc", std::nullopt, std::nullopt, std::nullopt},
  };
  for (const Row& r : rows) {
    SCOPED_TRACE(r.stored.toString() + " (" + r.stored.typeName() + ")");
    EXPECT_EQ(*anyCast<std::string>(r.stored), r.as_string);
    const auto i = anyCast<int>(r.stored);
    EXPECT_EQ(static_cast<bool>(i), r.as_int.has_value());
    if (i && r.as_int) {
      EXPECT_EQ(*i, *r.as_int);
    }
    const auto d = anyCast<double>(r.stored);
    EXPECT_EQ(static_cast<bool>(d), r.as_double.has_value());
    if (d && r.as_double) {
      EXPECT_EQ(*d, *r.as_double);
    }
    const auto b = anyCast<bool>(r.stored);
    EXPECT_EQ(static_cast<bool>(b), r.as_bool.has_value());
    if (b && r.as_bool) {
      EXPECT_EQ(*b, *r.as_bool);
    }
  }
  // BT.CPP's integer reading is a prefix parse.
  EXPECT_EQ(*anyCast<int>(Any("2abc")), 2);
  EXPECT_FALSE(anyCast<unsigned>(Any(-3)));
}

// ---- timers on a simulated clock ----

class StepAction final : public StatefulActionNode {  // RUNNING until halted, counting halts
 public:
  using StatefulActionNode::StatefulActionNode;
  static PortsList providedPorts() { return {}; }
  static inline int halts = 0;

 protected:
  NodeStatus onStart() override { return NodeStatus::kRunning; }
  NodeStatus onRunning() override { return NodeStatus::kRunning; }
  void onHalted() override { ++halts; }
};

struct Clocked {
  double t = 0;
  Factory f;
  std::unique_ptr<Tree> tree;
  std::vector<std::string> log;
  explicit Clocked(const std::string& xml) {
    f.registerNodeType<StepAction>("StepAction");
    tree = f.instantiate(f.loadText(xml, "inline.xml"));
    tree->setClock([this] { return t; });
    tree->addObserver([this](const TreeNode& n, NodeStatus p, NodeStatus s) {
      log.push_back(n.name() + " " + toString(p) + "->" + toString(s));
    });
  }
  // Advances the clock to `until` in 1 ms steps, ticking at once when a timer fires.
  NodeStatus runUntil(double until) {
    NodeStatus s = tree->tickOnce();
    while (t < until - 1e-9 && s == NodeStatus::kRunning) {
      t += 0.001;
      if (tree->fireDueTimers()) s = tree->tickOnce();
    }
    return s;
  }
};

TEST(Timers, SleepCountsTheTreeClock) {
  Clocked c(R"(<root BTCPP_format="4"><BehaviorTree ID="M">
                 <Sequence><Sleep msec="300"/><AlwaysSuccess name="after"/></Sequence>
               </BehaviorTree></root>)");
  EXPECT_EQ(c.runUntil(0.2985), NodeStatus::kRunning);
  EXPECT_EQ(c.runUntil(0.31), NodeStatus::kSuccess);
  EXPECT_NEAR(c.t, 0.300, 1e-9);  // woken by the timer, not by a later tick
}

TEST(Timers, DelayThenTheChild) {
  Clocked c(R"(<root BTCPP_format="4"><BehaviorTree ID="M">
                 <Delay delay_msec="150"><AlwaysFailure name="late"/></Delay>
               </BehaviorTree></root>)");
  EXPECT_EQ(c.runUntil(1.0), NodeStatus::kFailure);
  EXPECT_NEAR(c.t, 0.150, 1e-9);
  EXPECT_THAT(c.log, ::testing::Contains("late IDLE->FAILURE"));
}

TEST(Timers, TimeoutHaltsTheRunningChildWhenItFires) {
  StepAction::halts = 0;
  Clocked c(R"(<root BTCPP_format="4"><BehaviorTree ID="M">
                 <Timeout msec="500"><StepAction name="long"/></Timeout>
               </BehaviorTree></root>)");
  EXPECT_EQ(c.runUntil(2.0), NodeStatus::kFailure);
  EXPECT_NEAR(c.t, 0.5, 1e-9);
  EXPECT_EQ(StepAction::halts, 1);
  // The child is halted when the timer fires, between ticks; the next tick fails.
  EXPECT_THAT(c.log, ::testing::ElementsAre("Timeout IDLE->RUNNING", "long IDLE->RUNNING", "long RUNNING->IDLE",
                                            "Timeout RUNNING->FAILURE", "Timeout FAILURE->IDLE"));
}

TEST(Timers, TimeoutThatDoesNotFireIsCancelled) {
  Clocked c(R"(<root BTCPP_format="4"><BehaviorTree ID="M">
                 <Sequence><Timeout msec="500"><Sleep msec="100"/></Timeout><Sleep msec="1000"/></Sequence>
               </BehaviorTree></root>)");
  EXPECT_EQ(c.runUntil(2.0), NodeStatus::kSuccess);
  EXPECT_NEAR(c.t, 1.1, 1e-9);
  EXPECT_FALSE(c.tree->nextTimerDeadline().has_value());
}

TEST(Halt, HaltTreeReachesRunningChildrenAndRunsOnHalted) {
  StepAction::halts = 0;
  Clocked c(R"(<root BTCPP_format="4"><BehaviorTree ID="M">
                 <Parallel success_count="2"><StepAction name="a" _onHalted="ha := 1"/><StepAction name="b"/></Parallel>
               </BehaviorTree></root>)");
  EXPECT_EQ(c.tree->tickOnce(), NodeStatus::kRunning);
  c.tree->haltTree();
  EXPECT_EQ(StepAction::halts, 2);
  EXPECT_EQ(c.tree->root()->status(), NodeStatus::kIdle);
  EXPECT_EQ(c.tree->rootBlackboard().getEntry("ha")->value.integer(), 1);
}

// ---- Switch4..6 (Switch2 and Switch3 are in the BT.CPP traces; all share one implementation) ----

TEST(Switch, EveryCaseAndTheDefaultOfSwitch4To6) {
  for (int n = 4; n <= 6; ++n) {
    std::string cases, children;
    for (int k = 1; k <= n; ++k) {
      cases += " case_" + std::to_string(k) + "=\"c" + std::to_string(k) + "\"";
      children += "<Script code=\"ran := " + std::to_string(k) + "\"/>";
    }
    children += "<Script code=\"ran := 0\"/>";  // the default
    for (int pick = 0; pick <= n; ++pick) {
      const std::string value = pick == 0 ? "none" : "c" + std::to_string(pick);
      const std::string xml = "<root BTCPP_format=\"4\"><BehaviorTree ID=\"M\"><Sequence><Script code=\"v := '" + value +
                              "'\"/><Switch" + std::to_string(n) + " variable=\"{v}\"" + cases + ">" + children + "</Switch" +
                              std::to_string(n) + "></Sequence></BehaviorTree></root>";
      SCOPED_TRACE(xml);
      Clocked c(xml);
      EXPECT_EQ(c.tree->tickOnce(), NodeStatus::kSuccess);
      EXPECT_EQ(c.tree->rootBlackboard().getEntry("ran")->value.integer(), pick);
    }
  }
  // A SwitchN needs N + 1 children.
  EXPECT_THROW(Clocked(R"(<root BTCPP_format="4"><BehaviorTree ID="M">
                 <Switch4 variable="x" case_1="a" case_2="b" case_3="c" case_4="d"><AlwaysSuccess/></Switch4>
               </BehaviorTree></root>)"),
               InputError);
}

// ---- load-time errors: file, line, node, what was expected ----

std::string loadError(const std::string& xml) {
  Factory f;
  f.registerNodeType<StepAction>("StepAction");
  try {
    f.loadText(xml, "bad.xml");
  } catch (const InputError& e) {
    return e.what();
  }
  return "(loaded)";
}

TEST(LoadErrors, NameTheFileTheLineAndTheNode) {
  EXPECT_THAT(loadError("<root BTCPP_format=\"4\">\n<BehaviorTree ID=\"M\">\n  <Nope/>\n</BehaviorTree></root>"),
              HasSubstr("bad.xml:3: <Nope>: Node not recognized: Nope"));
  EXPECT_THAT(loadError("<root BTCPP_format=\"4\">\n<BehaviorTree ID=\"M\">\n  <Sleep msec=\"1\" nap=\"2\"/>\n</BehaviorTree></root>"),
              HasSubstr("bad.xml:3: <Sleep>: a port with name [nap] is found in the XML"));
  EXPECT_THAT(loadError("<root BTCPP_format=\"4\"><BehaviorTree ID=\"M\">\n<Sleep msec=\"soon\"/></BehaviorTree></root>"),
              HasSubstr("bad.xml:2: <Sleep>: The port with name \"msec\" and value \"soon\" can not be converted to unsigned int"));
  EXPECT_THAT(loadError("<root BTCPP_format=\"4\"><BehaviorTree ID=\"M\">\n<Sleep/></BehaviorTree></root>"),
              HasSubstr("bad.xml:2: <Sleep>: missing required port [msec]"));
  EXPECT_THAT(loadError("<root BTCPP_format=\"4\"><BehaviorTree ID=\"M\">\n<Script code=\"x := (1 +\"/></BehaviorTree></root>"),
              HasSubstr("bad.xml:2: <Script>: Expected operand at position 9 (got '')"));
  EXPECT_THAT(loadError("<root BTCPP_format=\"4\"><BehaviorTree ID=\"M\">\n<AlwaysSuccess _skipIf=\"a ==\"/></BehaviorTree></root>"),
              HasSubstr("bad.xml:2: <AlwaysSuccess>: Error in the script \"a ==\""));
  EXPECT_THAT(loadError("<root BTCPP_format=\"4\">\n<BehaviorTree ID=\"M\">\n<Sequence>\n<AlwaysSuccess/>\n</BehaviorTree></root>"),
              HasSubstr("bad.xml:3: malformed XML: XML_ERROR_MISMATCHED_ELEMENT"));  // the unclosed <Sequence>
  EXPECT_THAT(loadError("<root BTCPP_format=\"4\"><BehaviorTree ID=\"M\">\n<SubTree ID=\"Gone\"/></BehaviorTree></root>"),
              HasSubstr("bad.xml:2: <SubTree>: Can't find a tree with name: Gone"));
  EXPECT_THAT(loadError("<root BTCPP_format=\"4\" main_tree_to_execute=\"A\">\n<BehaviorTree ID=\"A\"><SubTree ID=\"B\"/></BehaviorTree>\n"
                        "<BehaviorTree ID=\"B\">\n<SubTree ID=\"A\"/></BehaviorTree></root>"),
              HasSubstr("bad.xml:4: <SubTree>: Recursive behavior tree cycle detected: tree 'A'"));
  EXPECT_THAT(loadError("<root BTCPP_format=\"4\"><BehaviorTree ID=\"M\">\n<Inverter><AlwaysSuccess/><AlwaysSuccess/></Inverter>"
                        "</BehaviorTree></root>"),
              HasSubstr("bad.xml:2: <Inverter>: The node 'Inverter' must have exactly 1 child"));
  EXPECT_THAT(loadError("<root BTCPP_format=\"3\"><BehaviorTree ID=\"M\"><AlwaysSuccess/></BehaviorTree></root>"),
              HasSubstr("only version 4 is supported"));
  EXPECT_THAT(loadError("<root BTCPP_format=\"4\"><BehaviorTree ID=\"M\"><AlwaysSuccess/></BehaviorTree>"
                        "<BehaviorTree ID=\"N\"><AlwaysSuccess/></BehaviorTree></root>"),
              HasSubstr("[main_tree_to_execute] was not specified correctly"));
}

}  // namespace
}  // namespace mm::bt
