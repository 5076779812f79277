#include "core/error.h"

namespace mm {
void internalError(const std::string& what) { throw std::logic_error("internal error: " + what); }
}  // namespace mm
