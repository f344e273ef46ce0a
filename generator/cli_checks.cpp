#include "generator/cli_checks.h"

#include <charconv>
#include <cmath>
#include <sstream>

namespace dg {
namespace {
std::string shortest(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

bool readDouble(const std::string& text, double& v) { return CLI::detail::lexical_cast(text, v); }
}  // namespace

CLI::Validator numberIn(double lo, double hi) {
  const std::string want = "a number from " + shortest(lo) + " to " + shortest(hi);
  return CLI::Validator(
      [=](std::string& text) {
        double v = 0;
        if (!readDouble(text, v) || !std::isfinite(v) || v < lo || v > hi) return "expected " + want + ", got " + text;
        return std::string();
      },
      want);
}

CLI::Validator wholeNumberIn(std::int64_t lo, std::int64_t hi) {
  const std::string want = "a whole number from " + std::to_string(lo) + " to " + std::to_string(hi);
  return CLI::Validator(
      [=](std::string& text) {
        const char* b = text.data();
        const char* e = b + text.size();
        if (b != e && *b == '+') ++b;  // from_chars takes '-' but not '+'
        std::int64_t v = 0;
        const auto r = std::from_chars(b, e, v);
        if (b == e || r.ec != std::errc() || r.ptr != e || v < lo || v > hi) return "expected " + want + ", got " + text;
        return std::string();
      },
      want);
}

CLI::Validator finiteNumber() {
  return CLI::Validator(
      [](std::string& text) {
        double v = 0;
        if (!readDouble(text, v) || !std::isfinite(v)) return "expected a number, got " + text;
        return std::string();
      },
      "a number");
}

CLI::Validator nonEmptyPath() {
  return CLI::Validator(
      [](std::string& text) { return text.empty() ? std::string("expected a path, got an empty one") : std::string(); },
      "");
}

}  // namespace dg
