// User-facing errors: bad config, mesh, image or flag. One clear message naming the file, the place
// and what was expected; the CLI turns it into exit status 2. Internal invariant breaks are not
// InputErrors; they are bugs.
#pragma once
#include <stdexcept>
#include <string>

namespace dg {

// A message as one whole line: control characters that a bad file's bytes bring into it (a NUL
// would end it early, a newline or vertical tab break it) are shown as '?'. UTF-8 is kept.
inline std::string withoutControlCharacters(std::string s) {
  for (char& ch : s)
    if ((ch >= 0 && ch < 32) || ch == 127) ch = '?';
  return s;
}

class InputError : public std::runtime_error {
 public:
  // line and column are 1-based; 0 means "no position".
  InputError(std::string file, int line, int column, const std::string& what)
      : std::runtime_error(format(file, line, column, what)), file_(std::move(file)), line_(line),
        column_(column) {}
  InputError(std::string file, const std::string& what) : InputError(std::move(file), 0, 0, what) {}
  const std::string& file() const { return file_; }
  int line() const { return line_; }
  int column() const { return column_; }

 private:
  static std::string format(const std::string& f, int l, int c, const std::string& w) {
    std::string s = f;
    if (l > 0) s += ":" + std::to_string(l) + (c > 0 ? ":" + std::to_string(c) : "");
    return withoutControlCharacters((s.empty() ? std::string() : s + ": ") + w);
  }
  std::string file_;
  int line_, column_;
};

// A file that could not be written: a full disk, a folder without write permission or removed
// meanwhile. Not a bug, and the user's to fix, so it is reported as an InputError is: one line
// naming the file, exit status 2.
class WriteError : public InputError {
 public:
  using InputError::InputError;
};

constexpr int kExitInputError = 2;

}  // namespace dg
