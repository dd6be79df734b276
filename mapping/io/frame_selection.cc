#include "mapping/io/frame_selection.h"

#include <cerrno>
#include <cstdlib>

namespace lcv::mapping {
namespace {

// Parses a non-negative integer; empty text gives fallback.
bool ParseIndex(const std::string& text, std::optional<std::size_t>* out, std::string* error) {
  if (text.empty()) {
    out->reset();
    return true;
  }
  bool digits = true;
  for (const char c : text) digits &= c >= '0' && c <= '9';
  errno = 0;
  const unsigned long long value = digits ? std::strtoull(text.c_str(), nullptr, 10) : 0;
  if (!digits || errno != 0) {
    if (error) *error = "'" + text + "' is not a non-negative integer";
    return false;
  }
  *out = static_cast<std::size_t>(value);
  return true;
}

}  // namespace

std::optional<FrameSelection> FrameSelection::Parse(const std::string& text, std::string* error) {
  std::vector<std::string> parts(1);
  for (const char c : text) {
    if (c == ':') {
      parts.emplace_back();
    } else if (c != ' ') {
      parts.back() += c;
    }
  }
  if (parts.size() == 1 || parts.size() > 3) {
    if (error) {
      *error = "'" + text + "': expected START:END or START:END:STEP (e.g. 1::2 for odd frames)";
    }
    return std::nullopt;
  }
  FrameSelection selection;
  std::optional<std::size_t> start, end, step;
  if (!ParseIndex(parts[0], &start, error) || !ParseIndex(parts[1], &end, error)) {
    return std::nullopt;
  }
  if (parts.size() == 3 && !ParseIndex(parts[2], &step, error)) return std::nullopt;
  if (step && *step == 0) {
    if (error) *error = "'" + text + "': step must be >= 1";
    return std::nullopt;
  }
  selection.start = start.value_or(0);
  selection.end = end;
  selection.step = step.value_or(1);
  return selection;
}

std::vector<std::size_t> FrameSelection::Apply(std::size_t count) const {
  std::vector<std::size_t> indices;
  const std::size_t stop = end ? std::min(*end, count) : count;
  for (std::size_t i = start; i < stop; i += step) indices.push_back(i);
  return indices;
}

std::string FrameSelection::ToString() const {
  std::string text = std::to_string(start) + ":" + (end ? std::to_string(*end) : "");
  if (step != 1) text += ":" + std::to_string(step);
  return text;
}

}  // namespace lcv::mapping
