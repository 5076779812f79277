#include "bt/factory.h"

#include <tinyxml2.h>

#include <algorithm>
#include <charconv>
#include <filesystem>
#include <functional>
#include <iostream>
#include <set>

#include "bt/builtin_nodes.h"
#include "core/error.h"

namespace mm::bt {
namespace fs = std::filesystem;
using tinyxml2::XMLElement;

namespace {

// A SubTree instance: ticks the referenced tree's root, with its own blackboard.
class SubTreeNode final : public DecoratorNode {
 public:
  using DecoratorNode::DecoratorNode;
  NodeKind kind() const override { return NodeKind::kSubTree; }

 protected:
  NodeStatus tick() override {
    if (status() == NodeStatus::kIdle) setStatus(NodeStatus::kRunning);
    const NodeStatus s = child_->executeTick();
    if (isCompleted(s)) resetChild();
    return s;
  }
};

const char* const kPreNames[] = {"_failureIf", "_successIf", "_skipIf", "_while"};
const char* const kPostNames[] = {"_onHalted", "_onFailure", "_onSuccess", "_post"};
const char* const kExplicitKinds[] = {"Action", "Condition", "Control", "Decorator"};

bool isExplicitForm(const std::string& element) {
  for (const char* k : kExplicitKinds)
    if (element == k) return true;
  return false;
}

// BT.CPP's allowed port names: a letter first, none of the forbidden characters, not reserved.
bool allowedPortName(const std::string& s) {
  if (s.empty() || !std::isalpha(static_cast<unsigned char>(s[0]))) return false;
  if (s == "name" || s == "ID") return false;
  return s.find_first_of(" \t\n\r<>&\"'/\\:*?|.") == std::string::npos;
}

// A SubTree's literal port: int if it fits, else long; a real; else text (BT.CPP's detection).
Any typedLiteral(const std::string& v) {
  if (v.find_first_of(".eE") == std::string::npos) {
    long x = 0;
    const auto [p, ec] = std::from_chars(v.data(), v.data() + v.size(), x);
    if (ec == std::errc() && p == v.data() + v.size() && !v.empty()) {
      if (x >= INT32_MIN && x <= INT32_MAX) return Any(static_cast<int>(x));
      return Any(x);
    }
  }
  double d = 0;
  const auto [p, ec] = std::from_chars(v.data(), v.data() + v.size(), d);
  if (ec == std::errc() && p == v.data() + v.size() && !v.empty()) return Any(d);
  return Any(v);
}

}  // namespace

// ---- the loaded document ---------------------------------------------------------------------

struct SubtreeModel {
  struct Port {
    std::string name;
    std::optional<std::string> default_value;
  };
  std::vector<Port> ports;
};

struct TreeDocument::Impl {
  std::vector<std::unique_ptr<tinyxml2::XMLDocument>> docs;
  struct Definition {
    const XMLElement* element;
    std::string file;
  };
  std::map<std::string, Definition> trees;
  std::map<std::string, SubtreeModel> models;
  std::string main_id, file;
};

TreeDocument::TreeDocument() : impl_(std::make_unique<Impl>()) {}
TreeDocument::~TreeDocument() = default;
TreeDocument::TreeDocument(TreeDocument&&) noexcept = default;
TreeDocument& TreeDocument::operator=(TreeDocument&&) noexcept = default;
const std::string& TreeDocument::mainTreeId() const { return impl_->main_id; }
const std::string& TreeDocument::file() const { return impl_->file; }

std::vector<std::pair<std::string, std::string>> TreeDocument::attributeValues(const std::string& node,
                                                                               const std::string& attribute) const {
  std::vector<std::pair<std::string, std::string>> out;
  for (const auto& [id, def] : impl_->trees) {
    std::vector<const XMLElement*> open{def.element};
    while (!open.empty()) {
      const XMLElement* e = open.back();
      open.pop_back();
      if (node == e->Name())
        if (const char* v = e->Attribute(attribute.c_str())) out.emplace_back(v, def.file + ":" + std::to_string(e->GetLineNum()));
      for (const XMLElement* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) open.push_back(c);
    }
  }
  return out;
}

namespace {

std::string where(const std::string& file, const XMLElement* e) { return file + ":" + std::to_string(e->GetLineNum()); }

// Reads one file's <root>: its trees, models and includes.
void loadRoot(TreeDocument::Impl& doc, const XMLElement* root, const std::string& file, std::set<std::string>& open_files,
              const Factory& factory);

void loadFile(TreeDocument::Impl& doc, const std::string& path, std::set<std::string>& open_files, const Factory& factory,
              const std::string& included_from) {
  const std::string canonical = fs::weakly_canonical(path).string();
  if (open_files.count(canonical)) throw InputError(included_from, "<include> cycle: " + path + " includes itself");
  if (!fs::exists(path)) throw InputError(included_from.empty() ? path : included_from, "no such behavior-tree file: " + path);
  auto xml = std::make_unique<tinyxml2::XMLDocument>();
  if (xml->LoadFile(path.c_str()) != tinyxml2::XML_SUCCESS)
    throw InputError(path + ":" + std::to_string(xml->ErrorLineNum()), std::string("malformed XML: ") + xml->ErrorName() +
                                                                          " (" + (xml->ErrorStr() ? xml->ErrorStr() : "") + ")");
  const XMLElement* root = xml->RootElement();
  doc.docs.push_back(std::move(xml));
  open_files.insert(canonical);
  loadRoot(doc, root, path, open_files, factory);
  open_files.erase(canonical);
}

void loadRoot(TreeDocument::Impl& doc, const XMLElement* root, const std::string& file, std::set<std::string>& open_files,
              const Factory& factory) {
  if (!root || std::string(root->Name()) != "root")
    throw InputError(root ? where(file, root) : file, "the XML must have a root node called <root>");
  const char* format = root->Attribute("BTCPP_format");
  if (!format)
    std::cerr << "warning: " << file << ": <root> should contain the attribute BTCPP_format=\"4\"\n";
  else if (std::string(format) != "4")
    throw InputError(where(file, root), "BTCPP_format=\"" + std::string(format) + "\": only version 4 is supported");
  int models = 0;
  for (const XMLElement* e = root->FirstChildElement(); e; e = e->NextSiblingElement()) {
    const std::string name = e->Name();
    if (name == "include") {
      const char* p = e->Attribute("path");
      if (!p) throw InputError(where(file, e), "invalid <include> tag: missing 'path' attribute");
      fs::path target(p);
      if (target.is_relative()) target = fs::path(file).parent_path() / target;
      loadFile(doc, target.lexically_normal().string(), open_files, factory, where(file, e));
    } else if (name == "BehaviorTree") {
      const char* id = e->Attribute("ID");
      std::string tree_id = id ? id : "";
      if (tree_id.empty()) throw InputError(where(file, e), "<BehaviorTree> needs an ID attribute");
      if (factory.manifests().count(tree_id))
        throw InputError(where(file, e), "The attribute [ID] of tag <BehaviorTree> must not use the name of a registered Node");
      int children = 0;
      for (const XMLElement* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) ++children;
      if (children != 1) throw InputError(where(file, e), "The tag <BehaviorTree> with ID '" + tree_id + "' must have exactly 1 child");
      if (doc.trees.count(tree_id))
        throw InputError(where(file, e), "a tree with ID '" + tree_id + "' is already defined in " + doc.trees[tree_id].file);
      doc.trees[tree_id] = {e, file};
    } else if (name == "TreeNodesModel") {
      if (++models > 1) throw InputError(where(file, e), "Only a single node <TreeNodesModel> is supported");
      for (const XMLElement* m = e->FirstChildElement(); m; m = m->NextSiblingElement()) {
        if (std::string(m->Name()) != "SubTree" || !m->Attribute("ID")) continue;
        SubtreeModel& model = doc.models[m->Attribute("ID")];
        for (const XMLElement* p = m->FirstChildElement(); p; p = p->NextSiblingElement()) {
          const std::string kind = p->Name();
          if ((kind != "input_port" && kind != "output_port" && kind != "inout_port") || !p->Attribute("name")) continue;
          SubtreeModel::Port port{p->Attribute("name"), std::nullopt};
          if (const char* d = p->Attribute("default")) port.default_value = d;
          model.ports.push_back(port);
        }
      }
    } else {
      throw InputError(where(file, e), "unexpected <" + name + "> under <root> (expected <BehaviorTree>, <include> or <TreeNodesModel>)");
    }
  }
}

}  // namespace

// ---- factory ---------------------------------------------------------------------------------

Factory::Factory() {
  registerBuiltinNodes(*this);
  for (const auto& [id, m] : manifests_) builtins_.push_back(id);
}

Factory::~Factory() = default;

void Factory::registerNode(NodeManifest manifest) {
  const std::string id = manifest.id;
  manifests_[id] = std::move(manifest);
}

void Factory::registerScriptingEnum(const std::string& name, int value) {
  auto it = enums_.find(name);
  if (it != enums_.end() && it->second != value) throw RuntimeError("Registering the enum [" + name + "] twice with different values");
  enums_[name] = value;
}

bool Factory::isBuiltin(const std::string& id) const {
  return std::find(builtins_.begin(), builtins_.end(), id) != builtins_.end();
}

namespace {

// Builds one tree from a document; every problem is an InputError naming the element.
class Builder {
 public:
  Builder(const Factory& f, const TreeDocument::Impl& doc, const ScriptEnums& enums, Tree& tree)
      : f_(f), doc_(doc), enums_(enums), tree_(tree) {}

  void buildMain() {
    const auto it = doc_.trees.find(doc_.main_id);
    Blackboard* bb = tree_.newBlackboard(nullptr);
    tree_.addSubtree({"", doc_.main_id, bb, {}});
    std::set<std::string> ancestors{doc_.main_id};
    tree_.setRoot(build(it->second.element->FirstChildElement(), it->second.file, bb, 0, "", ancestors));
  }

 private:
  [[noreturn]] void fail(const std::string& file, const XMLElement* e, const std::string& what) const {
    throw InputError(where(file, e), "<" + std::string(e->Name()) + (e->Attribute("name") ? " name=\"" + std::string(e->Attribute("name")) + "\"" : "") +
                                         ">: " + what);
  }

  // Scripts of the pre/post-condition attributes.
  void conditions(const XMLElement* e, const std::string& file, NodeConfig& config) const {
    for (int k = 0; k < NodeConfig::kPreCount; ++k)
      if (const char* code = e->Attribute(kPreNames[k])) config.pre[k] = parseScript(code, file, e);
    for (int k = 0; k < NodeConfig::kPostCount; ++k)
      if (const char* code = e->Attribute(kPostNames[k])) config.post[k] = parseScript(code, file, e);
  }
  Script parseScript(const std::string& code, const std::string& file, const XMLElement* e) const {
    try {
      return Script::parse(code);
    } catch (const RuntimeError& err) {
      fail(file, e, "Error in the script \"" + code + "\": " + err.what());
    }
  }

  // The blackboard entry a port points to, created with the port's type; two strongly typed
  // ports of different types on one key are an error (unless the first was a string).
  void declareEntry(Blackboard* bb, const std::string& key, const PortInfo& port, const std::string& file,
                    const XMLElement* e) const {
    try {
      if (Blackboard::Entry* prev = bb->getEntry(key)) {
        if (prev->info.stronglyTyped() && port.type.stronglyTyped() && prev->info.name != port.type.name &&
            prev->info.name != "std::string")
          fail(file, e, "The creation of the tree failed because the port [" + key + "] was initially created with type [" +
                            prev->info.name + "] and, later type [" + port.type.name + "] was used somewhere else.");
        return;
      }
      bb->createEntry(key, port.type);
    } catch (const RuntimeError& err) {
      fail(file, e, err.what());
    }
  }

  TreeNode* build(const XMLElement* e, const std::string& file, Blackboard* bb, size_t subtree, const std::string& prefix,
                  std::set<std::string>& ancestors) {
    std::string id = e->Name();
    if (isExplicitForm(id)) {
      if (!e->Attribute("ID")) fail(file, e, "the explicit form <" + id + "> needs an ID attribute");
      id = e->Attribute("ID");
    } else if (id != "SubTree" && e->Attribute("ID")) {
      fail(file, e, "Attribute [ID] is not allowed in <" + id + ">");
    }
    if (id == "SubTree") return buildSubtree(e, file, bb, subtree, prefix, ancestors);
    const auto m = f_.manifests().find(id);
    if (m == f_.manifests().end()) fail(file, e, "Node not recognized: " + id);
    const NodeManifest& manifest = m->second;

    int children = 0;
    for (const XMLElement* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) ++children;
    if (manifest.max_children == 0 && children > 0) fail(file, e, "The node '" + id + "' must not have any child");
    if (manifest.min_children == 1 && manifest.max_children == 1 && children != 1)
      fail(file, e, "The node '" + id + "' must have exactly 1 child");
    if (children < manifest.min_children)
      fail(file, e, "The node '" + id + "' must have " + std::to_string(manifest.min_children) + " or more children");
    if (manifest.max_children > 0 && children > manifest.max_children)
      fail(file, e, "The node '" + id + "' must have at most " + std::to_string(manifest.max_children) + " children");
    if (id == "ReactiveSequence") {
      int async = 0;
      for (const XMLElement* c = e->FirstChildElement(); c; c = c->NextSiblingElement())
        async += std::string(c->Name()) == "AsyncSequence";
      if (async > 1) fail(file, e, "A ReactiveSequence cannot have more than one async child.");
    }

    const char* name_attr = e->Attribute("name");
    const std::string instance = name_attr ? name_attr : id;
    NodeConfig config;
    config.blackboard = bb;
    config.enums = &enums_;
    config.ports = &manifest.ports;
    config.uid = tree_.nextUid();
    config.path = prefix + instance + (instance == id ? "::" + std::to_string(config.uid) : "");
    config.registration_id = id;
    config.tree = &tree_;
    config.where = where(file, e);
    conditions(e, file, config);
    for (const tinyxml2::XMLAttribute* a = e->FirstAttribute(); a; a = a->Next()) {
      const std::string port = a->Name(), value = a->Value();
      if (!allowedPortName(port)) continue;  // name, ID, _conditions and other reserved attributes
      const auto p = manifest.ports.find(port);
      if (p == manifest.ports.end()) {
        std::string known;
        for (const auto& [k, info] : manifest.ports) known += (known.empty() ? "" : ", ") + k;
        fail(file, e, "a port with name [" + port + "] is found in the XML (<" + id + ">, line " +
                          std::to_string(a->GetLineNum()) + ") but not in the providedPorts() of its registered node type" +
                          (known.empty() ? " (it has none)" : " (its ports: " + known + ")"));
      }
      const PortInfo& info = p->second;
      if (info.direction != PortDirection::kOutput) config.input_ports[port] = value;
      if (info.direction != PortDirection::kInput) config.output_ports[port] = value;
      if (const auto key = blackboardKey(value, port)) {
        declareEntry(bb, *key, info, file, e);
      } else if (info.direction == PortDirection::kOutput) {
        fail(file, e, "the output port [" + port + "] must point to a blackboard entry ({key}), got \"" + value + "\"");
      } else if (info.type.stronglyTyped() && info.type.parse) {
        try {
          info.type.parse(value);
        } catch (const std::exception&) {
          fail(file, e, "The port with name \"" + port + "\" and value \"" + value + "\" can not be converted to " + info.type.name);
        }
      }
    }
    for (const auto& [port, info] : manifest.ports) {
      if (e->Attribute(port.c_str())) continue;
      if (info.default_value) {
        if (info.direction != PortDirection::kOutput) config.input_ports[port] = *info.default_value;
        if (info.direction != PortDirection::kInput && blackboardKey(*info.default_value, port))
          config.output_ports[port] = *info.default_value;
      } else if (info.required()) {
        fail(file, e, "missing required port [" + port + "]" + (info.description.empty() ? "" : " (" + info.description + ")"));
      }
    }
    std::unique_ptr<TreeNode> node;
    try {
      node = manifest.build(instance, config);
    } catch (const std::exception& err) {
      fail(file, e, err.what());
    }
    TreeNode* raw = tree_.adopt(std::move(node));
    tree_.subtree(subtree).nodes.push_back(raw);
    for (const XMLElement* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) {
      TreeNode* child = build(c, file, bb, subtree, prefix, ancestors);
      if (auto* control = dynamic_cast<ControlNode*>(raw)) control->addChild(child);
      else if (auto* decorator = dynamic_cast<DecoratorNode*>(raw)) decorator->setChild(child);
    }
    return raw;
  }

  TreeNode* buildSubtree(const XMLElement* e, const std::string& file, Blackboard* bb, size_t subtree,
                         const std::string& prefix, std::set<std::string>& ancestors) {
    const char* id_attr = e->Attribute("ID");
    if (!id_attr) fail(file, e, "<SubTree> needs an ID attribute");
    const std::string id = id_attr;
    if (e->FirstChildElement()) fail(file, e, "<SubTree> must not have any child");
    const auto def = doc_.trees.find(id);
    if (def == doc_.trees.end()) fail(file, e, "Can't find a tree with name: " + id);
    if (ancestors.count(id))
      fail(file, e, "Recursive behavior tree cycle detected: tree '" + id + "' references itself (directly or indirectly)");
    const char* name_attr = e->Attribute("name");
    NodeConfig config;
    config.blackboard = bb;
    config.enums = &enums_;
    config.uid = tree_.nextUid();
    const std::string instance = name_attr ? std::string(name_attr) : id + "::" + std::to_string(config.uid);
    config.path = prefix + instance;
    config.registration_id = "SubTree";
    config.tree = &tree_;
    config.where = where(file, e);
    conditions(e, file, config);
    for (const auto& s : tree_.subtrees())
      if (s.instance_name == config.path)
        fail(file, e, "Duplicate SubTree path detected: '" + config.path + "'. Use unique names or omit the 'name' attribute");
    Blackboard* inner = tree_.newBlackboard(bb);
    bool autoremap = false;
    if (const char* a = e->Attribute("_autoremap")) {
      try {
        autoremap = parseBool(a);
      } catch (const RuntimeError&) {
        fail(file, e, "_autoremap expects true or false, got \"" + std::string(a) + "\"");
      }
    }
    inner->enableAutoRemapping(autoremap);
    std::map<std::string, std::string> ports;
    for (const tinyxml2::XMLAttribute* a = e->FirstAttribute(); a; a = a->Next())
      if (allowedPortName(a->Name())) ports[a->Name()] = a->Value();
    if (const auto model = doc_.models.find(id); model != doc_.models.end() && !autoremap)
      for (const auto& p : model->second.ports) {
        if (ports.count(p.name)) continue;
        if (!p.default_value)
          fail(file, e, "In the <TreeNodesModel> the <Subtree ID=\"" + id + "\"> is defining a mandatory port called [" + p.name +
                            "], but you are not remapping it");
        ports[p.name] = *p.default_value;
      }
    for (const auto& [port, value] : ports) {
      const auto key = blackboardKey(value, port);
      if (key) inner->addSubtreeRemapping(port, *key);
      else inner->set(port, typedLiteral(value));
      config.input_ports[port] = value;
    }
    auto node = std::make_unique<SubTreeNode>(instance, config);
    auto* raw = static_cast<SubTreeNode*>(tree_.adopt(std::move(node)));
    tree_.subtree(subtree).nodes.push_back(raw);
    tree_.addSubtree({config.path, id, inner, {}});
    const size_t index = tree_.subtrees().size() - 1;
    ancestors.insert(id);
    raw->setChild(build(def->second.element->FirstChildElement(), def->second.file, inner, index, config.path + "/", ancestors));
    ancestors.erase(id);
    return raw;
  }

  const Factory& f_;
  const TreeDocument::Impl& doc_;
  const ScriptEnums& enums_;
  Tree& tree_;
};

void chooseMain(TreeDocument::Impl& doc, const XMLElement* root, const std::string& file) {
  if (const char* m = root->Attribute("main_tree_to_execute")) {
    doc.main_id = m;
  } else {
    std::vector<std::string> own;
    for (const XMLElement* e = root->FirstChildElement("BehaviorTree"); e; e = e->NextSiblingElement("BehaviorTree"))
      if (e->Attribute("ID")) own.push_back(e->Attribute("ID"));
    if (own.size() != 1)
      throw InputError(where(file, root), "[main_tree_to_execute] was not specified correctly: " + std::to_string(own.size()) +
                                              " trees in the file and no main_tree_to_execute attribute on <root>");
    doc.main_id = own.front();
  }
  if (!doc.trees.count(doc.main_id)) throw InputError(where(file, root), "Can't find a tree with name: " + doc.main_id);
}

}  // namespace

TreeDocument Factory::load(const std::string& path) const {
  TreeDocument d;
  TreeDocument::Impl& doc = d.impl();
  doc.file = path;
  std::set<std::string> open;
  loadFile(doc, path, open, *this, "");
  chooseMain(doc, doc.docs.front()->RootElement(), path);
  instantiate(d);  // every node, port and script checked once, before any trial
  return d;
}

TreeDocument Factory::loadText(const std::string& xml, const std::string& source) const {
  TreeDocument d;
  TreeDocument::Impl& doc = d.impl();
  doc.file = source;
  auto x = std::make_unique<tinyxml2::XMLDocument>();
  if (x->Parse(xml.c_str()) != tinyxml2::XML_SUCCESS)
    throw InputError(source + ":" + std::to_string(x->ErrorLineNum()), std::string("malformed XML: ") + x->ErrorName() +
                                                                         " (" + (x->ErrorStr() ? x->ErrorStr() : "") + ")");
  const XMLElement* root = x->RootElement();
  doc.docs.push_back(std::move(x));
  std::set<std::string> open;
  loadRoot(doc, root, source, open, *this);
  chooseMain(doc, root, source);
  instantiate(d);
  return d;
}

std::unique_ptr<Tree> Factory::instantiate(const TreeDocument& d) const {
  auto tree = std::make_unique<Tree>();
  Builder(*this, d.impl(), enums_, *tree).buildMain();
  return tree;
}

// ---- the tree as XML (the SQLite log's Definitions) ------------------------------------------

std::string Factory::treeToXml(const Tree& tree) const {
  tinyxml2::XMLPrinter out;
  out.OpenElement("root");
  out.PushAttribute("BTCPP_format", "4");
  // The SubTree node -> its instance (tree ID and path), to write <SubTree ID=...>.
  std::map<const TreeNode*, const Tree::Subtree*> instance_of;
  for (const auto& s : tree.subtrees())
    for (const TreeNode* n : s.nodes)
      if (n->kind() == NodeKind::kSubTree)
        for (const auto& t : tree.subtrees())
          if (t.instance_name == n->fullPath()) instance_of[n] = &t;
  std::function<void(const TreeNode&)> write = [&](const TreeNode& n) {
    if (n.kind() == NodeKind::kSubTree) {
      out.OpenElement("SubTree");
      out.PushAttribute("ID", instance_of.count(&n) ? instance_of[&n]->tree_id.c_str() : "");
      out.PushAttribute("_fullpath", n.fullPath().c_str());
      out.PushAttribute("_uid", n.uid());
      for (const auto& [port, value] : n.config().input_ports) out.PushAttribute(port.c_str(), value.c_str());
      out.CloseElement();
      return;
    }
    out.OpenElement(n.registrationId().c_str());
    out.PushAttribute("name", n.name().c_str());
    out.PushAttribute("_uid", n.uid());
    std::map<std::string, std::string> ports = n.config().input_ports;
    for (const auto& [port, value] : n.config().output_ports) ports[port] = value;
    for (const auto& [port, value] : ports) out.PushAttribute(port.c_str(), value.c_str());
    for (int k = 0; k < NodeConfig::kPreCount; ++k)
      if (n.config().pre[k]) out.PushAttribute(kPreNames[k], n.config().pre[k]->code().c_str());
    for (int k = 0; k < NodeConfig::kPostCount; ++k)
      if (n.config().post[k]) out.PushAttribute(kPostNames[k], n.config().post[k]->code().c_str());
    for (TreeNode* c : n.children()) write(*c);
    out.CloseElement();
  };
  for (const auto& s : tree.subtrees()) {
    out.OpenElement("BehaviorTree");
    out.PushAttribute("ID", s.tree_id.c_str());
    out.PushAttribute("_fullpath", s.instance_name.c_str());
    // The instance's root: the first node created in it.
    if (!s.nodes.empty()) write(*s.nodes.front());
    out.CloseElement();
  }
  out.OpenElement("TreeNodesModel");
  for (const auto& [id, m] : manifests_) {
    out.OpenElement(toString(m.kind));
    out.PushAttribute("ID", id.c_str());
    for (const auto& [port, info] : m.ports) {
      out.OpenElement(info.direction == PortDirection::kInput    ? "input_port"
                      : info.direction == PortDirection::kOutput ? "output_port"
                                                                 : "inout_port");
      out.PushAttribute("name", port.c_str());
      out.PushAttribute("type", info.type.stronglyTyped() ? info.type.name.c_str() : "BT::AnyTypeAllowed");
      if (info.default_value) out.PushAttribute("default", info.default_value->c_str());
      if (!info.description.empty()) out.PushText(info.description.c_str());
      out.CloseElement();
    }
    out.CloseElement();
  }
  out.OpenElement("SubTree");
  out.PushAttribute("ID", "SubTree");
  out.OpenElement("input_port");
  out.PushAttribute("name", "_autoremap");
  out.PushAttribute("type", "bool");
  out.PushAttribute("default", "false");
  out.PushText("If true, all the ports with the same name will be remapped");
  out.CloseElement();
  out.CloseElement();
  out.CloseElement();  // TreeNodesModel
  out.CloseElement();  // root
  return out.CStr();
}

}  // namespace mm::bt
