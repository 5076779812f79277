#include "core/utf8.h"

#include <cstdio>

#include "core/error.h"

namespace mm {

size_t firstInvalidUtf8(std::string_view s) {
  const auto* p = reinterpret_cast<const unsigned char*>(s.data());
  const size_t n = s.size();
  for (size_t i = 0; i < n;) {
    const unsigned char c = p[i];
    if (c < 0x80) {
      ++i;
      continue;
    }
    size_t len;
    unsigned lo = 0x80, hi = 0xBF;  // the allowed range of the second byte
    if (c >= 0xC2 && c <= 0xDF) len = 2;
    else if (c == 0xE0) len = 3, lo = 0xA0;
    else if (c >= 0xE1 && c <= 0xEC) len = 3;
    else if (c == 0xED) len = 3, hi = 0x9F;  // no UTF-16 surrogates
    else if (c >= 0xEE && c <= 0xEF) len = 3;
    else if (c == 0xF0) len = 4, lo = 0x90;
    else if (c >= 0xF1 && c <= 0xF3) len = 4;
    else if (c == 0xF4) len = 4, hi = 0x8F;  // nothing past U+10FFFF
    else return i;
    if (i + len > n) return i;
    if (p[i + 1] < lo || p[i + 1] > hi) return i;
    for (size_t k = 2; k < len; ++k)
      if (p[i + k] < 0x80 || p[i + k] > 0xBF) return i;
    i += len;
  }
  return std::string_view::npos;
}

namespace {

std::string byteText(unsigned char b) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "0x%02X", b);
  return buf;
}

}  // namespace

std::string escapeInvalidUtf8(std::string_view text) {
  std::string out;
  while (!text.empty()) {
    const size_t bad = firstInvalidUtf8(text);
    if (bad == std::string_view::npos) {
      out.append(text);
      break;
    }
    out.append(text.substr(0, bad));
    char buf[8];
    std::snprintf(buf, sizeof buf, "\\x%02X", static_cast<unsigned char>(text[bad]));
    out += buf;
    text.remove_prefix(bad + 1);
  }
  return out;
}

void requireUtf8(std::string_view text, const std::string& where, const std::string& what) {
  const size_t bad = firstInvalidUtf8(text);
  if (bad == std::string_view::npos) return;
  throw InputError(where, what + " is not valid UTF-8 (byte " + byteText(static_cast<unsigned char>(text[bad])) + " at column " +
                              std::to_string(bad + 1) + "; expected UTF-8 text)");
}

void requireUtf8File(std::string_view contents, const std::string& file) {
  const size_t bad = firstInvalidUtf8(contents);
  if (bad == std::string_view::npos) return;
  size_t line = 1, line_start = 0;
  for (size_t i = 0; i < bad; ++i)
    if (contents[i] == '\n') ++line, line_start = i + 1;
  throw InputError(file + ":" + std::to_string(line) + ":" + std::to_string(bad - line_start + 1),
                   "not valid UTF-8 (byte " + byteText(static_cast<unsigned char>(contents[bad])) + "; expected UTF-8 text)");
}

}  // namespace mm
