// Objects as URDF files: one link with its inertial, visual and collision elements, the way
// PyBullet-era object sets (and bins) are distributed. Read here into plain geometry (the
// simulator's composition turns it into a body: sim/object_catalogue.h).
#pragma once
#include <string>
#include <vector>

#include "core/pose.h"
#include "robot/solid_mesh.h"

namespace mm {

struct UrdfObject {
  std::string name;  ///< the link's
  std::vector<std::string> files;  ///< the mesh files it reads (a campaign's fingerprint holds them)
  /// The collision elements, each a convex piece's points in the link frame [m]: a mesh file's
  /// parts (each its own piece; scaled and placed by the element's origin), a box's corners, a
  /// cylinder's and a sphere's points on their surface (a 32-gon prism; an icosphere of 42 points).
  std::vector<std::vector<Vec3>> collision;
  std::vector<std::string> collision_what;  ///< each piece's origin in the file, for messages
  /// Each piece's primitive when the element was one (a static cell part collides as it exactly):
  /// its kind, its pose in the link frame and its size as MuJoCo's geoms take it (box: half sizes;
  /// cylinder: radius, half length, along its z; sphere: radius). kNone: a mesh file's part.
  struct Primitive {
    enum class Kind { kNone, kBox, kCylinder, kSphere } kind = Kind::kNone;
    Pose T = Pose::Identity();
    Vec3 size = Vec3::Zero();
  };
  std::vector<Primitive> collision_primitive;
  /// The visual elements' mesh files as triangles in the link frame (primitives: none).
  std::vector<TriangleMesh> visual;
  bool has_inertial = false;  ///< the link gives <inertial>
  double mass = 0;            ///< [kg]
  Vec3 com = Vec3::Zero();    ///< [m] in the link frame
  Mat3 inertia = Mat3::Zero();  ///< [kg m^2] about the com, link axes
};

/// Reads an object URDF (or a static cell part's: a bin, a tray, a table): exactly one link, at least one collision element, mesh files STL or OBJ
/// (package:// found in ROS_PACKAGE_PATH and the folders above the URDF; file://; relative to it).
/// Throws InputError naming the file (and the link) for anything else, or an inertial with a mass
/// <= 0 or an inertia that no body has.
UrdfObject loadUrdfObject(const std::string& path);

}  // namespace mm
