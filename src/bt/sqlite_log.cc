#include "bt/sqlite_log.h"

#include <sqlite3.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string_view>
#include <vector>

#include "core/file_io.h"

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
  Db() {
    if (sqlite3_open(":memory:", &db) != SQLITE_OK) throw std::runtime_error("sqlite: cannot open an in-memory database");
  }
  ~Db() {
    if (db) sqlite3_close(db);
  }
  Db(const Db&) = delete;
  Db& operator=(const Db&) = delete;
  void exec(const char* sql) {
    char* err = nullptr;
    if (sqlite3_exec(db, sql, nullptr, nullptr, &err) != SQLITE_OK) {
      const std::string what = err ? err : "unknown error";
      sqlite3_free(err);
      throw std::runtime_error(std::string("sqlite: ") + what + " in: " + sql);
    }
  }
  // A statement kept for the connection's life (the log writer's, reused from log to log).
  sqlite3_stmt* prepare(const char* sql) {
    sqlite3_stmt* s = nullptr;
    if (sqlite3_prepare_v3(db, sql, -1, SQLITE_PREPARE_PERSISTENT, &s, nullptr) != SQLITE_OK)
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

// Each thread's log writer: one in-memory connection and its prepared statements, kept from log to
// log (each log starts from a fresh copy of the empty image, deserialized into the connection).
// Against opening a connection and preparing the statements for every log, this halves SQLite's
// share of writing a log between two trials' physics (cold caches).
struct Writer {
  Db d;
  sqlite3_stmt* begin = nullptr;
  sqlite3_stmt* commit = nullptr;
  sqlite3_stmt* definition = nullptr;
  sqlite3_stmt* node = nullptr;
  sqlite3_stmt* transition = nullptr;

  Writer() {
    fresh();
    begin = d.prepare("BEGIN TRANSACTION;");
    commit = d.prepare("COMMIT;");
    definition = d.prepare("INSERT into Definitions (date, xml_tree) VALUES (?, ?);");
    node = d.prepare("INSERT INTO Nodes VALUES (?, ?, ?);");
    transition = d.prepare("INSERT INTO Transitions VALUES (?, ?, ?, ?, ?, ?);");
  }
  ~Writer() {
    for (sqlite3_stmt* s : {begin, commit, definition, node, transition}) sqlite3_finalize(s);
  }
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  // The connection's database becomes a copy of the empty log.
  void fresh() {
    const std::vector<unsigned char>& empty = emptyLogImage();
    auto* start = static_cast<unsigned char*>(sqlite3_malloc64(empty.size()));
    if (!start) throw std::runtime_error("sqlite: out of memory");
    std::memcpy(start, empty.data(), empty.size());
    const auto bytes = static_cast<sqlite3_int64>(empty.size());
    if (sqlite3_deserialize(d.db, "main", start, bytes, bytes, SQLITE_DESERIALIZE_FREEONCLOSE | SQLITE_DESERIALIZE_RESIZEABLE) !=
        SQLITE_OK)
      throw std::runtime_error(std::string("sqlite: ") + sqlite3_errmsg(d.db));
  }
};

}  // namespace

void TransitionRecorder::write(const std::string& file, const Tree& tree, const std::string& date,
                               const std::string& xml) const {
  // Built in memory from the empty log's image and written to the file in one write, renamed into
  // place when complete (flushed like trials.jsonl, not synced). `minimanip bench` times it.
  thread_local std::unique_ptr<Writer> writer;
  if (!writer) writer = std::make_unique<Writer>();
  Writer& w = *writer;
  unsigned char* image = nullptr;
  sqlite3_int64 size = 0;
  try {
    w.fresh();
    w.d.step(w.begin);
    sqlite3_bind_text(w.definition, 1, date.c_str(), -1, SQLITE_STATIC);
    sqlite3_bind_text(w.definition, 2, xml.c_str(), -1, SQLITE_STATIC);
    w.d.step(w.definition);
    const sqlite3_int64 session = sqlite3_last_insert_rowid(w.d.db);
    // Every node of every subtree instance, main tree first, in creation order (as BT.CPP).
    for (const Tree::Subtree& s : tree.subtrees())
      for (const TreeNode* n : s.nodes) {
        sqlite3_bind_int64(w.node, 1, session);
        sqlite3_bind_text(w.node, 2, n->fullPath().c_str(), -1, SQLITE_TRANSIENT);
        sqlite3_bind_int(w.node, 3, n->uid());
        w.d.step(w.node);
      }
    for (const Transition& t : transitions_) {
      sqlite3_bind_int64(w.transition, 1, t.timestamp_us);
      sqlite3_bind_int64(w.transition, 2, session);
      sqlite3_bind_int(w.transition, 3, t.uid);
      sqlite3_bind_int64(w.transition, 4, t.duration_us);
      sqlite3_bind_int(w.transition, 5, t.state);
      sqlite3_bind_text(w.transition, 6, "", -1, SQLITE_STATIC);
      w.d.step(w.transition);
    }
    w.d.step(w.commit);
    image = sqlite3_serialize(w.d.db, "main", &size, 0);
    if (!image) throw std::runtime_error("sqlite: cannot serialize the log for " + file);
  } catch (...) {
    writer.reset();  // a statement or a transaction may be left open: the next log starts anew
    throw;
  }
  try {
    writeFileAtomically(file, std::string_view(reinterpret_cast<const char*>(image), static_cast<size_t>(size)));
  } catch (...) {
    sqlite3_free(image);
    throw;
  }
  sqlite3_free(image);
}

}  // namespace mm::bt
