#include "voxcut/io/StrictJson.h"

#include <algorithm>
#include <cstdio>
#include <unordered_set>
#include <vector>

#include "voxcut/core/Error.h"

namespace voxcut::detail {
namespace {

using Json = nlohmann::ordered_json;

/// Throws at the first '[' or '{' outside strings that opens more than maxDepth containers.
/// Brackets that do not balance are left to the parser, which reports them precisely.
void checkDepth(std::string_view text, const std::string& source, std::size_t maxDepth) {
  std::size_t depth = 0, line = 1, column = 1;
  bool inString = false, escaped = false;
  for (const char c : text) {
    if (inString) {
      if (escaped)
        escaped = false;
      else if (c == '\\')
        escaped = true;
      else if (c == '"')
        inString = false;
    } else if (c == '"') {
      inString = true;
    } else if (c == '[' || c == '{') {
      if (++depth > maxDepth)
        throw InputError(source + ": JSON nesting too deep at line " + std::to_string(line) +
                         ", column " + std::to_string(column) + ": more than " +
                         std::to_string(maxDepth) + " lists and objects inside one another");
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
    if (c == '\n') {
      ++line;
      column = 1;
    } else {
      ++column;
    }
  }
}

/// Builds the document from the parser's events. Open containers sit on a stack of pointers;
/// a container only grows while it is the innermost open one, so the pointers to the
/// enclosing ones stay valid. Object members are appended to the ordered map's vector
/// directly: the key set of each open object has already rejected repeats, and the map's own
/// insertion would search its members linearly.
class DocumentBuilder final : public nlohmann::json_sax<Json> {
 public:
  explicit DocumentBuilder(const std::string& source) : source_(source) {}

  bool null() override { return add(Json(nullptr)); }
  bool boolean(bool value) override { return add(Json(value)); }
  bool number_integer(number_integer_t value) override { return add(Json(value)); }
  bool number_unsigned(number_unsigned_t value) override { return add(Json(value)); }
  bool number_float(number_float_t value, const string_t&) override { return add(Json(value)); }
  bool string(string_t& value) override { return add(Json(std::move(value))); }
  bool binary(binary_t& value) override { return add(Json::binary(std::move(value))); }

  bool start_object(std::size_t) override {
    open_.push_back(place(Json::object()));
    keys_.emplace_back();
    return true;
  }
  bool key(string_t& key) override {
    if (!keys_.back().insert(key).second)
      throw InputError(oneLine(source_ + ": key \"" + key + "\" appears twice in one object"));
    pendingKey_ = std::move(key);
    return true;
  }
  bool end_object() override {
    open_.pop_back();
    keys_.pop_back();
    return true;
  }
  bool start_array(std::size_t) override {
    open_.push_back(place(Json::array()));
    return true;
  }
  bool end_array() override {
    open_.pop_back();
    return true;
  }

  bool parse_error(std::size_t position, const std::string& lastToken,
                   const nlohmann::detail::exception& error) override {
    errorIsSyntax_ = error.id >= 100 && error.id < 200;  // parse_error ids; 406 is a range error
    // A syntax error is placed where the parser stopped (the position counts from 1 and
    // points just past the offending character); a number out of range at its start.
    const std::size_t back = errorIsSyntax_ ? 1 : lastToken.size();
    errorOffset_ = position >= back ? position - back : 0;
    errorMessage_ = error.what();
    return false;
  }

  [[nodiscard]] Json& root() { return root_; }
  /// Byte offset (from 0) of the error in the text.
  [[nodiscard]] std::size_t errorOffset() const { return errorOffset_; }
  [[nodiscard]] bool errorIsSyntax() const { return errorIsSyntax_; }
  [[nodiscard]] const std::string& errorMessage() const { return errorMessage_; }

 private:
  /// Stores `value` where the document expects the next value and returns its address.
  Json* place(Json value) {
    if (open_.empty()) {
      root_ = std::move(value);
      return &root_;
    }
    Json& parent = *open_.back();
    if (parent.is_array()) {
      auto& elements = parent.get_ref<Json::array_t&>();
      elements.push_back(std::move(value));
      return &elements.back();
    }
    Json::object_t::Container& members = parent.get_ref<Json::object_t&>();
    members.emplace_back(std::move(pendingKey_), std::move(value));
    return &members.back().second;
  }
  bool add(Json value) {
    (void)place(std::move(value));
    return true;
  }

  const std::string& source_;
  Json root_;
  std::vector<Json*> open_;
  std::vector<std::unordered_set<std::string>> keys_;  // keys seen in each open object
  std::string pendingKey_;
  std::size_t errorOffset_ = 0;
  bool errorIsSyntax_ = true;
  std::string errorMessage_;
};

/// The parser's reason without its "[json.exception...] parse error at line L, column C: "
/// prefix (the position is recomputed from the byte offset), on one line.
std::string reasonOf(std::string message) {
  std::size_t start = message.find("] ");
  start = start == std::string::npos ? 0 : start + 2;
  const std::size_t at = message.find("parse error", start);
  if (at != std::string::npos) {
    const std::size_t colon = message.find(": ", at);
    if (colon != std::string::npos) start = colon + 2;
  }
  message = message.substr(start);
  std::replace(message.begin(), message.end(), '\n', ' ');
  return message;
}

}  // namespace

std::string oneLine(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    const auto byte = static_cast<unsigned char>(c);
    if (byte >= 0x20 && byte != 0x7f) {
      out += c;
    } else if (c == '\n') {
      out += "\\n";
    } else if (c == '\r') {
      out += "\\r";
    } else if (c == '\t') {
      out += "\\t";
    } else {
      char escape[8];
      std::snprintf(escape, sizeof escape, "\\u%04x", byte);
      out += escape;
    }
  }
  return out;
}

std::pair<std::size_t, std::size_t> lineAndColumn(std::string_view text, std::size_t offset) {
  offset = std::min(offset, text.size());
  const std::string_view before = text.substr(0, offset);
  const std::size_t line =
      1 + static_cast<std::size_t>(std::count(before.begin(), before.end(), '\n'));
  const std::size_t lastNewline = before.rfind('\n');
  const std::size_t column =
      lastNewline == std::string_view::npos ? offset + 1 : offset - lastNewline;
  return {line, column};
}

Json parseStrictJson(std::string_view text, const std::string& source, std::size_t maxDepth) {
  checkDepth(text, source, maxDepth);
  DocumentBuilder builder(source);
  if (!Json::sax_parse(text.begin(), text.end(), &builder)) {
    const auto [line, column] = lineAndColumn(text, builder.errorOffset());
    throw InputError(source + (builder.errorIsSyntax() ? ": JSON syntax error" : ": JSON error") +
                     " at line " + std::to_string(line) + ", column " + std::to_string(column) +
                     ": " + reasonOf(builder.errorMessage()));
  }
  return std::move(builder.root());
}

}  // namespace voxcut::detail
