// Under AddressSanitizer + UBSan (tools/test --sanitize) our code runs about ten times slower. That
// pass looks for memory and undefined-behaviour errors, which the same code paths show on a few
// trials as well as on many; a test whose size is for statistics or for a margin of wall time runs
// a smaller share of it there (`sanitizedOr(small, full)`), and the Release pass keeps the full size.
#pragma once

namespace mm::testing_sanitized {

#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = false;
#endif

/// `small` in the sanitized build, `full` otherwise.
constexpr int sanitizedOr(int small, int full) { return kSanitized ? small : full; }

}  // namespace mm::testing_sanitized
