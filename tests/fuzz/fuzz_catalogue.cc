// The object catalogue loader (sim/object_catalogue.h). Pure parsing.
#include "fuzz_common.h"
#include "sim/object_catalogue.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = mm::fuzz::asFile(data, size, "objects.yaml");
  mm::fuzz::expectOnlyInputErrors([&] { mm::loadObjectCatalogue(path); });
  return 0;
}
