#include "bt/blackboard.h"

#include <cmath>

namespace mm::bt {

Blackboard& Blackboard::root() {
  Blackboard* b = this;
  while (b->parent_) b = b->parent_;
  return *b;
}

Blackboard* Blackboard::remapTarget(const std::string& key, std::string& parent_key) const {
  if (!parent_) return nullptr;
  if (auto it = remap_.find(key); it != remap_.end()) {
    parent_key = it->second;
    return parent_;
  }
  if (autoremap_ && !key.empty() && key[0] != '_') {
    parent_key = key;
    return parent_;
  }
  return nullptr;
}

Blackboard::Entry* Blackboard::getEntry(const std::string& key) {
  if (!key.empty() && key[0] == '@') return root().getEntry(key.substr(1));
  if (auto it = storage_.find(key); it != storage_.end()) return it->second.get();
  std::string parent_key;
  if (Blackboard* p = remapTarget(key, parent_key)) return p->getEntry(parent_key);
  return nullptr;
}

Blackboard::Entry* Blackboard::createEntry(const std::string& key, const TypeInfo& info) {
  if (!key.empty() && key[0] == '@') {
    if (key.size() > 1 && key[1] == '@') throw RuntimeError("Character '@' used multiple times in the key");
    return root().createEntry(key.substr(1), info);
  }
  if (auto it = storage_.find(key); it != storage_.end()) return it->second.get();
  std::string parent_key;
  if (Blackboard* p = remapTarget(key, parent_key)) return p->createEntry(parent_key, info);
  auto e = std::make_unique<Entry>();
  e->info = info;
  Entry* raw = e.get();
  storage_[key] = std::move(e);
  return raw;
}

Any convertForEntry(const Blackboard::Entry& entry, const Any& value, const std::string& key) {
  if (!entry.info.stronglyTyped() || entry.info.name == value.typeName()) return value;
  if (value.isString() && entry.info.parse) {
    try {
      return entry.info.parse(value.string());
    } catch (const std::exception&) {
    }
  }
  // A number into a numeric entry when it fits exactly.
  const std::string& t = entry.info.name;
  if (value.isNumber()) {
    if (t == "double") return Any(value.real());
    const double x = value.real();
    const bool integral = x == std::floor(x);
    if (integral && t == "int" && x >= INT32_MIN && x <= INT32_MAX) return Any(static_cast<int>(x));
    if (integral && t == "long") return Any(static_cast<long>(x));
    if (integral && t == "unsigned int" && x >= 0 && x <= UINT32_MAX) return Any(static_cast<unsigned>(x));
    if (integral && t == "bool" && (x == 0 || x == 1)) return Any(x == 1);
  }
  throw RuntimeError("Blackboard::set(" + key + "): once declared, the type of a port shall not change. "
                     "Previously declared type [" + t + "], current type [" + value.typeName() + "]");
}

void Blackboard::set(const std::string& key, const Any& value) {
  if (!key.empty() && key[0] == '@') return root().set(key.substr(1), value);
  auto it = storage_.find(key);
  if (it == storage_.end()) {
    // A new key (or one reached through a remapping): the value goes in as it is.
    TypeInfo info;
    if (!value.isString() && !value.empty()) info.name = value.typeName();
    Entry* e = createEntry(key, info);
    e->value = value;
    ++e->sequence;
    return;
  }
  Entry& e = *it->second;
  if (!e.info.stronglyTyped()) {  // the first typed write declares the type
    e.info.name = value.typeName();
    e.value = value;
  } else {
    e.value = convertForEntry(e, value, key);
  }
  ++e.sequence;
}

void Blackboard::unset(const std::string& key) { storage_.erase(key); }

void Blackboard::addSubtreeRemapping(const std::string& internal, const std::string& external) {
  remap_[internal] = external;
}

std::vector<std::string> Blackboard::localKeys() const {
  std::vector<std::string> keys;
  for (const auto& [k, e] : storage_) keys.push_back(k);
  return keys;
}

}  // namespace mm::bt
