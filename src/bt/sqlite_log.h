// A tree's transitions in the file Groot2 replays: BT.CPP's SqliteLogger schema (>= 4.6, read from
// BT.CPP 4.10's src/loggers/bt_sqlite_logger.cpp): Definitions (session, date, the tree as XML with
// its UIDs and node models), Nodes (session, full path, UID), Transitions (timestamp [us], session,
// node UID, duration [us] of a RUNNING spell that ends, state 0..4, extra data). Timestamps are
// the tree clock's (the trial's simulated time) in microseconds, forced strictly increasing as
// BT.CPP forces its own, so a log is the same on every run. Recorded in memory during the trial,
// written at its end in one transaction (and only for the trials a campaign keeps a log of).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "bt/tree.h"

namespace mm::bt {

class TransitionRecorder {
 public:
  struct Transition {
    int64_t timestamp_us;
    uint16_t uid;
    int64_t duration_us;
    int state;
  };
  /// Subscribes to `tree`'s status changes until destroyed (the tree must outlive the recorder).
  explicit TransitionRecorder(Tree& tree);
  ~TransitionRecorder();
  TransitionRecorder(const TransitionRecorder&) = delete;
  TransitionRecorder& operator=(const TransitionRecorder&) = delete;
  const std::vector<Transition>& transitions() const { return transitions_; }
  /// Writes `file` (replaced if it exists; written to a temporary name and renamed). `date` is
  /// the Definitions date ("YYYY-MM-DD HH:MM:SS"), `xml` the tree as Factory::treeToXml gives it.
  /// Throws std::runtime_error when SQLite fails.
  void write(const std::string& file, const Tree& tree, const std::string& date, const std::string& xml) const;

 private:
  Tree& tree_;
  int observer_ = 0;
  std::vector<Transition> transitions_;
  std::vector<int64_t> started_;  // per UID: when its current RUNNING spell began
  int64_t last_ = 0;
};

}  // namespace mm::bt
