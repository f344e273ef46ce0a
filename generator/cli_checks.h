// Validators for numeric command-line flags: each refuses bad text with one line that says what
// was expected, in the words the docs use ("expected a whole number from 1 to 64, got 1e3").
#pragma once

#include <CLI/CLI.hpp>

#include <cstdint>
#include <string>

namespace dg {

// A number in [lo, hi]; NaN and infinities refused (CLI::Range lets NaN through: no comparison with
// it is true).
CLI::Validator numberIn(double lo, double hi);

// A whole number in [lo, hi], written in decimal digits with an optional sign ("1e3", "5.0" and
// "0x10" are refused rather than read as something the user may not have meant).
CLI::Validator wholeNumberIn(std::int64_t lo, std::int64_t hi);

// Any finite number (the range is checked where the value is used).
CLI::Validator finiteNumber();

// A path that is not the empty string (an empty --out fell back to the default folder without a
// word, an empty --pairs was ignored).
CLI::Validator nonEmptyPath();

}  // namespace dg
