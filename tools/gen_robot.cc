// gen_robot ROBOT.yaml: writes <dir>/<name>.xml (MJCF) and <dir>/<name>.urdf from the robot's YAML.
#include <fstream>
#include <iostream>

#include "core/error.h"
#include "robot/description_writer.h"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: gen_robot ROBOT.yaml\n";
    return 2;
  }
  try {
    const mm::RobotSpec spec = mm::loadRobotSpec(argv[1]);
    std::ofstream(spec.mjcfPath()) << mm::writeMjcf(spec);
    std::ofstream(spec.urdfPath()) << mm::writeUrdf(spec);
    std::cout << "wrote " << spec.mjcfPath() << " and " << spec.urdfPath() << "\n";
  } catch (const mm::InputError& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 2;
  }
  return 0;
}
