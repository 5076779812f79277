#include "bt/sqlite_log.h"

#include <sqlite3.h>

#include <cmath>
#include <filesystem>
#include <stdexcept>

namespace mm::bt {

TransitionRecorder::~TransitionRecorder() { tree_.removeObserver(observer_); }

TransitionRecorder::TransitionRecorder(Tree& tree) : tree_(tree) {
  observer_ = tree.addObserver([this, &tree](const TreeNode& n, NodeStatus prev, NodeStatus now) {
    const auto t_us = static_cast<int64_t>(std::llround(tree.now() * 1e6));
    last_ = std::max(last_ + 1, t_us);  // the primary key: strictly increasing
    if (started_.size() <= n.uid()) started_.resize(n.uid() + 1, 0);
    int64_t duration = 0;
    if (prev == NodeStatus::kIdle && now == NodeStatus::kRunning) started_[n.uid()] = last_;
    else if (prev == NodeStatus::kRunning && now != NodeStatus::kRunning) duration = last_ - started_[n.uid()];
    transitions_.push_back({last_, n.uid(), duration, static_cast<int>(now)});
  });
}

namespace {

struct Db {
  sqlite3* db = nullptr;
  ~Db() {
    if (db) sqlite3_close(db);
  }
  void exec(const char* sql) {
    char* err = nullptr;
    if (sqlite3_exec(db, sql, nullptr, nullptr, &err) != SQLITE_OK) {
      const std::string what = err ? err : "unknown error";
      sqlite3_free(err);
      throw std::runtime_error(std::string("sqlite: ") + what + " in: " + sql);
    }
  }
  sqlite3_stmt* prepare(const char* sql) {
    sqlite3_stmt* s = nullptr;
    if (sqlite3_prepare_v2(db, sql, -1, &s, nullptr) != SQLITE_OK)
      throw std::runtime_error(std::string("sqlite: ") + sqlite3_errmsg(db));
    return s;
  }
  void step(sqlite3_stmt* s) {
    if (sqlite3_step(s) != SQLITE_DONE) throw std::runtime_error(std::string("sqlite: ") + sqlite3_errmsg(db));
    sqlite3_reset(s);
    sqlite3_clear_bindings(s);
  }
};

}  // namespace

void TransitionRecorder::write(const std::string& file, const Tree& tree, const std::string& date,
                               const std::string& xml) const {
  const std::string tmp = file + ".tmp";
  std::filesystem::remove(tmp);
  Db d;
  if (sqlite3_open(tmp.c_str(), &d.db) != SQLITE_OK) throw std::runtime_error("sqlite: cannot open " + tmp);
  // A new file written once by one writer and renamed into place when complete: no journal, no
  // fsync (flushed like trials.jsonl, not synced).
  d.exec("PRAGMA journal_mode=OFF;");
  d.exec("PRAGMA synchronous=OFF;");
  // The statements of BT.CPP's SqliteLogger, as it writes them.
  d.exec(
      "CREATE TABLE IF NOT EXISTS Transitions (timestamp  INTEGER PRIMARY KEY NOT NULL, session_id INTEGER NOT NULL, "
      "node_uid   INTEGER NOT NULL, duration   INTEGER, state      INTEGER NOT NULL,extra_data VARCHAR );");
  d.exec("CREATE TABLE IF NOT EXISTS Nodes (session_id INTEGER NOT NULL, fullpath   VARCHAR, node_uid   INTEGER NOT NULL );");
  d.exec(
      "CREATE TABLE IF NOT EXISTS Definitions (session_id INTEGER PRIMARY KEY AUTOINCREMENT, date       TEXT NOT NULL,"
      "xml_tree   TEXT NOT NULL);");
  d.exec("BEGIN TRANSACTION;");
  sqlite3_stmt* def = d.prepare("INSERT into Definitions (date, xml_tree) VALUES (?, ?);");
  sqlite3_bind_text(def, 1, date.c_str(), -1, SQLITE_TRANSIENT);
  sqlite3_bind_text(def, 2, xml.c_str(), -1, SQLITE_TRANSIENT);
  d.step(def);
  sqlite3_finalize(def);
  const sqlite3_int64 session = sqlite3_last_insert_rowid(d.db);
  // Every node of every subtree instance, main tree first, in creation order (as BT.CPP).
  sqlite3_stmt* node = d.prepare("INSERT INTO Nodes VALUES (?, ?, ?);");
  for (const Tree::Subtree& s : tree.subtrees())
    for (const TreeNode* n : s.nodes) {
      sqlite3_bind_int64(node, 1, session);
      sqlite3_bind_text(node, 2, n->fullPath().c_str(), -1, SQLITE_TRANSIENT);
      sqlite3_bind_int(node, 3, n->uid());
      d.step(node);
    }
  sqlite3_finalize(node);
  sqlite3_stmt* tr = d.prepare("INSERT INTO Transitions VALUES (?, ?, ?, ?, ?, ?);");
  for (const Transition& t : transitions_) {
    sqlite3_bind_int64(tr, 1, t.timestamp_us);
    sqlite3_bind_int64(tr, 2, session);
    sqlite3_bind_int(tr, 3, t.uid);
    sqlite3_bind_int64(tr, 4, t.duration_us);
    sqlite3_bind_int(tr, 5, t.state);
    sqlite3_bind_text(tr, 6, "", -1, SQLITE_STATIC);
    d.step(tr);
  }
  sqlite3_finalize(tr);
  d.exec("COMMIT;");
  sqlite3_close(d.db);
  d.db = nullptr;
  std::filesystem::rename(tmp, file);
}

}  // namespace mm::bt
