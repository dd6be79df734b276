#include "mapping/io/yaml_subset.h"

#include <cerrno>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "slam/util/error.h"

namespace lcv::mapping {
namespace {

using nlohmann::json;

// One logical line: comments stripped, flow collections spanning several physical lines joined.
struct Line {
  int number = 0;  // 1-based physical line number where it starts
  int indent = 0;  // leading spaces
  std::string text;  // without the indentation and trailing blanks
};

bool IsBlank(char c) { return c == ' ' || c == '\t' || c == '\r'; }

std::string TrimRight(const std::string& s) {
  size_t end = s.size();
  while (end > 0 && IsBlank(s[end - 1])) --end;
  return s.substr(0, end);
}

std::string Trim(const std::string& s) {
  size_t begin = 0;
  while (begin < s.size() && IsBlank(s[begin])) ++begin;
  return TrimRight(s.substr(begin));
}

class Parser {
 public:
  Parser(const std::string& text, const std::string& source_name) : source_(source_name) {
    Split(text);
  }

  json Parse() {
    if (lines_.empty()) return json();
    size_t index = 0;
    json root = ParseBlock(&index, lines_[0].indent);
    if (index < lines_.size()) Fail(lines_[index].number, "unexpected indentation");
    return root;
  }

 private:
  [[noreturn]] void Fail(int line, const std::string& what) const {
    throw InputError(source_, "line " + std::to_string(line) + ": " + what);
  }

  // Strips a comment (a '#' at the start or after a blank, outside quotes) and updates the
  // bracket depth of flow collections.
  std::string StripComment(const std::string& raw, int number, int* depth) const {
    char quote = 0;
    for (size_t i = 0; i < raw.size(); ++i) {
      const char c = raw[i];
      if (quote) {
        if (quote == '"' && c == '\\') {
          ++i;
        } else if (c == quote) {
          // '' inside a single-quoted string is an escaped quote.
          if (quote == '\'' && i + 1 < raw.size() && raw[i + 1] == '\'') {
            ++i;
          } else {
            quote = 0;
          }
        }
        continue;
      }
      // Quotes open a scalar only where a scalar may start.
      if ((c == '"' || c == '\'') && (i == 0 || IsBlank(raw[i - 1]) || raw[i - 1] == '[' ||
                                      raw[i - 1] == '{' || raw[i - 1] == ',' ||
                                      raw[i - 1] == ':' || raw[i - 1] == '-')) {
        quote = c;
      } else if (c == '#' && (i == 0 || IsBlank(raw[i - 1]))) {
        return TrimRight(raw.substr(0, i));
      } else if (c == '[' || c == '{') {
        ++*depth;
      } else if (c == ']' || c == '}') {
        --*depth;
        if (*depth < 0) Fail(number, std::string("unbalanced '") + c + "'");
      }
    }
    if (quote) Fail(number, std::string("unclosed ") + quote + " quote");
    return TrimRight(raw);
  }

  void Split(const std::string& text) {
    std::vector<std::string> raw_lines;
    size_t start = 0;
    while (start <= text.size()) {
      size_t end = text.find('\n', start);
      if (end == std::string::npos) end = text.size();
      raw_lines.push_back(text.substr(start, end - start));
      start = end + 1;
    }
    for (size_t i = 0; i < raw_lines.size(); ++i) {
      const std::string& raw = raw_lines[i];
      const int number = static_cast<int>(i) + 1;
      size_t indent = 0;
      while (indent < raw.size() && raw[indent] == ' ') ++indent;
      if (indent < raw.size() && raw[indent] == '\t') {
        // A tab after the indentation is only an error where it would be indentation.
        const std::string rest = Trim(raw);
        if (!rest.empty() && rest[0] != '#') Fail(number, "tab in indentation");
      }
      int depth = 0;
      std::string content = StripComment(raw.substr(indent), number, &depth);
      content = Trim(content);
      if (content.empty()) continue;
      if (lines_.empty() && content[0] == '%') continue;  // %YAML directive
      if (content == "---" || content.rfind("--- ", 0) == 0) {
        if (!lines_.empty()) Fail(number, "several YAML documents are not supported");
        content = Trim(content.substr(3));
        if (content.empty()) continue;
      }
      if (content == "...") break;
      // A flow collection continues until its brackets balance.
      while (depth > 0) {
        if (++i >= raw_lines.size()) Fail(number, "unclosed '[' or '{'");
        const std::string more = Trim(StripComment(raw_lines[i], static_cast<int>(i) + 1, &depth));
        if (!more.empty()) content += " " + more;
      }
      lines_.push_back(Line{number, static_cast<int>(indent), content});
    }
  }

  static bool IsSequenceItem(const std::string& text) {
    return text[0] == '-' && (text.size() == 1 || text[1] == ' ');
  }

  // Position of the ':' that ends a mapping key (followed by a blank or the end), outside
  // quotes and brackets; npos when the text is not `key: ...`.
  static size_t FindKeyColon(const std::string& text) {
    if (text.empty() || text[0] == '[' || text[0] == '{') return std::string::npos;
    char quote = 0;
    for (size_t i = 0; i < text.size(); ++i) {
      const char c = text[i];
      if (quote) {
        if (quote == '"' && c == '\\') {
          ++i;
        } else if (c == quote) {
          quote = 0;
        }
        continue;
      }
      if (i == 0 && (c == '"' || c == '\'')) {
        quote = c;
      } else if (c == ':' && (i + 1 == text.size() || text[i + 1] == ' ')) {
        return i;
      }
    }
    return std::string::npos;
  }

  json ParseBlock(size_t* index, int indent) {
    if (IsSequenceItem(lines_[*index].text)) return ParseSequence(index, indent);
    return ParseMapping(index, indent);
  }

  // Value of `key:` with nothing after the colon: a nested block, or null.
  json ParseNested(size_t* index, int parent_indent, bool allow_same_indent_sequence) {
    if (*index >= lines_.size()) return json();
    const Line& next = lines_[*index];
    if (next.indent > parent_indent) return ParseBlock(index, next.indent);
    // YAML allows "key:\n- a\n- b" with the dashes at the key's own indentation.
    if (allow_same_indent_sequence && next.indent == parent_indent && IsSequenceItem(next.text)) {
      return ParseSequence(index, parent_indent);
    }
    return json();
  }

  json ParseMapping(size_t* index, int indent) {
    json mapping = json::object();
    while (*index < lines_.size()) {
      const Line& line = lines_[*index];
      if (line.indent < indent) break;
      if (line.indent > indent) Fail(line.number, "unexpected indentation");
      if (IsSequenceItem(line.text)) break;  // "key:\n- a" handled by the caller
      const size_t colon = FindKeyColon(line.text);
      if (colon == std::string::npos) Fail(line.number, "expected 'key: value', got '" + line.text + "'");
      std::string key = Trim(line.text.substr(0, colon));
      if (!key.empty() && (key[0] == '"' || key[0] == '\'')) {
        size_t pos = 0;
        key = ParseQuoted(key, &pos, line.number);
        if (pos != Trim(line.text.substr(0, colon)).size()) Fail(line.number, "bad quoted key");
      }
      if (key.empty()) Fail(line.number, "empty key");
      if (key == "<<" || key[0] == '&' || key[0] == '*' || key[0] == '?') {
        Fail(line.number, "anchors, aliases and complex keys are not supported");
      }
      if (mapping.contains(key)) Fail(line.number, "duplicate key '" + key + "'");
      std::string rest = StripTag(Trim(line.text.substr(colon + 1)));
      const int number = line.number;
      ++*index;
      if (rest.empty()) {
        mapping[key] = ParseNested(index, indent, true);
      } else {
        mapping[key] = ParseInlineValue(rest, number);
      }
    }
    return mapping;
  }

  json ParseSequence(size_t* index, int indent) {
    json sequence = json::array();
    while (*index < lines_.size()) {
      Line& line = lines_[*index];
      if (line.indent < indent) break;
      if (line.indent > indent) Fail(line.number, "unexpected indentation");
      if (!IsSequenceItem(line.text)) break;
      size_t offset = 1;
      while (offset < line.text.size() && line.text[offset] == ' ') ++offset;
      const std::string rest = StripTag(line.text.substr(offset));
      if (rest.empty()) {
        ++*index;
        sequence.push_back(ParseNested(index, indent, false));
      } else if (IsSequenceItem(rest) || FindKeyColon(rest) != std::string::npos) {
        // "- key: value" or "- - x": the item is a block that starts on this line, indented
        // as far as its text.
        line.indent = indent + static_cast<int>(offset);
        line.text = rest;
        sequence.push_back(ParseBlock(index, line.indent));
      } else {
        const int number = line.number;
        ++*index;
        sequence.push_back(ParseInlineValue(rest, number));
      }
    }
    return sequence;
  }

  // Drops a leading tag such as "!!opencv-matrix".
  static std::string StripTag(const std::string& text) {
    if (text.empty() || text[0] != '!') return text;
    const size_t blank = text.find(' ');
    return blank == std::string::npos ? std::string() : Trim(text.substr(blank));
  }

  json ParseInlineValue(const std::string& text, int number) {
    if (text[0] == '&' || text[0] == '*') Fail(number, "anchors and aliases are not supported");
    if (text == "|" || text == ">" || text[0] == '|' || text[0] == '>') {
      Fail(number, "block scalars ('|', '>') are not supported");
    }
    size_t pos = 0;
    json value;
    if (text[0] == '[' || text[0] == '{') {
      value = ParseFlow(text, &pos, number);
    } else if (text[0] == '"' || text[0] == '\'') {
      value = ParseQuoted(text, &pos, number);
    } else {
      return PlainScalar(text);
    }
    while (pos < text.size() && IsBlank(text[pos])) ++pos;
    if (pos != text.size()) Fail(number, "unexpected text after value: '" + text.substr(pos) + "'");
    return value;
  }

  std::string ParseQuoted(const std::string& text, size_t* pos, int number) const {
    const char quote = text[*pos];
    std::string out;
    for (size_t i = *pos + 1; i < text.size(); ++i) {
      const char c = text[i];
      if (quote == '"' && c == '\\') {
        if (++i >= text.size()) break;
        switch (text[i]) {
          case 'n': out += '\n'; break;
          case 't': out += '\t'; break;
          case 'r': out += '\r'; break;
          case '0': out += '\0'; break;
          case '"': out += '"'; break;
          case '\\': out += '\\'; break;
          case '/': out += '/'; break;
          case 'b': out += '\b'; break;
          case 'f': out += '\f'; break;
          case 'u': {  // \uXXXX (what JSON writers emit for control characters), as UTF-8
            unsigned code = 0;
            for (int k = 0; k < 4; ++k) {
              const char h = ++i < text.size() ? text[i] : '\0';
              const int digit = (h >= '0' && h <= '9')   ? h - '0'
                                : (h >= 'a' && h <= 'f') ? h - 'a' + 10
                                : (h >= 'A' && h <= 'F') ? h - 'A' + 10
                                                         : -1;
              if (digit < 0) Fail(number, "bad \\u escape");
              code = code * 16 + static_cast<unsigned>(digit);
            }
            if (code < 0x80) {
              out += static_cast<char>(code);
            } else if (code < 0x800) {
              out += static_cast<char>(0xC0 | (code >> 6));
              out += static_cast<char>(0x80 | (code & 0x3F));
            } else {
              out += static_cast<char>(0xE0 | (code >> 12));
              out += static_cast<char>(0x80 | ((code >> 6) & 0x3F));
              out += static_cast<char>(0x80 | (code & 0x3F));
            }
            break;
          }
          default: Fail(number, std::string("unsupported escape '\\") + text[i] + "'");
        }
      } else if (c == quote) {
        if (quote == '\'' && i + 1 < text.size() && text[i + 1] == '\'') {
          out += '\'';
          ++i;
        } else {
          *pos = i + 1;
          return out;
        }
      } else {
        out += c;
      }
    }
    Fail(number, std::string("unclosed ") + quote + " quote");
  }

  void SkipBlanks(const std::string& text, size_t* pos) const {
    while (*pos < text.size() && IsBlank(text[*pos])) ++*pos;
  }

  // A flow scalar, sequence or mapping starting at *pos.
  json ParseFlow(const std::string& text, size_t* pos, int number) {
    SkipBlanks(text, pos);
    if (*pos >= text.size()) Fail(number, "unexpected end of flow collection");
    const char c = text[*pos];
    if (c == '"' || c == '\'') return ParseQuoted(text, pos, number);
    if (c == '[' || c == '{') {
      const bool is_sequence = c == '[';
      const char close = is_sequence ? ']' : '}';
      json out = is_sequence ? json::array() : json::object();
      ++*pos;
      while (true) {
        SkipBlanks(text, pos);
        if (*pos >= text.size()) Fail(number, std::string("missing '") + close + "'");
        if (text[*pos] == close) {
          ++*pos;
          return out;
        }
        if (is_sequence) {
          out.push_back(ParseFlow(text, pos, number));
        } else {
          json key = ParseFlow(text, pos, number);
          if (!key.is_string()) key = key.dump(-1, ' ', false, json::error_handler_t::replace);
          SkipBlanks(text, pos);
          if (*pos >= text.size() || text[*pos] != ':') Fail(number, "expected ':' in flow mapping");
          ++*pos;
          const std::string key_string = key.get<std::string>();
          if (out.contains(key_string)) Fail(number, "duplicate key '" + key_string + "'");
          out[key_string] = ParseFlow(text, pos, number);
        }
        SkipBlanks(text, pos);
        if (*pos < text.size() && text[*pos] == ',') {
          ++*pos;
        } else if (*pos >= text.size() || text[*pos] != close) {
          Fail(number, std::string("expected ',' or '") + close + "' in flow collection");
        }
      }
    }
    // Plain scalar inside a flow collection: up to , ] } or a ': '.
    const size_t begin = *pos;
    while (*pos < text.size()) {
      const char d = text[*pos];
      if (d == ',' || d == ']' || d == '}') break;
      if (d == ':' && (*pos + 1 == text.size() || text[*pos + 1] == ' ')) break;
      ++*pos;
    }
    return PlainScalar(Trim(text.substr(begin, *pos - begin)));
  }

  // null, booleans, integers, decimals, else the string itself.
  static json PlainScalar(const std::string& s) {
    if (s.empty() || s == "~" || s == "null" || s == "Null" || s == "NULL") return json();
    if (s == "true" || s == "True" || s == "TRUE") return true;
    if (s == "false" || s == "False" || s == "FALSE") return false;
    const char c0 = s[0];
    const bool may_be_number = (c0 >= '0' && c0 <= '9') ||
                               ((c0 == '-' || c0 == '+' || c0 == '.') && s.size() > 1 &&
                                ((s[1] >= '0' && s[1] <= '9') || s[1] == '.'));
    if (may_be_number) {
      bool integral = true;
      for (size_t i = (c0 == '-' || c0 == '+') ? 1 : 0; i < s.size(); ++i) {
        integral &= s[i] >= '0' && s[i] <= '9';
      }
      errno = 0;
      char* end = nullptr;
      if (integral) {
        const long long v = std::strtoll(s.c_str(), &end, 10);
        if (errno == 0 && *end == '\0') return static_cast<std::int64_t>(v);
      }
      errno = 0;
      const double d = std::strtod(s.c_str(), &end);
      if (*end == '\0' && errno == 0) return d;
    }
    return s;
  }

  std::string source_;
  std::vector<Line> lines_;
};

}  // namespace

nlohmann::json ParseYamlSubset(const std::string& text, const std::string& source_name) {
  return Parser(text, source_name).Parse();
}

}  // namespace lcv::mapping
