// The URDF robot loader (robot/urdf_robot.cc: tinyxml2, urdfdom, our chain, meshes). Pure parsing
// (no companion; the stock gripper).
#include "fuzz_common.h"
#include "robot/robot_spec.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = mm::fuzz::asFile(data, size, "robot.urdf");
  mm::fuzz::expectOnlyInputErrors([&] { mm::loadRobotSpec(path, mm::fuzz::repo("robots/grippers/panda_hand.yaml")); });
  return 0;
}
