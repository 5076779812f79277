// The experiment loader (campaign/experiment.h): YAML, keys, values, paths, sweeps. Pure parsing.
#include "campaign/experiment.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = mm::fuzz::asFile(data, size, "experiment.yaml");
  mm::fuzz::expectOnlyInputErrors([&] { mm::loadExperiment(path, {}, {}, true); });
  return 0;
}
