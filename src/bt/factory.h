// The node registry and the XML loader: BTCPP_format="4" files with <BehaviorTree ID=...>,
// main_tree_to_execute, <include path=...> (relative to the including file), an accepted
// <TreeNodesModel> (its SubTree port models give defaults and required ports), SubTree with port
// remapping, literals and _autoremap, pre/post-condition scripts. Everything that can be wrong
// in a file is found when it loads (not when a trial runs): unknown node, unknown or missing
// required port, a literal of the wrong type, two ports of different types on one key, bad
// script, malformed XML, missing or recursive subtree; each an mm::InputError naming the file,
// the line and the node (exit code 2).
#pragma once
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "bt/tree.h"
#include "bt/tree_node.h"

namespace mm::bt {

struct NodeManifest {
  std::string id;
  NodeKind kind = NodeKind::kAction;
  PortsList ports;
  std::string description;  ///< what the node does (for docs/reference/nodes.md and the tree's model)
  std::function<std::unique_ptr<TreeNode>(const std::string& name, const NodeConfig& config)> build;
  int min_children = 0, max_children = 0;  ///< -1: no upper bound
};

/// A loaded, checked set of behavior trees (one file and its includes). Workers may instantiate
/// trees from one document concurrently: loading built the tree once, so tinyxml2 has already
/// decoded every string it lazily decodes in place on first access, and later reads are const.
class TreeDocument {
 public:
  TreeDocument();
  ~TreeDocument();
  TreeDocument(TreeDocument&&) noexcept;
  TreeDocument& operator=(TreeDocument&&) noexcept;
  const std::string& mainTreeId() const;
  const std::string& file() const;
  /// The values of `attribute` on every node of type `node` in the document's trees (what a
  /// campaign must set up for them: a port that asks for the camera, say).
  /// Each as (value, "file:line").
  std::vector<std::pair<std::string, std::string>> attributeValues(const std::string& node, const std::string& attribute) const;
  struct Impl;
  Impl& impl() const { return *impl_; }

 private:
  std::unique_ptr<Impl> impl_;
};

class Factory {
 public:
  /// A registry with BT.CPP's built-in nodes.
  Factory();
  ~Factory();
  Factory(const Factory&) = delete;  // builders may hold references to what they were registered with
  Factory& operator=(const Factory&) = delete;

  void registerNode(NodeManifest manifest);
  /// T derives from one of the node kinds, has `static PortsList providedPorts()` and a
  /// constructor (const std::string& name, const NodeConfig&).
  template <class T>
  void registerNodeType(const std::string& id, std::string description = "") {
    NodeManifest m;
    m.id = id;
    m.kind = std::is_base_of_v<ConditionNode, T> ? NodeKind::kCondition
             : std::is_base_of_v<ControlNode, T> ? NodeKind::kControl
             : std::is_base_of_v<DecoratorNode, T> ? NodeKind::kDecorator
                                                     : NodeKind::kAction;
    m.ports = T::providedPorts();
    m.description = std::move(description);
    m.build = [](const std::string& name, const NodeConfig& config) { return std::make_unique<T>(name, config); };
    m.min_children = m.kind == NodeKind::kControl ? 1 : m.kind == NodeKind::kDecorator ? 1 : 0;
    m.max_children = m.kind == NodeKind::kControl ? -1 : m.kind == NodeKind::kDecorator ? 1 : 0;
    registerNode(std::move(m));
  }
  void registerScriptingEnum(const std::string& name, int value);
  const std::map<std::string, NodeManifest>& manifests() const { return manifests_; }
  bool isBuiltin(const std::string& id) const;

  /// Loads and checks `path` with its includes, and builds the main tree once to check every
  /// node, port and script. Throws mm::InputError (file:line: what was expected).
  TreeDocument load(const std::string& path) const;
  /// The same from text (`source` names it in messages; includes resolve from the working dir).
  TreeDocument loadText(const std::string& xml, const std::string& source) const;
  /// A fresh tree of the document's main tree (cheap enough to build one per trial).
  std::unique_ptr<Tree> instantiate(const TreeDocument& doc) const;

  /// The tree as XML with each node's _uid and _fullpath and every registered node's model:
  /// what BT.CPP's SqliteLogger stores in its Definitions table (WriteTreeToXML with metadata
  /// and built-in models).
  std::string treeToXml(const Tree& tree) const;

 private:
  std::map<std::string, NodeManifest> manifests_;
  ScriptEnums enums_;
  std::vector<std::string> builtins_;
};

}  // namespace mm::bt
