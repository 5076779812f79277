// Internal to robot/: urdfdom's parser with its console messages captured, so a rejected URDF is
// reported with urdfdom's reason and the file (and line, for malformed XML).
#pragma once
#include <memory>
#include <string>
#include <vector>

namespace urdf {
class ModelInterface;
}

namespace mm {

/// Parses URDF text; `origin` names it in errors. Throws InputError.
std::shared_ptr<urdf::ModelInterface> parseUrdfText(const std::string& text, const std::string& origin);

/// Where a URDF's package:// meshes are looked for: `first`, then ROS_PACKAGE_PATH's folders, then
/// the URDF's folder and its ancestors (a package as published keeps urdf/ and meshes/ side by side).
std::vector<std::string> urdfSearchDirs(const std::string& urdf_path, std::vector<std::string> first = {});

/// A URDF mesh's filename as a path: package://<pkg>/... found in `dirs` (in order), file://...,
/// or relative to the URDF's folder. Throws InputError(where) naming `searched` for a package
/// path found nowhere.
std::string resolveUrdfMesh(const std::string& filename, const std::string& urdf_path, const std::vector<std::string>& dirs,
                            const std::string& where, const std::string& searched);

}  // namespace mm
