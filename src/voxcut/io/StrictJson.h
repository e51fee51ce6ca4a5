#pragma once
/// @file StrictJson.h
/// Strict JSON parsing for the readers of io/: a bounded nesting depth, no key repeated in one
/// object, and time and memory linear in the size of the text. Internal to io/ (it returns
/// nlohmann's ordered_json, a private dependency of the library).
///
/// Thread-safety: reentrant, no shared state.

#include <cstddef>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <utility>

namespace voxcut::detail {

/// Parses the JSON document `text` (strict: no comments, no trailing commas) into an
/// ordered_json that keeps every object's keys in the order written.
///
/// The nesting depth (lists and objects inside one another) is checked by a linear scan of
/// the text, strings and escapes skipped, before the parser sees it, so that no later
/// recursion over the document can run out of stack. The document is built by a SAX handler
/// that appends each member and element in constant amortised time (nlohmann's callback
/// parser rescans a container's members after each nested object, quadratic in a long list).
///
/// Throws InputError, one line starting with "SOURCE: ", for nesting deeper than `maxDepth`
/// (line and column of the first bracket too deep), a syntax error (line and column), a
/// number too large for a double (line and column), and a key that appears twice in one
/// object (the parser would keep the last one silently).
[[nodiscard]] nlohmann::ordered_json parseStrictJson(std::string_view text,
                                                     const std::string& source,
                                                     std::size_t maxDepth);

/// `text` with every control character (newline, tab, ...) written as a JSON escape (\n, \t,
/// \u001b, ...), so that a key or path quoted in a message keeps the message on one line.
[[nodiscard]] std::string oneLine(std::string_view text);

/// Line and column (both from 1; columns count bytes) of the byte at `offset` (from 0) of
/// `text`; an offset past the end counts as the end.
[[nodiscard]] std::pair<std::size_t, std::size_t> lineAndColumn(std::string_view text,
                                                                std::size_t offset);

}  // namespace voxcut::detail
