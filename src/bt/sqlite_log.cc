#include "bt/sqlite_log.h"

#include <sqlite3.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <vector>

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

// The empty log: the statements of BT.CPP's SqliteLogger (its src/loggers/bt_sqlite_logger.cpp),
// as it writes them, run once into an in-memory database whose image every log starts from.
const std::vector<unsigned char>& emptyLogImage() {
  static const std::vector<unsigned char> image = [] {
    Db d;
    if (sqlite3_open(":memory:", &d.db) != SQLITE_OK) throw std::runtime_error("sqlite: cannot open an in-memory database");
    d.exec("PRAGMA page_size=1024;");  // a 5 KB log instead of 20 KB
    d.exec(
        "CREATE TABLE IF NOT EXISTS Transitions (timestamp  INTEGER PRIMARY KEY NOT NULL, session_id INTEGER NOT NULL, "
        "node_uid   INTEGER NOT NULL, duration   INTEGER, state      INTEGER NOT NULL,extra_data VARCHAR );");
    d.exec("CREATE TABLE IF NOT EXISTS Nodes (session_id INTEGER NOT NULL, fullpath   VARCHAR, node_uid   INTEGER NOT NULL );");
    d.exec(
        "CREATE TABLE IF NOT EXISTS Definitions (session_id INTEGER PRIMARY KEY AUTOINCREMENT, date       TEXT NOT NULL,"
        "xml_tree   TEXT NOT NULL);");
    sqlite3_int64 size = 0;
    unsigned char* bytes = sqlite3_serialize(d.db, "main", &size, 0);
    if (!bytes) throw std::runtime_error("sqlite: cannot serialize the empty log");
    std::vector<unsigned char> v(bytes, bytes + size);
    sqlite3_free(bytes);
    return v;
  }();
  return image;
}

}  // namespace

void TransitionRecorder::write(const std::string& file, const Tree& tree, const std::string& date,
                               const std::string& xml) const {
  // Built in memory from the empty log's image and written to the file in one write, renamed into
  // place when complete (flushed like trials.jsonl, not synced): 0.40-0.44 ms a log, against
  // 0.62 ms for running the schema's statements into the file (measured with `minimanip bench`).
  const std::vector<unsigned char>& empty = emptyLogImage();
  Db d;
  if (sqlite3_open(":memory:", &d.db) != SQLITE_OK) throw std::runtime_error("sqlite: cannot open an in-memory database");
  auto* start = static_cast<unsigned char*>(sqlite3_malloc64(empty.size()));
  if (!start) throw std::runtime_error("sqlite: out of memory");
  std::memcpy(start, empty.data(), empty.size());
  const auto bytes = static_cast<sqlite3_int64>(empty.size());
  if (sqlite3_deserialize(d.db, "main", start, bytes, bytes, SQLITE_DESERIALIZE_FREEONCLOSE | SQLITE_DESERIALIZE_RESIZEABLE) !=
      SQLITE_OK)
    throw std::runtime_error(std::string("sqlite: ") + sqlite3_errmsg(d.db));
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
  sqlite3_int64 size = 0;
  unsigned char* image = sqlite3_serialize(d.db, "main", &size, 0);
  if (!image) throw std::runtime_error("sqlite: cannot serialize the log for " + file);
  const std::string tmp = file + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(image), static_cast<std::streamsize>(size));
    sqlite3_free(image);
    if (!out.flush()) throw std::runtime_error("cannot write " + tmp);
  }
  std::filesystem::rename(tmp, file);
}

}  // namespace mm::bt
