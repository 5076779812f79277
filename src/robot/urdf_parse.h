// Internal to robot/: urdfdom's parser with its console messages captured, so a rejected URDF is
// reported with urdfdom's reason and the file (and line, for malformed XML).
#pragma once
#include <memory>
#include <string>

namespace urdf {
class ModelInterface;
}

namespace mm {

/// Parses URDF text; `origin` names it in errors. Throws InputError.
std::shared_ptr<urdf::ModelInterface> parseUrdfText(const std::string& text, const std::string& origin);

}  // namespace mm
