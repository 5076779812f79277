// UTF-8 at the boundary: text that enters (files, --set values, paths) is checked once where it
// enters, so that a stray byte is reported with its place instead of failing deep inside (a JSON
// writer refusing a record, say).
#pragma once
#include <cstddef>
#include <string>
#include <string_view>

namespace mm {

/// The offset of the first byte that does not belong to well-formed UTF-8 (RFC 3629: no
/// overlong forms, no surrogates, nothing past U+10FFFF), or std::string_view::npos.
size_t firstInvalidUtf8(std::string_view text);

/// `text` with each byte that is not part of well-formed UTF-8 written as \xNN (for messages).
std::string escapeInvalidUtf8(std::string_view text);

/// Throws InputError at `where` when `text` is not UTF-8: "<what> is not valid UTF-8 (byte 0xE9
/// at column 7 ...)". Lines and columns count from 1, columns in bytes.
void requireUtf8(std::string_view text, const std::string& where, const std::string& what);

/// As requireUtf8 for a whole file's contents: the place is `file`:line:column.
void requireUtf8File(std::string_view contents, const std::string& file);

}  // namespace mm
