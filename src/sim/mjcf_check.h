// Checks an MJCF file (and the files it includes) before MuJoCo sees it: well-formed XML, no NaN or
// infinite numbers, no zero quaternions, no mesh file names MuJoCo 2.2.2 would abort on. MuJoCo
// itself loads NaN sizes and zero quaternions silently, so these are caught here.
#pragma once
#include <string>

namespace mm {

/// Throws InputError naming file:line, the element and attribute, and what was expected.
void checkMjcf(const std::string& path);

}  // namespace mm
