// Objects from meshes: the triangles of an OBJ or STL file as solids (closed, outward-oriented
// surfaces), their mass properties, and a convex hull with few enough vertices for MuJoCo to collide
// quickly.
#pragma once
#include <array>
#include <string>
#include <vector>

#include "core/pose.h"
#include "robot/mesh.h"

namespace mm {

/// One part of a mesh file: its triangles over its own vertices.
struct TriangleMesh {
  std::string part;                       ///< OBJ group/object name ("" for STL or an OBJ without groups)
  std::vector<Vec3> vertices;             ///< [m], scaled
  std::vector<std::array<int, 3>> faces;  ///< triangles as in the file (polygons fan-triangulated)
};

/// Volume, centroid and inertia of a solid.
struct MassProperties {
  double volume = 0;             ///< [m^3]
  Vec3 centroid = Vec3::Zero();  ///< [m]
  Mat3 inertia = Mat3::Zero();   ///< about the centroid, world axes, for unit density (1 kg/m^3) [kg m^2]
};

/// The parts of an OBJ or STL file, every vertex scaled by `scale` (per axis).
/// OBJ: each 'o' or 'g' that has faces is one part (faces before any are a part named ""; an 'o' or
/// 'g' named again adds to its part); 'f' entries may be v, v/vt, v//vn or v/vt/vn, negative indices
/// count back from the last vertex read; polygons are fan-triangulated; vertices are global to the
/// file, and each part keeps only the vertices its faces use (in file order), re-indexed.
/// STL (binary or ASCII): one part, vertices welded where their positions are exactly equal.
/// Throws InputError naming `path` (and ":line" for an OBJ line) for an unreadable file, another
/// extension, no faces, a face index out of range or a number that is not finite.
std::vector<TriangleMesh> readMeshParts(const std::string& path, const Vec3& scale = Vec3::Ones());

/// Mass properties of a closed, outward-oriented triangle mesh (divergence theorem). Faces wound
/// inside out give a negative volume and inertia; a mesh with no volume gives zero inertia and its
/// bounding box's centre.
MassProperties massProperties(const TriangleMesh& m);

/// Throws InputError(what, reason) unless `m` is a solid: at least 4 vertices and 4 faces, finite
/// vertices and face indices in range, its bounding box's largest side within [min_extent,
/// max_extent] [m] (the message suggests a scale of 0.001 when that would fit), no degenerate
/// (zero-area) triangle, every edge shared by exactly two faces (closed and manifold), consistently
/// oriented (each directed edge used once) and a positive volume (a negative one: inside out).
void checkSolid(const TriangleMesh& m, const std::string& what, double min_extent = 0.005, double max_extent = 1.0);

/// The convex hull of `points` with at most `max_vertices` (>= 4) vertices: the full hull if it has
/// no more, otherwise the hull of `max_vertices` of its vertices chosen by farthest-point sampling
/// (starting at the one with the largest x; ties go to the lower index in `points`), so the result
/// depends on the points only. Throws InputError naming `what` for max_vertices < 4 or points that
/// span no volume.
ConvexHull cappedHull(const std::vector<Vec3>& points, int max_vertices, const std::string& what);

/// Inertia [kg m^2] about the centroid of a solid of `mass` [kg] (uniform density): the unit-density
/// tensor scaled by mass / volume. The volume must be positive (checkSolid).
Mat3 inertiaWithMass(const MassProperties& p, double mass);

}  // namespace mm
