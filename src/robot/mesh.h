// Collision meshes: STL (binary or ASCII) and OBJ files read into vertices, and their convex hull
// (qhull, as MuJoCo computes it for collision). A mesh collides as its hull everywhere: in MuJoCo,
// in FCL, and in the sphere cover built from it.
#pragma once
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/pose.h"

namespace mm {

struct ConvexHull {
  std::vector<Vec3> vertices;               ///< the hull's vertices [m]
  std::vector<std::array<int, 3>> faces;    ///< triangles, counter-clockwise seen from outside
  Vec3 lower = Vec3::Zero(), upper = Vec3::Zero();  ///< axis-aligned bounds of the vertices
};

/// The vertices of an STL (binary or ASCII) or OBJ file, each scaled by `scale`. Throws InputError
/// naming the file for an unreadable, empty or malformed one, or another format.
std::vector<Vec3> readMeshVertices(const std::string& path, const Vec3& scale = Vec3::Ones());

/// Whether `bytes` are a binary STL (80-byte header, triangle count, 50 bytes a triangle: the size
/// its count gives; an ASCII file has another), and its triangle count.
bool binaryStl(const std::string& bytes, uint32_t& triangles);

/// The convex hull of `points` (qhull). Throws InputError naming `what` when the points span no
/// volume (fewer than four, or all on a plane).
ConvexHull convexHull(const std::vector<Vec3>& points, const std::string& what);

/// An OBJ file of these vertices (a mesh a description holds in memory, e.g. MuJoCo's compiled
/// one), under the temporary directory, named by its content and written once; its path.
std::string meshCacheFile(const std::vector<Vec3>& vertices);

/// The hull of a mesh file, scaled; read once per (file, scale) and shared.
std::shared_ptr<const ConvexHull> meshHull(const std::string& path, const Vec3& scale = Vec3::Ones());

}  // namespace mm
