// The arm and gripper YAML loaders (robot/robot_spec.h): the first byte picks which. Pure parsing
// (the arm's gripper is the stock one, named absolutely).
#include "fuzz_common.h"
#include "robot/robot_spec.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const bool arm = data[0] & 1;
  const std::string path = mm::fuzz::asFile(data + 1, size - 1, arm ? "arm.yaml" : "gripper.yaml");
  mm::fuzz::expectOnlyInputErrors([&] {
    if (arm) mm::loadRobotSpec(path, mm::fuzz::repo("robots/grippers/panda_hand.yaml"));
    else mm::loadGripperSpec(path);
  });
  return 0;
}
