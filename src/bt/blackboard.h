// A blackboard as BT.CPP's: typed entries by key; a SubTree's blackboard has the enclosing one as
// parent, reaches it through explicit remappings (port -> key) or, with _autoremap, by the same
// name; "@key" is the root blackboard's key.
#pragma once
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "bt/basic.h"

namespace mm::bt {

class Blackboard {
 public:
  struct Entry {
    Any value;
    TypeInfo info;         ///< the type declared by the port (or value) that created it
    uint64_t sequence = 0; ///< incremented on every write
  };

  explicit Blackboard(Blackboard* parent = nullptr) : parent_(parent) {}
  Blackboard* parent() const { return parent_; }
  Blackboard& root();

  /// The entry for `key` here or where it is remapped to; nullptr if there is none.
  Entry* getEntry(const std::string& key);
  /// The entry for `key`, created (empty, with `info`) where the remapping leads if missing.
  Entry* createEntry(const std::string& key, const TypeInfo& info);
  /// Writes with BT.CPP's rules: a new key takes the value's type; an existing typed entry takes
  /// the same type, a string its type parses, or an exactly convertible number; else throws
  /// RuntimeError ("once declared, the type of a port shall not change").
  void set(const std::string& key, const Any& value);
  /// Removes a key of this blackboard only (no remapping, as BT.CPP's UnsetBlackboard).
  void unset(const std::string& key);

  void addSubtreeRemapping(const std::string& internal, const std::string& external);
  void enableAutoRemapping(bool on) { autoremap_ = on; }
  /// Keys stored here (not the parent's), sorted.
  std::vector<std::string> localKeys() const;

 private:
  Blackboard* remapTarget(const std::string& key, std::string& parent_key) const;
  Blackboard* parent_;
  std::map<std::string, std::unique_ptr<Entry>> storage_;
  std::map<std::string, std::string> remap_;
  bool autoremap_ = false;
};

/// Converts `value` to what the entry holds (same type, parsed string, exact number); throws
/// RuntimeError when it cannot.
Any convertForEntry(const Blackboard::Entry& entry, const Any& value, const std::string& key);

}  // namespace mm::bt
