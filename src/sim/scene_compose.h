// Scene composition: a scene MJCF holds the world only (table, bins, tray, object pool, obstacles,
// cameras, lights); the robot's MJCF, written from its arm and gripper YAML, is mounted into it by
// code, with the weld-on-grasp equalities that tie each object to the gripper's hand. MuJoCo 2.2
// has no model-editing API, so the composition is XML, compiled from memory.
//
// The scene contract (what the harness reads by name):
//   robot_mount       optional site, a child of <worldbody>: where the robot's base stands (the
//                     world origin when absent), turned about z only. The harness works in the
//                     base's frame: a mount elsewhere moves the scene by its inverse (the static
//                     parts inside one frame body; free and mocap bodies each), so the composed
//                     model's world frame is the robot's base frame.
//   object_<k>        bodies with one free joint and one box geom: the object pool, k = 0, 1, ...
//   obstacle_<k>      mocap bodies with one box geom: the obstacle pool (optional)
//   bin_region        box site: where objects are spawned and searched for
//   place_target      site: where a placed object goes
#pragma once
#include <string>

#include "robot/robot_spec.h"

namespace mm {

/// The scene's MJCF with the robot mounted and one weld `attach_<k>` (off) per object_<k>, as a
/// self-contained MJCF text (the scene's <include>s expanded). Throws InputError naming the scene
/// file for malformed XML, a scene that already holds a body of the robot's, or a misplaced mount.
std::string composeScene(const std::string& scene_xml, const RobotSpec& robot);

}  // namespace mm
