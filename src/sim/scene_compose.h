// Scene composition: a scene MJCF holds the world only (table, bins, tray, obstacles, cameras,
// lights); the robot's MJCF, written from its arm and gripper YAML, is mounted into it by code, the
// trial's objects are added from the object catalogue (sim/object_catalogue.h), with the
// weld-on-grasp equalities that tie each object to the gripper's hand. MuJoCo 2.2 has no
// model-editing API, so the composition is XML, compiled from memory.
//
// The scene contract (what the harness reads by name):
//   robot_mount       optional site, a child of <worldbody>: where the robot's base stands (the
//                     world origin when absent), turned about z only. The harness works in the
//                     base's frame: a mount elsewhere moves the scene by its inverse (the static
//                     parts inside one frame body; free and mocap bodies each), so the composed
//                     model's world frame is the robot's base frame.
//   object_park       optional site: where objects out of play rest (object_k at 0.1 m steps
//                     along the site's x, five to a row, rows 0.1 m apart along its y; its z is the
//                     surface they rest on). Absent: far below the scene.
//   obstacle_<k>      mocap bodies with one box geom: the obstacle pool (optional)
//   bin_region        box site: where objects are spawned and searched for
//   place_target      site: where a placed object goes
#pragma once
#include <string>

#include <vector>

#include "robot/robot_spec.h"
#include "sim/object_catalogue.h"

namespace mm {

/// Whether an <include>d file is a URDF static cell part (its extension .urdf, any case), which
/// composeScene expands, rather than MJCF.
bool isUrdfPart(const std::string& path);

/// The files a scene reads besides itself, for a campaign's fingerprint: each file it <include>s
/// (recursively), and each URDF cell part's meshes, in the order met. Throws InputError as
/// composeScene would for a file that cannot be read.
std::vector<std::string> sceneSources(const std::string& scene_xml);

/// The scene's MJCF with the robot mounted, `objects` added as bodies object_0, object_1, ... (a
/// free joint each, and one box or cylinder geom, or a mesh kind's convex pieces (group 3) and its
/// drawn mesh (no contacts) with its <inertial>; in the base frame, where MuJoCo's initial state
/// leaves them does not matter: SimWorld parks them) and one weld `attach_<k>` (off) per object, as a
/// self-contained MJCF text (the scene's <include>s expanded). Throws InputError naming the scene
/// file for malformed XML, a scene that already holds a body of the robot's or an object_<k> body,
/// or a misplaced mount.
std::string composeScene(const std::string& scene_xml, const RobotSpec& robot, const std::vector<ObjectKind>& objects);

}  // namespace mm
