// The behavior-tree XML loader (bt/factory.h) with our node library: XML, includes, ports, scripts,
// and building the main tree once. Pure parsing.
#include <memory>

#include "bt/factory.h"
#include "bt/manip_nodes.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static mm::bt::TaskNodeEnv env;
  static const std::unique_ptr<mm::bt::Factory> factory = [] {
    auto f = std::make_unique<mm::bt::Factory>();
    mm::bt::registerTaskNodes(*f, env);
    return f;
  }();
  const std::string path = mm::fuzz::asFile(data, size, "tree.xml");
  mm::fuzz::expectOnlyInputErrors([&] { factory->load(path); });
  return 0;
}
