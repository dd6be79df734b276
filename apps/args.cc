#include "apps/args.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>

#include "mapping/io/atomic_file.h"

namespace lcv::apps {

ArgParser::ArgParser(std::string usage, std::string description, std::string example)
    : usage_(std::move(usage)), description_(std::move(description)), example_(std::move(example)) {}

void ArgParser::AddOption(const std::string& flag, const std::string& value_name,
                          const std::string& help, const std::string& default_value) {
  options_[flag] = Option{value_name.empty() ? "VALUE" : value_name, help, default_value};
  option_order_.push_back(flag);
}

void ArgParser::AddSwitch(const std::string& flag, const std::string& help) {
  options_[flag] = Option{"", help, ""};
  option_order_.push_back(flag);
}

void ArgParser::AddPositional(const std::string& name, const std::string& help, bool required) {
  positional_specs_.push_back({name, help, required});
}

void ArgParser::AddPositionalList(const std::string& name, const std::string& help) {
  positional_specs_.push_back({name, help, true});
  last_positional_is_list_ = true;
}

std::vector<std::string> ArgParser::PositionalList(const std::string& name) const {
  if (!last_positional_is_list_ || positional_specs_.back().name != name) {
    throw UsageError("missing argument " + name + " (see --help)");
  }
  return positional_list_;
}

bool ArgParser::Parse(int argc, char** argv) {
  std::vector<std::string> positional;
  bool only_positional = false;
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    if (!only_positional && (arg == "-h" || arg == "--help")) {
      std::cout << Help();
      return false;
    }
    if (!only_positional && arg == "--") {
      only_positional = true;
      continue;
    }
    if (!only_positional && arg.size() > 2 && arg.compare(0, 2, "--") == 0) {
      std::string flag = arg;
      std::optional<std::string> inline_value;
      const auto eq = arg.find('=');
      if (eq != std::string::npos) {
        flag = arg.substr(0, eq);
        inline_value = arg.substr(eq + 1);
      }
      const auto it = options_.find(flag);
      if (it == options_.end()) {
        throw UsageError("unknown option " + flag + " (see --help)");
      }
      if (it->second.value_name.empty()) {  // switch
        if (inline_value) throw UsageError(flag + " takes no value");
        values_[flag].push_back("1");
        continue;
      }
      if (inline_value) {
        values_[flag].push_back(*inline_value);
      } else {
        if (i + 1 >= argc) throw UsageError(flag + " needs a value " + it->second.value_name);
        values_[flag].push_back(argv[++i]);
      }
      continue;
    }
    positional.push_back(arg);
  }
  if (last_positional_is_list_ && positional.size() >= positional_specs_.size()) {
    positional_list_.assign(positional.begin() + (positional_specs_.size() - 1), positional.end());
    positional.resize(positional_specs_.size());
  }
  if (positional.size() > positional_specs_.size()) {
    throw UsageError("unexpected argument '" + positional[positional_specs_.size()] +
                     "' (see --help)");
  }
  for (size_t k = 0; k < positional_specs_.size(); ++k) {
    if (k < positional.size()) {
      positionals_[positional_specs_[k].name] = positional[k];
    } else if (positional_specs_[k].required) {
      throw UsageError("missing argument " + positional_specs_[k].name + " (see --help)");
    }
  }
  return true;
}

bool ArgParser::Has(const std::string& flag) const { return values_.count(flag) > 0; }

std::optional<std::string> ArgParser::GetOptional(const std::string& flag) const {
  const auto v = values_.find(flag);
  if (v != values_.end()) return v->second.back();
  const auto o = options_.find(flag);
  if (o != options_.end() && !o->second.default_value.empty()) return o->second.default_value;
  return std::nullopt;
}

std::vector<std::string> ArgParser::GetAll(const std::string& flag) const {
  const auto v = values_.find(flag);
  if (v != values_.end()) return v->second;
  const auto o = options_.find(flag);
  if (o != options_.end() && !o->second.default_value.empty()) return {o->second.default_value};
  return {};
}

std::string ArgParser::Get(const std::string& flag) const {
  auto v = GetOptional(flag);
  if (!v) throw UsageError("missing required option " + flag + " (see --help)");
  return *v;
}

int ArgParser::GetInt(const std::string& flag) const {
  const std::string s = Get(flag);
  errno = 0;
  char* end = nullptr;
  const long v = std::strtol(s.c_str(), &end, 10);
  if (s.empty() || *end != '\0' || errno != 0 || v < -2147483647L || v > 2147483647L) {
    throw UsageError(flag + ": '" + s + "' is not an integer");
  }
  return static_cast<int>(v);
}

double ArgParser::GetDouble(const std::string& flag) const {
  const std::string s = Get(flag);
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (s.empty() || *end != '\0' || errno != 0 || !std::isfinite(v)) {
    throw UsageError(flag + ": '" + s + "' is not a finite number");
  }
  return v;
}

std::pair<int, int> ArgParser::GetSize(const std::string& flag, int min, int max) const {
  const std::string s = Get(flag);
  int cols = 0, rows = 0;
  char rest = 0;
  if (std::sscanf(s.c_str(), "%dx%d%c", &cols, &rows, &rest) != 2 || cols < min || rows < min ||
      cols > max || rows > max) {
    throw UsageError(flag + ": '" + s + "' is not a size WxH with " + std::to_string(min) +
                     " <= W, H <= " + std::to_string(max));
  }
  return {cols, rows};
}

std::uint64_t ArgParser::GetSeed(const std::string& flag) const {
  const std::string s = Get(flag);
  errno = 0;
  char* end = nullptr;
  const unsigned long long v = std::strtoull(s.c_str(), &end, 10);
  if (s.empty() || s[0] == '-' || *end != '\0' || errno != 0) {
    throw UsageError(flag + ": '" + s + "' is not a non-negative integer");
  }
  return v;
}

std::string ArgParser::Positional(const std::string& name) const {
  auto v = PositionalOptional(name);
  if (!v) throw UsageError("missing argument " + name + " (see --help)");
  return *v;
}

std::optional<std::string> ArgParser::PositionalOptional(const std::string& name) const {
  const auto it = positionals_.find(name);
  if (it == positionals_.end()) return std::nullopt;
  return it->second;
}

void ArgParser::CheckOutputs(const std::vector<std::string>& names) const {
  for (const std::string& name : names) {
    const bool is_flag = name.rfind("--", 0) == 0;
    const std::optional<std::string> path = is_flag ? GetOptional(name) : PositionalOptional(name);
    if (path) mapping::CheckOutputPath(*path, name);
  }
}

std::string ArgParser::Help() const {
  std::ostringstream out;
  out << "usage: " << usage_ << "\n\n" << description_ << "\n";
  if (!positional_specs_.empty()) {
    out << "\narguments:\n";
    for (const auto& p : positional_specs_) {
      out << "  " << p.name << (p.required ? "" : " (optional)") << "\n      " << p.help << "\n";
    }
  }
  out << "\noptions:\n  -h, --help\n      print this help and exit\n";
  for (const auto& flag : option_order_) {
    const Option& o = options_.at(flag);
    out << "  " << flag;
    if (!o.value_name.empty()) out << " " << o.value_name;
    out << "\n      " << o.help;
    if (!o.default_value.empty()) out << " (default: " << o.default_value << ")";
    out << "\n";
  }
  if (!example_.empty()) out << "\nexample:\n  " << example_ << "\n";
  return out.str();
}

}  // namespace lcv::apps
