// The per-trial behavior-tree logs: a campaign writes results/<name>/bt/trial_<N>.db3 in BT.CPP's
// SqliteLogger schema. Read back with the sqlite3 library (tables, the tree definition, nodes,
// transitions in time order, durations) and with the sqlite3 command-line tool, whose .schema
// must print what it prints for a file BT.CPP 4.10 wrote (tests/bt/btcpp_reference/sqlite_schema.txt).
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sqlite3.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

namespace mm {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

std::string shell(const std::string& cmd, int* code = nullptr) {
  std::string out;
  FILE* p = popen((cmd + " 2>&1").c_str(), "r");
  char buf[4096];
  while (size_t n = fread(buf, 1, sizeof buf, p)) out.append(buf, n);
  const int status = pclose(p);
  if (code) *code = WEXITSTATUS(status);
  return out;
}

// Rows of a query as tab-separated text.
std::vector<std::vector<std::string>> query(sqlite3* db, const std::string& sql) {
  std::vector<std::vector<std::string>> rows;
  sqlite3_stmt* s = nullptr;
  EXPECT_EQ(sqlite3_prepare_v2(db, sql.c_str(), -1, &s, nullptr), SQLITE_OK) << sqlite3_errmsg(db);
  while (sqlite3_step(s) == SQLITE_ROW) {
    std::vector<std::string> row;
    for (int c = 0; c < sqlite3_column_count(s); ++c) {
      const unsigned char* t = sqlite3_column_text(s, c);
      row.push_back(t ? reinterpret_cast<const char*>(t) : "NULL");
    }
    rows.push_back(row);
  }
  sqlite3_finalize(s);
  return rows;
}

class BtLog : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("mm_btlog_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    int code = 0;
    const std::string out = shell(std::string(MINIMANIP_BINARY) +
                                  " run experiments/quickstart.yaml --trials 2 --set hardware=mock --set progress=none "
                                  "--set bt.log=all --out " + dir_.string(), &code);
    ASSERT_EQ(code, 0) << out;
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(BtLog, EveryTrialHasADb3InBehaviorTreeCppSchema) {
  std::ifstream in(dir_ / "trials.jsonl");
  std::string line;
  std::vector<json> trials;
  while (std::getline(in, line)) trials.push_back(json::parse(line));
  ASSERT_EQ(trials.size(), 2u);
  for (const json& t : trials) {
    ASSERT_TRUE(t["bt_log"].is_string()) << t.dump();
    const fs::path file = dir_ / t["bt_log"].get<std::string>();
    ASSERT_TRUE(fs::exists(file)) << file;
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open_v2(file.c_str(), &db, SQLITE_OPEN_READONLY, nullptr), SQLITE_OK);
    // The three tables of BT.CPP's SqliteLogger.
    const auto tables = query(db, "SELECT name FROM sqlite_master WHERE type='table' ORDER BY name");
    std::vector<std::string> names;
    for (const auto& r : tables) names.push_back(r[0]);
    EXPECT_THAT(names, ::testing::IsSupersetOf({"Definitions", "Nodes", "Transitions"}));
    // One session: the campaign's date and the tree as XML with its UIDs and node models.
    const auto defs = query(db, "SELECT session_id, date, xml_tree FROM Definitions");
    ASSERT_EQ(defs.size(), 1u);
    EXPECT_THAT(defs[0][1], ::testing::MatchesRegex("[0-9]{4}-[0-9]{2}-[0-9]{2} [0-9]{2}:[0-9]{2}:[0-9]{2}"));
    EXPECT_THAT(defs[0][2], ::testing::HasSubstr("<BehaviorTree ID=\"MiniManip\" _fullpath=\"\">"));
    EXPECT_THAT(defs[0][2], ::testing::HasSubstr("<PlanAndExecutePick name=\"PlanAndExecutePick\" _uid=\"5\" object_pose=\"{cube_pose}\"/>"));
    EXPECT_THAT(defs[0][2], ::testing::HasSubstr("<TreeNodesModel>"));
    EXPECT_THAT(defs[0][2], ::testing::HasSubstr("<Action ID=\"DetectObject\">"));
    // Every node of the MiniManip tree, UIDs 1..12 in depth-first order.
    const auto nodes = query(db, "SELECT node_uid, fullpath FROM Nodes ORDER BY node_uid");
    ASSERT_EQ(nodes.size(), 12u);
    EXPECT_EQ(nodes[0][1], "Sequence::1");
    EXPECT_EQ(nodes[1][1], "RetryUntilSuccessful::2");
    EXPECT_EQ(nodes[2][1], "DetectObject::3");
    EXPECT_EQ(nodes[11][1], "MoveToHome::12");
    // Transitions in time order (simulated microseconds, strictly increasing), valid states,
    // durations only when a RUNNING spell ends; the root ends SUCCESS then IDLE.
    const auto tr = query(db, "SELECT timestamp, node_uid, duration, state, session_id, extra_data FROM Transitions ORDER BY rowid");
    ASSERT_GE(tr.size(), 20u);
    long long last = -1;
    int running_spells = 0;
    for (const auto& r : tr) {
      const long long ts = std::stoll(r[0]);
      EXPECT_GT(ts, last);
      last = ts;
      const int state = std::stoi(r[3]);
      EXPECT_GE(state, 0);
      EXPECT_LE(state, 3);
      EXPECT_EQ(r[4], defs[0][0]);
      EXPECT_EQ(r[5], "");
      if (std::stoll(r[2]) > 0) ++running_spells;
    }
    EXPECT_GT(running_spells, 3);  // the pick, the place, home and the Sequence itself
    EXPECT_EQ(tr[tr.size() - 2][1], "1");
    EXPECT_EQ(tr[tr.size() - 2][3], "2");  // root SUCCESS
    EXPECT_EQ(tr.back()[3], "0");          // then IDLE
    // The last transition is at the end of the tree's simulated time.
    EXPECT_NEAR(last * 1e-6, t["sim_time"].get<double>() - 0.5, 0.01);  // before the 0.5 s evaluation rest
    sqlite3_close(db);
  }
}

TEST_F(BtLog, TheSqliteToolPrintsTheSameSchemaAsForBehaviorTreeCppsOwnFile) {
  const fs::path file = *fs::directory_iterator(dir_ / "bt");
  int code = 0;
  const std::string ours = shell("sqlite3 " + file.string() + " .schema", &code);
  ASSERT_EQ(code, 0) << ours;
  std::ifstream in("tests/bt/btcpp_reference/sqlite_schema.txt");
  std::stringstream theirs;
  theirs << in.rdbuf();
  EXPECT_EQ(ours, theirs.str());
  // And the tool can read the rows.
  EXPECT_THAT(shell("sqlite3 " + file.string() + " 'SELECT count(*) > 0 FROM Transitions'"), ::testing::HasSubstr("1"));
}

TEST(BtLogSelection, OnlyFailedOrRecoveredTrialsKeepALogByDefault) {
  const fs::path dir = fs::temp_directory_path() / ("mm_btlog_sel_" + std::to_string(getpid()));
  fs::remove_all(dir);
  int code = 0;
  const std::string out = shell(std::string(MINIMANIP_BINARY) +
                                " run experiments/quickstart.yaml --trials 3 --set hardware=mock --set progress=none --out " +
                                dir.string(), &code);
  ASSERT_EQ(code, 0) << out;
  EXPECT_TRUE(fs::is_empty(dir / "bt")) << "all three trials succeeded at the first attempt";
  fs::remove_all(dir);
}

}  // namespace
}  // namespace mm
