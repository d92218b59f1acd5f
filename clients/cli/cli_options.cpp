#include "cli_options.h"

#include <algorithm>
#include <charconv>
#include <cmath>

namespace gvd::cli {

std::optional<std::string> Args::value(const std::string& flag) const {
  auto it = flags.find(flag);
  if (it == flags.end() || it->second.empty()) return std::nullopt;
  return it->second.back();
}

int Args::int_value(const std::string& flag, int fallback) const {
  const auto v = value(flag);
  if (!v) return fallback;
  int out = 0;
  const auto [p, ec] = std::from_chars(v->data(), v->data() + v->size(), out);
  if (ec != std::errc() || p != v->data() + v->size()) {
    throw UsageError{flag + " expects an integer, got \"" + *v + "\""};
  }
  return out;
}

uint64_t Args::u64_value(const std::string& flag, uint64_t fallback) const {
  const auto v = value(flag);
  if (!v) return fallback;
  uint64_t out = 0;
  const auto [p, ec] = std::from_chars(v->data(), v->data() + v->size(), out);
  if (ec != std::errc() || p != v->data() + v->size()) {
    throw UsageError{flag + " expects a non-negative integer, got \"" + *v + "\""};
  }
  return out;
}

std::optional<std::vector<double>> Args::numbers(const std::string& flag) const {
  const auto v = value(flag);
  if (!v) return std::nullopt;
  std::vector<double> out;
  size_t start = 0;
  while (start <= v->size()) {
    size_t end = v->find(',', start);
    if (end == std::string::npos) end = v->size();
    const std::string item = v->substr(start, end - start);
    double d = 0;
    const auto [p, ec] = std::from_chars(item.data(), item.data() + item.size(), d);
    if (item.empty() || ec != std::errc() || p != item.data() + item.size() || !std::isfinite(d)) {
      throw UsageError{flag + " expects comma-separated numbers, got \"" + *v + "\""};
    }
    out.push_back(d);
    start = end + 1;
  }
  return out;
}

std::string required_value(const Args& args, const std::string& flag) {
  const auto v = args.value(flag);
  if (!v) throw UsageError{"missing " + flag};
  return *v;
}

std::vector<double> point_value(const std::string& flag, const std::string& text, int dimension) {
  Args one;
  one.flags[flag] = {text};
  std::vector<double> v = *one.numbers(flag);
  if (v.size() != static_cast<size_t>(dimension)) {
    throw UsageError{flag + " expects " + std::to_string(dimension) + " numbers for a " +
                     std::to_string(dimension) + "D result, got \"" + text + "\""};
  }
  return v;
}

Args parse_args(int argc, char** argv, int first, const std::vector<std::string>& with_value,
                const std::vector<std::string>& boolean) {
  Args args;
  auto known = [](const std::vector<std::string>& list, const std::string& f) {
    return std::find(list.begin(), list.end(), f) != list.end();
  };
  for (int i = first; i < argc; ++i) {
    std::string a = argv[i];
    if (a.size() > 1 && a[0] == '-' && !(a.size() > 1 && (std::isdigit(a[1]) || a[1] == '.'))) {
      std::string name = a, val;
      const size_t eq = a.find('=');
      const bool inline_value = eq != std::string::npos;
      if (inline_value) {
        name = a.substr(0, eq);
        val = a.substr(eq + 1);
      }
      if (known(with_value, name)) {
        if (!inline_value) {
          if (i + 1 >= argc) throw UsageError{name + " needs a value"};
          val = argv[++i];
        }
        args.flags[name].push_back(val);
      } else if (known(boolean, name) && !inline_value) {
        args.flags[name].push_back("");
      } else {
        throw UsageError{"unknown option " + name};
      }
    } else {
      args.positional.push_back(a);
    }
  }
  return args;
}

}  // namespace gvd::cli
